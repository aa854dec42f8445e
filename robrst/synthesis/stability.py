"""The closed-loop stability rows of the robust program (:mod:`robrst.synthesis.exchange`).

Every model's closed-loop polynomial ``Delta = Dm xc + Dc`` must be Hurwitz: the program
imposes the first column of its Routh array (normalised by its leading coefficient,
:func:`robrst.synthesis.nlp.routh_column`) ``>= ROUTH_MIN``.  Like the grid points, these
rows are exchanged: the first round carries those of the models nearest to instability at
the start (:func:`initial_stability`), and a model whose rows a round's result violates
(:func:`routh_margins`) joins before the next.  A row left out holds strictly at the
final point, so its multiplier is zero there: the point is a KKT point of the program
with every row.  Most rows never bind (the peak bounds keep the loops well inside
stability), and each costs every IPOPT iteration of the round.

With a pole region (:class:`~robrst.synthesis.nlp.Region`, :mod:`robrst.core.region`)
the stability rows are those of the decay-shifted polynomial (``Delta(p - sigma)``, or
the disc map of a sampled model): decay implies stability.  The damping floor adds
*sector rows* (:func:`sector_rows`): the Routh column of ``E = Re(P)^2 + Im(P)^2``,
``P(p) = Delta(e^{j phi} p)``, a quadratic in the controller coefficients, exchanged the
same way (a model joins when its sector margin is short at the start or at a round's
result); the controller's own poles add one sector row of ``S / s^k``.
"""

import numpy as np

from dataclasses import dataclass

from robrst.core import region as pole_region
from robrst.synthesis.nlp import affine_controller, closed_loop_maps, routh_column

__all__ = ["ROUTH_MIN", "ROUTH_FIRST", "SECTOR_NEAR", "SectorRow", "stability_rows",
           "routh_margins", "initial_stability", "joined", "sector_rows", "sector_margins",
           "sector_dampings", "initial_sectors", "sectors_joined"]

ROUTH_MIN = 1e-9
ROUTH_FIRST = 4         # stability rows of the first round: models per closed-loop degree


SECTOR_NEAR = 0.01      # sector rows start imposed when the damping is this near the floor


def stability_rows(setup):
    """Per model ``(deg, Dm, Dc)`` of its closed-loop polynomial (decay-shifted with a
    region's ``sigma``: ``Delta(p - sigma)``, or for a sampled model the disc map,
    :func:`robrst.core.region.disc_matrix`)."""
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


@dataclass(frozen=True, eq=False)
class SectorRow:
    """One sector condition: the polynomial ``Pm x + Pc`` (degree ``deg``) has its roots
    damped more than ``zeta``; ``kind`` is ``"sector"`` (a model's closed loop, index
    ``model``) or ``"controller_sector"`` (the controller's own poles)."""

    deg: int
    Pm: np.ndarray
    Pc: np.ndarray
    zeta: float
    kind: str
    model: int = None

    def rotation(self):
        """``(cos, sin)`` of the rotation (:func:`robrst.core.region.rotation`)."""
        return pole_region.rotation(self.deg, self.zeta)


def sector_rows(setup):
    """Every sector row of ``setup`` (empty without a damping floor): one per model, then
    the controller's (:class:`SectorRow`)."""
    reg = setup.region
    out = []
    if reg is None:
        return out
    if reg.zeta is not None:
        cl = closed_loop_maps(setup)
        for j, (label, T, a, b) in enumerate(setup.models):
            fs = setup.fs_of[j] if setup.fs_of else None
            zeta = reg.zeta if fs is None else reg.zeta_sampled
            if zeta is None:
                continue
            (Dm, Dc), _ = cl(a, b)
            out.append(SectorRow(Dm.shape[0] - 1, Dm, Dc, zeta, "sector", j))
    if reg.ctrl_zeta is not None:
        Ls, s0, _ = affine_controller(setup)
        k = setup.integrators
        Lq, q = Ls[:len(s0) - k], s0[:len(s0) - k]
        if Lq.shape[0] >= 3:     # a complex pair needs degree 2
            out.append(SectorRow(Lq.shape[0] - 1, Lq, q, reg.ctrl_zeta, "controller_sector"))
    return out


