"""Time-domain specs of a reference step, computed exactly from the closed-loop polynomials.

For a reference step the output is ``Tr = B T / Delta`` and the control voltage
``A T / Delta`` (:func:`robrst.rst.closed_loop`).  Their step responses are computed
from the scaled realisation of :mod:`robrst.lti` by its exact zero-order-hold
discretisation (a step input *is* held): exact at every time point, no ODE solver.
The time grid follows the closed-loop modes: it runs until every mode has decayed by
``e**-16`` and, in each stretch of time, holds at least ``POINTS_PER_RAD`` points per
radian of the fastest mode still alive, so every oscillation is resolved; states are
propagated by repeated doubling (``x[k + m] = Phi**m x[k] + S_m``), a handful of
matrix products for tens of thousands of points.  The largest sample and the last
exit from the 2 % band are then refined by exact evaluation between grid points.

The sampled loop (``fs``) is a loop in the bilinear variable (:mod:`robrst.sampled`);
mapping its realisation back with ``z = (1 + s/2fs)/(1 - s/2fs)`` gives the
discrete closed loop, whose step response at the sampling instants is computed the
same way (what the controller sees).

:func:`check` is called by :func:`robrst.certificate.check_model` for every model
of the certificate; :func:`step_metrics` is the public computation.
"""

from dataclasses import dataclass

import numpy as np

from robrst import lti, poly

__all__ = ["StepMetrics", "step_metrics", "step_metrics_many", "check", "KEYS", "SETTLING_BAND"]

SETTLING_BAND = 0.02
POINTS_PER_RAD = 4.0       # grid points per radian of the fastest live mode
DECAY = 16.0               # a mode is dead after exp(-16) of its initial size
MAX_POINTS = 400_000
KEYS = ("overshoot_pct", "settling_time_s", "step_u_peak_V")


@dataclass(frozen=True)
class StepMetrics:
    """Step response of ``N/D``: final value, peak (value, time), overshoot [%],
    2 % settling time [s], and the largest ``|y|`` (for the control voltage)."""

    final: float
    peak: float
    peak_time_s: float
    overshoot_pct: float
    settling_time_s: float
    max_abs: float


def _bilinear(A, B, C, d, h):
    """Discrete ``(Ad, Bd, Cd, dd)`` with ``G_d(z) = G(2/h (z - 1)/(z + 1))`` (scaled;
    one row of ``C`` and one ``d`` per output)."""
    n = A.shape[0]
    M = np.eye(n) - A * (h / 2)
    Ad = np.linalg.solve(M, np.eye(n) + A * (h / 2))
    Bd = np.linalg.solve(M, B) * h
    Cd = np.linalg.solve(M.T, C.T).T
    return Ad, Bd, Cd, d + (C @ Bd).ravel() / 2


def _propagate(Phi, G, x0, n):
    """States ``x[0..n]`` of ``x[k+1] = Phi x[k] + G`` by doubling (columns)."""
    X = np.empty((len(x0), n + 1))
    X[:, 0] = x0
    P, S, m = Phi, G, 1               # P = Phi**m, S = sum_{i<m} Phi**i G
    while m <= n:
        k = min(m, n + 1 - m)
        X[:, m:m + k] = P @ X[:, :k] + S[:, None]
        S = P @ S + S
        P = P @ P
        m *= 2
    return X


def _power(Phi, G, m):
    """``(Phi**m, sum_{i<m} Phi**i G)`` by binary powering."""
    P, S = np.eye(len(G)), np.zeros(len(G))
    Pk, Sk = Phi, G                    # Phi**(2**j), sum_{i<2**j} Phi**i G
    while m:
        if m & 1:
            P, S = Pk @ P, Pk @ S + Sk
        Sk = Pk @ Sk + Sk
        Pk = Pk @ Pk
        m >>= 1
    return P, S


def _segments(decay, speed, unit=None):
    """``[(t_end, step), ...]``: per stretch of time, a step resolving every live mode.

    ``decay`` and ``speed`` are each mode's decay rate and ``|log|`` rate (per time
    unit); a mode is live until ``DECAY / decay``.  With ``unit`` (discrete time) steps
    are whole multiples of it.
    """
    life = DECAY / np.maximum(decay, 1e-300)
    merged = []
    for t in np.unique(life):          # merge ends within a factor 4 (fewer segments)
        if merged and t < 4 * merged[-1]:
            merged[-1] = t
        else:
            merged.append(t)
    out, t0 = [], 0.0
    for t1 in merged:
        fast = float(np.max(speed[life > t0 * (1 + 1e-12)]))
        h = min(1.0 / (POINTS_PER_RAD * fast), (t1 - t0) / 16)
        if unit is not None:
            h = max(1.0, np.floor(h))
            t1 = np.ceil(t1)
        out.append((t1, h))
        t0 = t1
    total = sum((t1 - ta) / h for (t1, h), ta in zip(out, [0.0] + [t for t, _ in out[:-1]]))
    if total > MAX_POINTS:             # keep the cost bounded: coarser, uniformly
        f = total / MAX_POINTS
        out = [(t1, h * f if unit is None else np.ceil(h * f)) for t1, h in out]
    return out


