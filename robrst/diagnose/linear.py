"""Fast exact simulation of a linear plant on sampled data, and its plain re-fit.

A plant ``B(s)/A(s)`` driven through a zero-order hold is discretised exactly
(matrix exponential of the realisation in the scaled time ``p = s / w0``, so the
paper's 1..1e10 coefficients become O(1)), converted to second-order sections and
run with :func:`scipy.signal.sosfilt` from rest.  The same code re-fits the linear
model (relative changes of every scaled coefficient, output error on the training
records): the baseline a gap must beat before it is blamed on a nonlinear effect.
"""

import warnings
from dataclasses import dataclass

import numpy as np
from scipy import linalg, optimize, signal

from robrst import poly
from robrst.errors import SpecError
from robrst.plant import Plant

__all__ = ["LinearSim", "zoh_sos", "refit_linear", "LinearFit", "levenberg_marquardt", "param_std"]


def _scaled_ss(b, a):
    """Controllable canonical realisation of scaled monic ``b/a`` (deg b < deg a)."""
    n = len(a) - 1
    A = np.zeros((n, n))
    A[0, :] = -a[1:]
    if n > 1:
        A[1:, :-1] = np.eye(n - 1)
    B = np.zeros((n, 1))
    B[0, 0] = 1.0
    bb = np.concatenate([np.zeros(n + 1 - len(b)), b])
    D = bb[0]
    C = (bb[1:] - D * a[1:]).reshape(1, n)
    return A, B, C, D


def zoh_sos(B, A, fs):
    """Second-order sections of the ZOH discretisation of ``B(s)/A(s)`` at ``fs`` [Hz].

    Returns ``(sos, poles, lag)``: ``zpk2sos`` pads missing zeros at the origin, so
    the sections realise ``z**lag H(z)``; the output is delayed by ``lag`` samples
    afterwards.  ``poles`` are the discrete poles (for a stability check).  Raises
    :class:`SpecError` for an improper model.
    """
    A = poly.trim(A)
    B = poly.trim(B)
    if len(B) > len(A):
        raise SpecError("linear model is improper (deg B > deg A)")
    w0 = poly.natural_scale(A)
    a_s = poly.to_scaled(A, w0)
    b_s = poly.to_scaled(B, w0) / a_s[0]
    a_s = a_s / a_s[0]
    Ac, Bc, Cc, Dc = _scaled_ss(b_s, a_s)
    n = Ac.shape[0]
    h = w0 / fs
    M = np.zeros((n + 1, n + 1))
    M[:n, :n], M[:n, n:] = Ac * h, Bc * h
    E = linalg.expm(M)
    Ad, Bd = E[:n, :n], E[:n, n:]
    with warnings.catch_warnings():  # leading zero numerator terms are expected
        warnings.simplefilter("ignore", signal.BadCoefficients)
        z, p, k = signal.ss2zpk(Ad, Bd, Cc, np.array([[Dc]]))
    z = np.atleast_1d(z).ravel()
    z = z[np.isfinite(z)]
    return signal.zpk2sos(z, p, k), p, len(p) - len(z)


def _run(sos, lag, u):
    y = signal.sosfilt(sos, u)
    if lag:
        y = np.concatenate([np.zeros(lag), y[:-lag]])
    return y


@dataclass(frozen=True, eq=False)
class LinearSim:
    """Exact ZOH simulation of ``B/A`` from rest at ``fs`` [Hz].

    ``y[k]`` is sampled at the instant ``u[k]`` is applied, as in the twin: a
    strictly proper plant's ``y[k]`` depends on ``u`` up to ``k-1`` only.
    """

    B: np.ndarray
    A: np.ndarray
    fs: float

    def __post_init__(self):
        sos, p, lag = zoh_sos(self.B, self.A, self.fs)
        object.__setattr__(self, "sos", sos)
        object.__setattr__(self, "lag", lag)
        object.__setattr__(self, "stable", bool(np.all(np.abs(p) < 1.0)))

    @classmethod
    def of(cls, plant, fs):
        return cls(np.asarray(plant.B, float), np.asarray(plant.A, float), float(fs))

    def __call__(self, u):
        return _run(self.sos, self.lag, np.asarray(u, float))


@dataclass(frozen=True)
class LinearFit:
    """A re-fitted linear model and its training gap."""

    plant: Plant
    rel_change: dict      # coefficient name -> relative change of the scaled coefficient
    std: dict             # 1-sigma of the relative changes (Gauss–Newton)
    n_eval: int


