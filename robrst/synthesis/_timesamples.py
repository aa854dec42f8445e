"""Reference-step specs as constraints of the robust program: time samples, exchanged.

A reference step's output ``y = B T / Delta`` and control voltage ``u = A T / Delta`` (times
the step ``step_um``) are smooth functions of the controller coefficients, but not
polynomial ones: the program sees them as *linear rows* at a few time samples, the
response's value and its gradient at the current point (sequential linearisation inside
a trust region), and the samples are exchanged like the frequency points of the peak
bounds (:mod:`robrst.synthesis.exchange`):

* at the current point every model's response is evaluated exactly on a dense grid (the
  zero-order-hold recursion of its realisation, continuous loop; the discrete loop at its
  samples for a sampled model), over twice the longer of the settling time and the spec;
* a sample joins the active set where a spec is violated or nearly so: the local maxima
  of ``y - 1`` (overshoot, ``y - 1 <= overshoot``), of ``|y - 1|`` after the settling
  time (``|y - 1| <= 0.02``) and of ``|u|`` (``|u| step <= step_u_max``);
* every active sample is linearised at the point (exact values, forward differences of
  the exact value for the gradient) and imposed; the program is solved again inside a
  trust region around the point, and the loop repeats until no sample is violated.

In the soft-goal phase the rows scale with ``gamma`` (the worst normalised spec ratio),
so "best achievable" is the optimum of the time specs with the others.  The final word is
the certificate's (:mod:`robrst.certificate.steps`), on every model and the sweep.

With ``T_mode = "reference_model"`` the reference path is designed after the feedback
(:mod:`robrst.synthesis.tracking`): its time specs are not imposed here.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from robrst.core import lti, poly
from robrst.certificate.steps import SETTLING_BAND, step_metrics
from robrst.synthesis._nlp import closed_loop_maps

if TYPE_CHECKING:
    from robrst.problem.records import Problem
    from robrst.synthesis._nlp import NLPSetup

__all__ = ["TimeSpecs", "TimeRows", "time_specs", "time_rows", "worst_time_ratio",
           "TIME_MARGIN"]

TIME_MARGIN = 0.99      # the rows hold the specs 1 % inside the certificate's bounds
GRID_POINTS = 3000      # dense grid per continuous response
MAX_SAMPLES = 20000     # longest discrete response scanned
PER_SPEC = 3            # active samples added per model, spec and round
NEAR = 0.8              # a local extremum above this share of its bound joins


@dataclass(frozen=True)
class TimeSpecs:
    """The reference-step specs in the program's units (time scaled by ``w0``).

    Parameters
    ----------
    overshoot : float, optional
        ``overshoot_max_pct / 100``.
    settling : float, optional
        The settling time, scaled.
    u_max : float, optional
        Peak ``|u|`` [V].
    step_um : float
        The reference step [µm].
    w0 : float
        The time scale [rad/s].
    """

    overshoot: float = None      # fraction (overshoot_max_pct / 100)
    settling: float = None       # scaled time
    u_max: float = None          # V
    step_um: float = 1.0
    w0: float = 1.0


@dataclass(frozen=True, eq=False)
class TimeRows:
    """Linear rows ``A xc + g gamma + c <= 0`` with their samples.

    Parameters
    ----------
    A : numpy.ndarray
        ``(rows, nx)``.
    g : numpy.ndarray
        Coefficients of ``gamma`` (soft and restoration phases; 0: never scaled).
    c : numpy.ndarray
        Constants.
    keys : tuple
        Per row ``(model index, kind, scaled time, sign)`` with ``kind`` ``"overshoot"``,
        ``"settling"`` or ``"u"`` (a root's row: ``(kind, model, root index)``).
    labels : tuple
        Per row the program's constraint label.
    """

    A: np.ndarray
    g: np.ndarray
    c: np.ndarray
    keys: tuple
    labels: tuple


def time_specs(problem: Problem, w0: float) -> TimeSpecs | None:
    """The problem's reference-step specs for the program.

    Parameters
    ----------
    problem : Problem
        The problem.
    w0 : float
        The program's frequency scale [rad/s].

    Returns
    -------
    TimeSpecs or None
        ``None``: no time-domain spec, or a 2-DOF reference path designed afterwards.
    """
    sp = problem.specs
    if not sp.time_domain or problem.controller.T_mode == "reference_model":
        return None
    return TimeSpecs(
        overshoot=None if sp.overshoot_max_pct is None else sp.overshoot_max_pct / 100.0,
        settling=None if sp.settling_time_max_s is None else sp.settling_time_max_s * w0,
        u_max=sp.step_u_max_V, step_um=sp.step_um, w0=w0)


class _Response:
    """The step responses ``y`` and ``u`` of one model at one controller vector."""

    def __init__(self, setup, j, x, maps):
        (Dm, Dc), nums = maps
        xc = np.asarray(x, float)[:Dm.shape[1]]
        D = poly.trim(Dm @ xc + Dc)
        Ny = nums["Ry"][0] @ xc + nums["Ry"][1]
        Nu = nums["AT"][0] @ xc + nums["AT"][1]
        self.fs = setup.fs_of[j] if setup.fs_of else None
        sc = poly.Scaling.natural(D)
        self.w1 = sc.w0        # the realisation's own time scale
        A, B, C, d = lti.companion(Ny, D, sc)
        _, _, Cu, du = lti.companion(Nu, D, sc)
        self.A, self.B = A, B
        self.C, self.d = np.vstack([np.atleast_2d(C), np.atleast_2d(Cu)]), np.array([d, du])
        self.dt = None
        if self.fs is not None:          # the discrete loop (bilinear: the sampled loop's z)
            h = self.w1 * setup.w0 / self.fs
            n = A.shape[0]
            ima = np.eye(n) - 0.5 * h * A
            self.Ad = np.linalg.solve(ima, np.eye(n) + 0.5 * h * A)
            Bd = np.linalg.solve(ima, h * B.reshape(-1, 1))
            self.dd = self.d + 0.5 * (self.C @ Bd).ravel()
            self.Bd = Bd.ravel()
            self.dt = setup.w0 / self.fs   # the sample period in program time

    def grid(self, horizon):
        """``(tau, y, u)`` on a dense grid (all samples of a discrete loop) up to
        ``horizon`` (program time)."""
        import scipy.linalg as sla   # only with time-domain specs (which need it anyway)

        n = self.A.shape[0]
        if self.fs is None:
            tau = np.linspace(0.0, horizon, GRID_POINTS)
            h = (tau[1] - tau[0]) * self.w1
            M = sla.expm(np.block([[self.A * h, self.B.reshape(-1, 1) * h],
                                   [np.zeros((1, n + 1))]]))
            Phi, Gam, d = M[:n, :n], M[:n, n], self.d
        else:
            k = int(min(MAX_SAMPLES, max(2, np.ceil(horizon / self.dt))))
            tau = np.arange(k) * self.dt
            Phi, Gam, d = self.Ad, self.Bd, self.dd
        X = np.zeros((len(tau), n))
        for i in range(1, len(tau)):
            X[i] = Phi @ X[i - 1] + Gam
        out = X @ self.C.T + d
        return tau, out[:, 0], out[:, 1]

    def at(self, taus):
        """``(y, u)`` at the program times ``taus`` (exact)."""
        import scipy.linalg as sla

        n = self.A.shape[0]
        out = np.zeros((len(taus), 2))
        for i, t in enumerate(taus):
            if self.fs is None:
                h = t * self.w1
                M = sla.expm(np.block([[self.A * h, self.B.reshape(-1, 1) * h],
                                       [np.zeros((1, n + 1))]]))
                out[i] = self.C @ M[:n, n] + self.d
            else:
                k = int(round(t / self.dt))
                x = np.zeros(n)
                P = np.linalg.matrix_power(self.Ad, k) if k else np.eye(n)
                x = np.linalg.solve(np.eye(n) - self.Ad, (np.eye(n) - P) @ self.Bd) if k else x
                out[i] = self.C @ x + self.dd
        return out[:, 0], out[:, 1]


def _horizon(resp, spec, maps, x):
    """Twice the longer of the settling time (exact, :func:`step_metrics`) and the spec."""
    (Dm, Dc), nums = maps
    xc = np.asarray(x, float)[:Dm.shape[1]]
    D = poly.trim(Dm @ xc + Dc)
    N = nums["Ry"][0] @ xc + nums["Ry"][1]
    try:
        ts = step_metrics(N, D).settling_time_s      # in program time (scaled polynomials)
    except (ValueError, np.linalg.LinAlgError):
        ts = np.nan
    if not np.isfinite(ts) or ts <= 0:
        ts = 50.0 / max(resp.w1, 1e-12)
    return 2.0 * max(ts, spec.settling or 0.0)


def _peaks(r):
    """Indices of the local maxima of ``r`` (ends included)."""
    if r.size < 3:
        return np.arange(r.size)
    left = np.r_[True, r[1:] > r[:-1]]
    right = np.r_[r[:-1] >= r[1:], True]
    return np.flatnonzero(left & right)


def _candidates(spec, tau, y, u, near=NEAR):
    """The samples to impose on one model: ``[(kind, tau, sign, ratio)]``."""
    out = []
    if spec.overshoot is not None:
        r = (y - 1.0) / max(spec.overshoot, 1e-9)
        ks = _peaks(r)
        ks = ks[r[ks] > near]
        out += [("overshoot", tau[k], 1.0, r[k]) for k in ks[np.argsort(-r[ks])][:PER_SPEC]]
    if spec.settling is not None:
        late = tau >= spec.settling
        for sign in (1.0, -1.0):
            r = np.where(late, sign * (y - 1.0) / SETTLING_BAND, -np.inf)
            ks = _peaks(r)
            ks = ks[r[ks] > near]
            out += [("settling", tau[k], sign, r[k]) for k in ks[np.argsort(-r[ks])][:PER_SPEC]]
    if spec.u_max is not None:
        for sign in (1.0, -1.0):
            r = sign * u * spec.step_um / spec.u_max
            ks = _peaks(r)
            ks = ks[r[ks] > near]
            out += [("u", tau[k], sign, r[k]) for k in ks[np.argsort(-r[ks])][:PER_SPEC]]
    return out


def _row_of(kind, sign, spec, y, u):
    """``(value, bound)`` of one sample: the row is ``value - bound gamma <= 0``."""
    if kind == "overshoot":
        return y - 1.0, spec.overshoot * TIME_MARGIN
    if kind == "settling":
        return sign * (y - 1.0), SETTLING_BAND * TIME_MARGIN
    return sign * u * spec.step_um, spec.u_max * TIME_MARGIN


def worst_time_ratio(setup: NLPSetup, x: np.ndarray, spec: TimeSpecs,
                     near: float = NEAR) -> tuple[float, dict]:
    """The worst sample ratio (value over bound) on a dense grid of every model.

    Parameters
    ----------
    setup : NLPSetup
        The program.
    x : numpy.ndarray
        The point.
    spec : TimeSpecs
        The specs.
    near : float
        A local extremum above this share of its bound is a candidate sample.

    Returns
    -------
    (float, dict)
        The ratio and the candidate samples per model:
        ``{model: [(kind, tau, sign, ratio)]}``.
    """
    cl = _closed_loop_maps_t(setup)
    worst, found = 0.0, {}
    for j, (_, _, a, b) in enumerate(setup.models):
        maps = cl(a, b)
        try:
            resp = _Response(setup, j, x, maps)
            tau, y, u = resp.grid(_horizon(resp, spec, maps, x))
        except (ValueError, np.linalg.LinAlgError):
            continue
        if not (np.all(np.isfinite(y)) and np.all(np.isfinite(u))):
            continue
        cands = _candidates(spec, tau, y, u, near)
        if cands:
            found[j] = cands
            worst = max(worst, max(c[3] for c in cands))
    return worst, found


def _closed_loop_maps_t(setup):
    """:func:`robrst.synthesis._nlp.closed_loop_maps` with the control voltage of a reference
    step, ``A T`` (key ``"AT"``)."""
    from robrst.synthesis._nlp import affine_controller, t_map

    cl = closed_loop_maps(setup)
    _, _, Lr = affine_controller(setup)
    Lt, t0 = t_map(setup, Lr)

    def maps(a, b):
        D, nums = cl(a, b)
        n_out = D[0].shape[0]
        C = np.zeros((len(a) + Lt.shape[0] - 1, Lt.shape[0]))
        for i in range(Lt.shape[0]):
            C[i:i + len(a), i] = a
        M, m0 = C @ Lt, C @ t0
        pad = n_out - M.shape[0]
        nums = {**nums, "AT": (np.vstack([np.zeros((pad, M.shape[1])), M]),
                               np.concatenate([np.zeros(pad), m0]))}
        return D, nums

    return maps


def time_rows(setup: NLPSetup, x: np.ndarray, spec: TimeSpecs, keys: Sequence = (),
              found: dict | None = None, step: float = 1e-7,
              reach: float = 1.0) -> TimeRows | None:
    """The rows of the active samples ``keys`` and the new ``found`` ones at ``x``.

    A sample beyond its bound is asked to close ``reach`` of its excess this round (1: all
    of it; a smaller step keeps the linearised program feasible in the objective phase).

    Parameters
    ----------
    setup : NLPSetup
    x : ndarray
        The point (its controller part is linearised about).
    spec : TimeSpecs
    keys : sequence
        Samples active before (re-linearised here).
    found : dict, optional
        New candidates (:func:`worst_time_ratio`).
    step : float
        Relative forward-difference step.
    reach : float
        Share of a violated sample's excess the row removes.

    Returns
    -------
    TimeRows or None
    """
    allk = {(j, kind, float(t), float(sg)) for j, kind, t, sg in keys}
    for j, cands in (found or {}).items():
        allk |= {(j, kind, float(t), float(sg)) for kind, t, sg, _ in cands}
    if not allk:
        return None
    allk = sorted(allk)
    cl = _closed_loop_maps_t(setup)
    xc = np.asarray(x, float)[:setup.n_x]
    rows_A, rows_g, rows_c, labels = [], [], [], []
    for j in sorted({k[0] for k in allk}):
        mine = [k for k in allk if k[0] == j]
        taus = np.array([k[2] for k in mine])
        a, b = setup.models[j][2:]
        maps = cl(a, b)
        base = np.array(_Response(setup, j, xc, maps).at(taus))
        grads = np.zeros((2, len(taus), len(xc)))
        for i in range(len(xc)):
            h = step * max(1.0, abs(xc[i]))
            xp = xc.copy()
            xp[i] += h
            grads[:, :, i] = (np.array(_Response(setup, j, xp, maps).at(taus)) - base) / h
        label, T = setup.models[j][:2]
        for q, (_, kind, t, sg) in enumerate(mine):
            val, bound = _row_of(kind, sg, spec, base[0, q], base[1, q])
            bound = max(bound, val - reach * (val - bound))
            if kind == "overshoot":
                gv = grads[0, q]
            elif kind == "settling":
                gv = sg * grads[0, q]
            else:
                gv = sg * spec.step_um * grads[1, q]
            rows_A.append(gv)
            rows_c.append(val - gv @ xc)
            rows_g.append(-bound)
            labels.append(("time", label, T, float(t)))
    return TimeRows(A=np.array(rows_A), g=np.array(rows_g), c=np.array(rows_c),
                    keys=tuple(allk), labels=tuple(labels))