class _Response:
    """Exact step response of ``N/D`` on a mode-adapted grid, refinable between points.

    Continuous: scaled time, steps by the exact ZOH of :mod:`robrst.lti`; discrete
    (``fs``): samples of the bilinear map of the same realisation, strides of whole
    samples.
    """

    def __init__(self, Ns, D, sc, fs=None):
        self.cache = {}
        A, B, C, d = lti.companion_outputs(Ns, D, sc)   # A, B depend on D only
        self.discrete = fs is not None
        if self.discrete:
            A, B, C, d = _bilinear(A, B, C, d, sc.w0 / fs)
            logz = np.log(np.linalg.eigvals(A).astype(complex))
            segs = _segments(-logz.real, np.abs(logz), unit=1)
            self.Ad, self.Bd = A, B.ravel()
        else:
            self.A, self.B = A, B
            lam = np.linalg.eigvals(A)
            segs = _segments(-lam.real, np.abs(lam))
        self.C, self.d = C, d
        n = A.shape[0]
        ts, Xs, x, t0 = [np.zeros(1)], [np.zeros((n, 1))], np.zeros(n), 0.0
        steps = []
        for t1, h in segs:
            n = max(1, int(np.ceil((t1 - t0) / h)))
            if not self.discrete:
                h = (t1 - t0) / n
            X = _propagate(*self._step(h), x, n)
            ts.append(t0 + h * np.arange(1, n + 1))
            Xs.append(X[:, 1:])
            steps.append(np.full(n, h))
            x, t0 = X[:, -1], t0 + n * h
        self.t, self.X = np.concatenate(ts), np.hstack(Xs)
        self.h = np.concatenate(steps)     # the exact step of each interval (t[i], t[i+1])
        self.Y = self.C @ self.X + self.d[:, None]   # one row per numerator

    def _step(self, h):
        """``(Phi, G)`` of one step ``h`` (scaled time, or whole samples), cached."""
        if h not in self.cache:
            if self.discrete:
                self.cache[h] = _power(self.Ad, self.Bd, int(h))
            else:
                Ad, _, Bd = lti.zoh_matrices(self.A, self.B, h, gamma=False)
                self.cache[h] = (Ad, Bd.ravel())
        return self.cache[h]

    def _fine(self, row, i, n_sub=256):
        """Times and outputs ``row`` on ``[t[i], t[i+1]]`` at up to ``n_sub`` times the
        resolution (the sub-step from the interval's exact step: intervals of one segment
        share one cached step matrix)."""
        h = float(self.h[i])
        if self.discrete:
            n_sub = int(round(h))
            if n_sub <= 1:
                return self.t[i:i + 2], self.Y[row, i:i + 2]
        X = _propagate(*self._step(h / n_sub if not self.discrete else 1.0), self.X[:, i], n_sub)
        return (self.t[i] + (h / n_sub) * np.arange(n_sub + 1),
                self.C[row] @ X + self.d[row])

    def extreme(self, row, sign=1.0):
        """Largest ``sign * y`` of output ``row`` and its time (refined between the grid
        points)."""
        i = int(np.argmax(sign * self.Y[row]))
        best, tbest = float(sign * self.Y[row, i]), float(self.t[i])
        for j in (i - 1, i):
            if 0 <= j < len(self.t) - 1:
                t, y = self._fine(row, j, 64)
                k = int(np.argmax(sign * y))
                v, tk = float(sign * y[k]), float(t[k])
                if not self.discrete and 0 < k < len(t) - 1:   # vertex of the parabola
                    a, b, c = sign * y[k - 1], sign * y[k], sign * y[k + 1]
                    den = a - 2 * b + c
                    if den < 0:
                        v = max(v, float(b - (a - c) ** 2 / (8 * den)))
                        tk = float(tk + 0.5 * (a - c) / den * (t[k + 1] - t[k]))
                if v > best:
                    best, tbest = v, tk
        return best, tbest

    def settling(self, row, final):
        """Last time ``|y - final| > 2 % |final|`` of output ``row`` (0 if never; the first
        time back in)."""
        tol = SETTLING_BAND * abs(final)
        out = np.flatnonzero(np.abs(self.Y[row] - final) > tol)
        if out.size == 0:
            return 0.0
        i = int(out[-1])
        if i + 1 >= len(self.t):
            return float(self.t[-1])
        t, y = self._fine(row, i)
        k = int(np.flatnonzero(np.abs(y - final) > tol)[-1])
        return float(t[min(k + 1, len(t) - 1)])


