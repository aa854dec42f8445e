"""The closed-loop stability rows of the robust program (:mod:`robrst.synthesis.exchange`).

Every model's closed-loop polynomial ``Delta = Dm xc + Dc`` must be Hurwitz: the program
imposes the first column of its Routh array (normalised by its leading coefficient,
:func:`robrst.synthesis._nlp.routh_column`) ``>= ROUTH_MIN``.  Like the grid points, these
rows are exchanged: the first round carries those of the models nearest to instability at
the start (:func:`initial_stability`), and a model whose rows a round's result violates
(:func:`routh_margins`) joins before the next.  A row left out holds strictly at the
final point, so its multiplier is zero there: the point is a KKT point of the program
with every row.  Most rows never bind (the peak bounds keep the loops well inside
stability), and each costs every IPOPT iteration of the round.

With a pole region's decay rate (:class:`~robrst.synthesis._nlp.Region`,
:mod:`robrst.core.region`) the stability rows are those of the decay-shifted polynomial
(``Delta(p - sigma)``, or the disc map of a sampled model): decay implies stability.
Damping floors are linearised rows (:mod:`robrst.synthesis._polerows`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from robrst.core import region as pole_region
from robrst.synthesis._nlp import closed_loop_maps, routh_column

if TYPE_CHECKING:
    from robrst.synthesis._nlp import NLPSetup

__all__ = ["ROUTH_MIN", "ROUTH_FIRST", "stability_rows", "routh_margins", "initial_stability",
           "joined"]

ROUTH_MIN = 1e-9
ROUTH_FIRST = 4         # stability rows of the first round: models per closed-loop degree


def stability_rows(setup: NLPSetup) -> list[tuple]:
    """Per model ``(deg, Dm, Dc)`` of its closed-loop polynomial (decay-shifted with a
    region's ``sigma``: ``Delta(p - sigma)``, or for a sampled model the disc map,
    :func:`robrst.core.region.disc_matrix`).

    Parameters
    ----------
    setup : NLPSetup
        The program's data.

    Returns
    -------
    list of (int, numpy.ndarray, numpy.ndarray)
        ``Delta = Dm xc + Dc`` of degree ``deg``.
    """
    cl = closed_loop_maps(setup)
    reg = setup.region
    out = []
    for j, (label, T, a, b) in enumerate(setup.models):
        (Dm, Dc), _ = cl(a, b)
        deg = Dm.shape[0] - 1
        if reg is not None and reg.sigma:
            fs = setup.fs_of[j] if setup.fs_of else None
            M = (pole_region.shift_matrix(deg, reg.sigma) if fs is None else
                 pole_region.disc_matrix(deg, reg.sigma * setup.w0, fs, setup.w0))
            Dm, Dc = M @ Dm, M @ Dc
        out.append((deg, Dm, Dc))
    return out


def routh_margins(rows: Sequence[tuple], x: np.ndarray) -> list[float]:
    """Per model, the least entry of the Routh column of its closed-loop polynomial at
    ``x`` (normalised as the program's rows, :func:`robrst.synthesis._nlp.routh_column`);
    ``-inf`` where it is undefined.

    Parameters
    ----------
    rows : sequence
        :func:`stability_rows`.
    x : numpy.ndarray
        The decision vector.

    Returns
    -------
    list of float
    """
    out = np.empty(len(rows))
    xc = np.asarray(x, float)[:rows[0][1].shape[1]] if rows else None
    with np.errstate(all="ignore"):
        for j, (_, Dm, Dc) in enumerate(rows):
            c = Dm @ xc + Dc
            col = routh_column(c / c[0])
            out[j] = col.min() if np.all(np.isfinite(col)) else -np.inf
    return out


def initial_stability(rows: Sequence[tuple], x0: np.ndarray) -> tuple[int, ...]:
    """The models whose stability rows the first round carries: per closed-loop degree,
    every model if there are at most ``2 ROUTH_FIRST`` (a smaller group would save few
    rows and cost a build of its own), else the ``ROUTH_FIRST`` with the least Routh
    margin at ``x0`` (every one whose rows ``x0`` violates, in steps of ``ROUTH_FIRST``).

    Parameters
    ----------
    rows : sequence
        :func:`stability_rows`.
    x0 : numpy.ndarray
        The start.

    Returns
    -------
    tuple of int
        Model indices, sorted.
    """
    margin = routh_margins(rows, x0)
    keep = []
    for deg in sorted({r[0] for r in rows}):
        mine = [j for j, r in enumerate(rows) if r[0] == deg]
        low = int(np.sum(~(margin[mine] >= ROUTH_MIN)))
        n = max(ROUTH_FIRST, -(-low // ROUTH_FIRST) * ROUTH_FIRST)
        keep += mine if len(mine) <= 2 * ROUTH_FIRST else \
            sorted(mine, key=lambda j: (margin[j], j))[:n]
    return tuple(sorted(keep))


def joined(rows: Sequence[tuple], routh: Sequence[int], x: np.ndarray) -> tuple[int, ...]:
    """``routh`` (model indices) and every model left out whose rows ``x`` violates.

    Parameters
    ----------
    rows : sequence
        :func:`stability_rows`.
    routh : sequence of int
        The models imposed so far.
    x : numpy.ndarray
        A round's result.

    Returns
    -------
    tuple of int
        Sorted.
    """
    if len(routh) == len(rows):
        return tuple(routh)
    margin = routh_margins(rows, x)
    new = [j for j in range(len(rows)) if j not in routh and not margin[j] >= ROUTH_MIN]
    return tuple(sorted(set(routh) | set(new)))
