"""Damping floors as constraints of the robust program: the roots near the floor, linearised.

The damping of a simple closed-loop root is a smooth function of the controller
coefficients: with ``Delta = Dm x + Dc``, a root ``p`` moves by ``dp/dx_k = -(Dm_k)(p) /
Delta'(p)``, and ``zeta = -Re s / |s|`` of its image ``s`` in the s-plane (``s = w0 p`` for a
continuous model, ``s = fs ln z`` for a sampled one, the exact map of the certificate) has
the gradient of the chain rule.  :func:`pole_rows` linearises, at the current point, every
root of every model whose damping is within ``NEAR`` of its floor (upper half-plane roots;
their conjugates follow), and the roots of the controller's ``S / s^k`` near
``controller_damping_min``; the program imposes them as linear rows inside a trust region
and the rounds repeat until no root is below its floor
(:meth:`robrst.synthesis.attempts.Run.linearised`).  The rows hold in every phase (they are
not scaled by ``gamma``).  The certificate has the final word.

(A sector test by the Routh array of the rotated product polynomial is exact, but of twice
the closed-loop degree and badly scaled where the floor is near a lightly damped
resonance: the linearised roots are well scaled there.)
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from robrst.core import region as pole_region
from robrst.synthesis._nlp import affine_controller, closed_loop_maps
from robrst.synthesis._timesamples import TimeRows

if TYPE_CHECKING:
    from robrst.synthesis._nlp import NLPSetup

__all__ = ["pole_rows", "worst_damping_ratio", "NEAR", "FLOOR_MARGIN"]

NEAR = 0.02            # roots damped less than floor + NEAR are linearised
FLOOR_MARGIN = 1e-3    # the rows hold the floor this much inside


def _polys(setup):
    """Per row ``(kind, model index, Pm, Pc, floor, fs)``: the polynomials whose roots are
    floored (each model's closed loop, then the controller's own)."""
    reg = setup.region
    out = []
    if reg is None:
        return out
    if reg.zeta is not None:
        cl = closed_loop_maps(setup)
        for j, (_, _, a, b) in enumerate(setup.models):
            (Dm, Dc), _ = cl(a, b)
            fs = setup.fs_of[j] if setup.fs_of else None
            out.append(("sector", j, Dm, Dc, reg.zeta, fs))
    if reg.ctrl_zeta is not None:
        Ls, s0, _ = affine_controller(setup)
        k = setup.integrators
        Lq, q = Ls[:len(s0) - k], s0[:len(s0) - k]
        if Lq.shape[0] >= 3:
            out.append(("controller_sector", None, Lq, q, reg.ctrl_zeta, None))
    return out


def _map(p, setup, fs):
    """The s-plane images of the scaled roots ``p`` and ``ds/dp``."""
    w = np.asarray(p, complex) * setup.w0
    if fs is None:
        return w, np.full(w.shape, setup.w0, complex)
    h = 2.0 * fs
    with np.errstate(all="ignore"):
        s = fs * np.log((h + w) / (h - w))
        ds = fs * setup.w0 * (1.0 / (h + w) + 1.0 / (h - w))
    return s, ds


def _dzeta(s):
    """``(d zeta / d sigma, d zeta / d omega)`` of ``zeta = -sigma / |s|``."""
    r3 = np.abs(s) ** 3
    return -(s.imag ** 2) / r3, s.real * s.imag / r3


def worst_damping_ratio(setup: NLPSetup, x: np.ndarray) -> float:
    """``max floor / zeta`` over the floored roots at ``x``.

    Parameters
    ----------
    setup : NLPSetup
        The program (its ``region``).
    x : numpy.ndarray
        The point.

    Returns
    -------
    float
        Above 1 where a root is below its floor; 0 when nothing is floored.
    """
    worst = 0.0
    xc = np.asarray(x, float)
    for kind, j, Pm, Pc, floor, fs in _polys(setup):
        c = Pm @ xc[:Pm.shape[1]] + Pc
        if not (np.all(np.isfinite(c)) and c[0] != 0):
            return np.inf
        s, _ = _map(np.roots(c), setup, fs)
        z = pole_region.least_damping(s[np.isfinite(s)])
        worst = max(worst, floor / z if z > 0 else np.inf)
    return worst


def pole_rows(setup: NLPSetup, x: np.ndarray) -> TimeRows | None:
    """Linear rows ``A xc + c <= 0`` for the roots near their floor at ``x``.

    Parameters
    ----------
    setup : NLPSetup
        The program (its ``region``).
    x : numpy.ndarray
        The point linearised about.

    Returns
    -------
    TimeRows or None
        The rows (``g = 0``: never scaled by ``gamma``), ``None`` when no root is near.
    """
    xc = np.asarray(x, float)[:setup.n_x]
    A, c0, labels, keys = [], [], [], []
    for kind, j, Pm, Pc, floor, fs in _polys(setup):
        c = Pm @ xc + Pc
        if not (np.all(np.isfinite(c)) and c[0] != 0):
            continue
        p = np.roots(c)
        s, ds = _map(p, setup, fs)
        zeta = pole_region.damping_of(s)
        pick = np.flatnonzero((p.imag > 0) & np.isfinite(s) & (zeta < floor + NEAR))
        if not pick.size:
            continue
        dc = np.polyder(c)
        label, T = (setup.models[j][:2] if j is not None else (None, None))
        for i in pick:
            dpd = -np.array([np.polyval(Pm[:, k], p[i]) for k in range(Pm.shape[1])]) \
                / np.polyval(dc, p[i])
            dsd = ds[i] * dpd
            zs, zw = _dzeta(s[i])
            g = zs * dsd.real + zw * dsd.imag            # d zeta / d x
            target = min(0.999, floor + FLOOR_MARGIN)
            A.append(-g)
            c0.append(target - zeta[i] + g @ xc)
            labels.append((kind, label, T, int(i)))
            keys.append((kind, j, int(i)))
    if not A:
        return None
    return TimeRows(A=np.array(A), g=np.zeros(len(A)), c=np.array(c0), keys=tuple(keys),
                    labels=tuple(labels))