def sector_margins(rows, x):
    """Per sector row, the least entry of the Routh column of ``E / E[0]`` at ``x``
    (``-inf`` where undefined)."""
    out = np.empty(len(rows))
    with np.errstate(all="ignore"):
        for i, r in enumerate(rows):
            c = r.Pm @ np.asarray(x, float)[:r.Pm.shape[1]] + r.Pc
            E = pole_region.sector_polynomial(c, r.zeta)
            col = routh_column(E / E[0])
            out[i] = col.min() if np.all(np.isfinite(col)) else -np.inf
    return out


def sector_dampings(rows, x):
    """Per sector row, the least damping of its polynomial's roots at ``x`` (``-inf`` where
    undefined)."""
    out = np.empty(len(rows))
    with np.errstate(all="ignore"):
        for i, r in enumerate(rows):
            c = r.Pm @ np.asarray(x, float)[:r.Pm.shape[1]] + r.Pc
            ok = np.all(np.isfinite(c)) and c[0] != 0
            out[i] = pole_region.least_damping(np.roots(c)) if ok else -np.inf
    return out


def initial_sectors(rows, x0):
    """The sector rows of the first round: those whose roots at ``x0`` are damped less than
    ``SECTOR_NEAR`` above their floor, and the controller's."""
    d = sector_dampings(rows, x0)
    return tuple(i for i, r in enumerate(rows)
                 if r.kind == "controller_sector" or not d[i] >= r.zeta + SECTOR_NEAR)


def sectors_joined(rows, chosen, x):
    """``chosen`` and every sector row left out whose roots ``x`` leaves below its floor."""
    if len(chosen) == len(rows):
        return tuple(chosen)
    d = sector_dampings(rows, x)
    new = [i for i in range(len(rows)) if i not in chosen and not d[i] >= rows[i].zeta]
    return tuple(sorted(set(chosen) | set(new)))


def routh_margins(rows, x):
    """Per model, the least entry of the Routh column of its closed-loop polynomial at
    ``x`` (normalised as the program's rows, :func:`robrst.synthesis.nlp.routh_column`);
    ``-inf`` where it is undefined."""
    out = np.empty(len(rows))
    xc = np.asarray(x, float)[:rows[0][1].shape[1]] if rows else None
    with np.errstate(all="ignore"):
        for j, (_, Dm, Dc) in enumerate(rows):
            c = Dm @ xc + Dc
            col = routh_column(c / c[0])
            out[j] = col.min() if np.all(np.isfinite(col)) else -np.inf
    return out


def initial_stability(rows, x0):
    """The models whose stability rows the first round carries: per closed-loop degree,
    every model if there are at most ``2 ROUTH_FIRST`` (a smaller group would save few
    rows and cost a build of its own), else the ``ROUTH_FIRST`` with the least Routh
    margin at ``x0`` (every one whose rows ``x0`` violates, in steps of ``ROUTH_FIRST``)."""
    margin = routh_margins(rows, x0)
    keep = []
    for deg in sorted({r[0] for r in rows}):
        mine = [j for j, r in enumerate(rows) if r[0] == deg]
        low = int(np.sum(~(margin[mine] >= ROUTH_MIN)))
        n = max(ROUTH_FIRST, -(-low // ROUTH_FIRST) * ROUTH_FIRST)
        keep += mine if len(mine) <= 2 * ROUTH_FIRST else \
            sorted(mine, key=lambda j: (margin[j], j))[:n]
    return tuple(sorted(keep))


def joined(rows, routh, x):
    """``routh`` (model indices) and every model left out whose rows ``x`` violates."""
    if len(routh) == len(rows):
        return tuple(routh)
    margin = routh_margins(rows, x)
    new = [j for j in range(len(rows)) if j not in routh and not margin[j] >= ROUTH_MIN]
    return tuple(sorted(set(routh) | set(new)))