def _overshoot_pct(peak, final):
    """Overshoot [%] of a response whose largest value in the direction of ``final`` is
    ``peak`` (``inf`` for a zero final value)."""
    return 100.0 * max(0.0, (peak - abs(final)) / abs(final)) if final != 0 else np.inf


def _responses(Ns, D, fs):
    """The step responses of the trimmed ``Ns`` over the trimmed ``D`` (one realisation)
    and the factor from their time unit to seconds."""
    sc = poly.Scaling.natural(D)
    return _Response(Ns, D, sc, fs), (1.0 / sc.w0 if fs is None else 1.0 / fs)


def step_metrics(N, D, fs=None):
    """Exact step response figures of ``N(s)/D(s)`` (``D`` Hurwitz).

    Parameters
    ----------
    N, D : array_like
        Numerator and denominator in s, ``deg N <= deg D``.
    fs : float, optional
        Sample rate [Hz]: ``N/D`` is then a loop in the bilinear variable of
        :mod:`robrst.sampled` and the response is the discrete one at the samples.

    Returns
    -------
    StepMetrics
        Times in seconds.

    Examples
    --------
    >>> m = step_metrics([1.0], [1.0, 1.0, 1.0])     # wn = 1 rad/s, zeta = 0.5
    >>> round(m.overshoot_pct, 3), round(m.peak_time_s, 3)
    (16.303, 3.628)
    """
    return step_metrics_many([N], D, fs)[0]


def step_metrics_many(Ns, D, fs=None):
    """:func:`step_metrics` of several numerators over one denominator, sharing one
    realisation and one propagation of its states.

    Returns
    -------
    list of StepMetrics
    """
    Ns, D = [poly.trim(N) for N in Ns], poly.trim(D)
    r, to_s = _responses(Ns, D, fs)
    out = []
    for row, N in enumerate(Ns):
        final = float(N[-1] / D[-1])
        sgn = 1.0 if final >= 0 else -1.0
        peak, tp = r.extreme(row, sgn)
        low, _ = r.extreme(row, -sgn)
        out.append(StepMetrics(final=final, peak=sgn * peak, peak_time_s=tp * to_s,
                               overshoot_pct=_overshoot_pct(peak, final),
                               settling_time_s=r.settling(row, final) * to_s,
                               max_abs=max(abs(peak), abs(low))))
    return out


def check(plant, ctrl, cl, specs, rtol, fs=None):
    """Time-domain figures and failed specs of one closed loop (the certificate's hook).

    Parameters
    ----------
    plant : Plant
        The (possibly sampled-loop) plant.
    ctrl : RSTController
    cl : ClosedLoop
        :func:`robrst.rst.closed_loop` of ``plant`` and ``ctrl``.
    specs : Specs
    rtol : float
    fs : float, optional
        Sample rate of a sampled-loop plant.

    Returns
    -------
    record : dict
        ``overshoot_pct``, ``settling_time_s`` and ``step_u_peak_V`` (the largest
        ``|u|`` for a reference step of ``specs.step_um``).
    failed : list of (quantity, value, bound)
    """
    Ny, Nu = poly.trim(cl.nums["Tr"]), poly.trim(poly.pmul(plant.A, ctrl.T))
    D = poly.trim(cl.Delta)
    # one realisation for y and u; only the figures checked: y's peak and settling time,
    # the largest |u|
    r, to_s = _responses([Ny, Nu], D, fs)
    final = float(Ny[-1] / D[-1])
    peak = r.extreme(0, 1.0 if final >= 0 else -1.0)[0]
    u_max = max(abs(r.extreme(1, 1.0)[0]), abs(r.extreme(1, -1.0)[0]))
    rec = {"overshoot_pct": _overshoot_pct(peak, final),
           "settling_time_s": r.settling(0, final) * to_s,
           "step_u_peak_V": u_max * specs.step_um}
    failed = []
    for key, bound, atol in (("overshoot_pct", specs.overshoot_max_pct, 1e-6),
                             ("settling_time_s", specs.settling_time_max_s, 0.0),
                             ("step_u_peak_V", specs.step_u_max_V, 0.0)):
        if bound is not None and rec[key] > bound * (1 + rtol) + atol:
            failed.append((key, rec[key], bound))
    return rec, failed