def refit_linear(plant, records, fs, max_nfev=200):
    """Re-fit every coefficient of ``plant`` (same degrees) on ``records`` (output error).

    Parameters
    ----------
    plant : Plant
        Starting model (the simulation model under diagnosis).
    records : list of (u, y)
        Training inputs [V] and measured outputs [µm], each simulated from rest.

    Returns
    -------
    LinearFit
    """
    w0 = poly.natural_scale(plant.A)
    a0 = poly.to_scaled(plant.A, w0)
    b0 = poly.to_scaled(plant.B, w0)
    free_a = np.flatnonzero(a0[1:] != 0)
    free_b = np.flatnonzero(b0 != 0)
    idx = [("a", i) for i in free_a] + [("b", i) for i in free_b]
    scale = np.sqrt(sum(float(np.sum(y ** 2)) for _, y in records)) or 1.0

    def model(z):
        a, b = a0.copy(), b0.copy()
        for (kind, i), d in zip(idx, z):
            if kind == "a":
                a[1 + i] *= 1 + d
            else:
                b[i] *= 1 + d
        return a, b

    def resid(z):
        a, b = model(z)
        sos, p, lag = zoh_sos(poly.from_scaled(b, w0), poly.from_scaled(a, w0), fs)
        if np.any(np.abs(p) >= 1.0):
            return np.concatenate([np.ones_like(y) for _, y in records]) * 1e3
        return np.concatenate([_run(sos, lag, u) - y for u, y in records]) / scale

    z0 = np.zeros(len(idx))
    n = len(z0)
    res = levenberg_marquardt(resid, z0, np.full(n, -0.9), np.full(n, 3.0),
                              max_iter=max(2, max_nfev // (n + 1)))
    a, b = model(res.x)
    std = param_std(res)
    keys = [f"a{i + 1}" if kind == "a" else f"b{i}" for kind, i in idx]
    fitted = Plant(poly.from_scaled(b, w0), poly.from_scaled(a, w0), label=f"{plant.label}_refit",
                   temperature_C=plant.temperature_C)
    return LinearFit(plant=fitted, rel_change=dict(zip(keys, map(float, res.x))),
                     std=dict(zip(keys, map(float, std))), n_eval=int(res.nfev))


def param_std(res, rtol=1e-7):
    """1-sigma of least-squares parameters from the final Jacobian.

    ``cov = s^2 (J^T J)^-1`` through the SVD of ``J``; a parameter taking part in a
    direction the data do not determine (singular value below ``rtol`` x the largest)
    gets ``inf``, never a misleadingly small number.
    """
    J = np.asarray(res.jac, float)
    m, n = J.shape
    if n == 0:
        return np.zeros(0)
    s2 = 2 * res.cost / max(m - n, 1)
    _, sv, Vt = np.linalg.svd(J, full_matrices=False)
    if sv[0] == 0:
        return np.full(n, np.inf)
    good = sv > rtol * sv[0]
    var = (Vt[good].T ** 2) @ (1.0 / sv[good] ** 2) * s2
    d = np.sqrt(var)
    if not good.all():
        weak = (np.abs(Vt[~good]) > 1e-3).any(axis=0)
        d[weak] = np.inf
    return d


def levenberg_marquardt(fun, z0, lo, hi, max_iter=30, diff_step=1e-4, ftol=1e-10):
    """Bounded Levenberg–Marquardt on ``||fun(z)||^2`` with a forward-difference Jacobian.

    Works on the normal equations (``n x n``, ``n`` = a handful of parameters), so a
    residual of a million samples costs ``n + 1`` simulations per iteration and no
    factorisation of the tall Jacobian.  Steps are projected onto the bounds.
    Returns a :class:`scipy.optimize.OptimizeResult` with ``x``, ``fun``, ``jac``,
    ``cost`` (half the squared norm) and ``nfev``.
    """
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    z = np.clip(np.asarray(z0, float), lo, hi)
    r = fun(z)
    cost, nfev, lam = float(r @ r), 1, 1e-3
    J = None
    for _ in range(max_iter):
        cols = []
        for j in range(z.size):
            h = diff_step * max(1.0, abs(z[j]))
            if z[j] + h > hi[j]:
                h = -h
            zj = z.copy()
            zj[j] += h
            cols.append((fun(zj) - r) / h)
        nfev += z.size
        J = np.column_stack(cols)
        H, g = J.T @ J, J.T @ r
        d = np.maximum(np.diag(H), 1e-12 * max(np.max(np.diag(H)), 1e-300))
        improved = False
        while lam < 1e10:
            step = np.linalg.solve(H + lam * np.diag(d), -g)
            zn = np.clip(z + step, lo, hi)
            rn = fun(zn)
            nfev += 1
            cn = float(rn @ rn)
            if np.isfinite(cn) and cn < cost:
                improved = True
                done = cost - cn <= ftol * cost
                z, r, cost, lam = zn, rn, cn, max(lam / 5, 1e-12)
                break
            lam *= 4
        if not improved or done:
            break
    return optimize.OptimizeResult(x=z, fun=r, jac=J, cost=0.5 * cost, nfev=nfev)
