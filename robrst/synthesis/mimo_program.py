"""The joint robust program of a decentralised multi-axis RST controller (CasADi/IPOPT).

**Decision vector.**  Per axis ``i``, in the scaled variable ``p = s / w0``:
``S_i = p F(p) S_i'(p)`` with ``F`` the fixed roll-off and ``S_i'`` monic of degree
``d`` (its ``d`` lower coefficients free), ``R_i`` of degree ``deg S_i - relative degree``
(every coefficient free); ``x = [S_1', R_1, ..., S_m', R_m]`` and the ratio ``t`` of the
soft phase (:class:`AxisParam` maps a controller to ``x`` and back).

**Constraints on a frequency grid.**  At a point ``nu`` of a model (the continuous loop,
or the sampled loop's w-plane), with ``M = G(j nu) W(j nu)`` numeric and
``P = diag(S_i) + M diag(R_i)`` *affine* in ``x``, every closed-loop map of the spec table
is ``X = N P^-1`` (``S = diag(S) P^-1``, ``T = M diag(R) P^-1``, ``U = W diag(R) P^-1``,
and with ``P' = G^-1 P``: ``Sd = diag(S) P'^-1``, ``Ti = W diag(R) P'^-1``).  The row of
a bounded figure is ``sigma_max(X) / b - t <= 0``, its gradient exact from the top
singular triplet ``(sigma, u, v)``::

    d sigma = Re(u^H dN w) - sigma Re(v^H dP w),   w = P^-1 v,

and crosstalk (``T_mode = "feedback"``: ``Tr = T``) the rows ``|T_ij| / c - t <= 0``,
``i != j``, over its band.

**The sector's figures** (``sector_S``, ``sector_T``, ``sector_U`` of
:func:`robrst.certificate.mimo.sector_figures`: the peaks for every input gain in
``[1 - delta, 1 + delta]``, the deviation any causal operator of gain ``<= delta`` per
input).  The certificate proves ``sector_X <= gamma`` when ``sigma_max(N) < 1`` at every
frequency for one constant positive diagonal ``D`` (:func:`robrst.certificate.mimo.
scaled_sector_peak`), ``N = diag(D, I) N_gamma diag(D^-1, I)`` with ``N_gamma = [[delta Ti,
delta U], [E_w / gamma, E_v / gamma]]`` (``E_w, E_v = Sd, S`` for ``S``; ``-Sd, T`` for
``T``; ``Ti, U`` for ``K S``).  Every block is ``. P^-1 .``, so ``N = L P^-1 Q + E`` with
``L = [delta D W diag(R); B]`` (``B = diag(S)``, ``-diag(S)``, ``W diag(R)``, over
``gamma``) affine in ``x``, ``Q = [G D^-1, I]`` numeric and ``E`` constant (``T = I - S``:
``E`` holds ``I / gamma`` in its last block, zero otherwise).  The row is ``sigma_max(N) -
t <= 0`` (``gamma`` the bound), its gradient ``Re(u^H dL a) - Re(b^H dP a)`` with ``a =
P^-1 Q v`` and ``b^H = u^H L P^-1``.  ``D`` is one per loop and figure, and its logarithms
are program variables beside ``x`` (a scaling fixed while the controller moves, as in D-K
iteration, stalls where the two must move together): ``d sigma / d log D_i = sigma (|u_i|^2
- |v_i|^2)``.  :meth:`GridRows.set_scaling` starts them at each round, minimising the
loop's largest ``sigma_max(N)`` over its points (convex in ``log D``, Sezginer and Overton
1990).  The rows are evaluated in numpy (:class:`GridRows`, every
point at once) and enter IPOPT through a CasADi callback with its exact Jacobian;
IPOPT's Hessian is its limited-memory approximation.  Only the points whose figure is
near its bound enter a solve (:meth:`GridRows.select`); the caller checks the whole grid
after each solve and exchanges points in.

**Stability between rounds** (Karimi's half-plane condition, on every point): with
``d = det P`` and ``d_0`` that of the round's start (a stable loop), the rows
``Re(d / d_0) >= NYQUIST_FLOOR`` keep ``d(j nu)`` in the start's half-plane: ``d`` cannot
pass through zero, so (the open-loop poles and the degree unchanged) the closed loop keeps
the start's number of unstable poles by the argument principle.  A grid holds it only at
its points; the exact check after each round is what decides.

**Other rows** (symbolic).  Each ``S_i'(p - CTRL_DECAY)`` Hurwitz (Routh column: every
axis's own law stable, its poles at least :data:`CTRL_DECAY` ``w0`` into the left
half-plane), and ``sign_i R_i(0) > 0`` (the integral gain's sign).

**Objective.**  With ``k_i = sign_i R_i(0) / S_i'(0)`` the axes' scaled integral gains:
``c_t t - c_k (z + TIE_BREAK sum_i log k_i) + c_reg |x - x_ref|^2`` with ``z <= log k_i``
for every axis: the soft phase minimises ``t`` down to 1 (the worst normalised spec: the
bounds reached, the gains then kept), the hard phase (``t = 1``) maximises the least
integral gain (the axes balanced).

Nothing here proves anything: the certificate (:mod:`robrst.certificate.mimo`) checks the
result on the exact loop.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from robrst.base.interrupt import solver_call
from robrst.core import poly
from robrst.core.rst import RSTController
from robrst.synthesis._nlp import routh_column, shift_matrix
from robrst.synthesis._stopping import StopWhenAsked

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = ["AxisParam", "GridRows", "MimoProgram", "PROGRAM_FIGURES", "SECTOR_FIGURES",
           "Sector", "TINY", "CTRL_DECAY", "NYQUIST_FLOOR"]

#: the figures the program constrains: their numerator, and whether ``P' = G^-1 P``
PROGRAM_FIGURES = {"sigma_S": ("S", False), "sigma_T": ("MR", False),
                   "sigma_U": ("WR", False), "sigma_Sd": ("S", True), "sigma_Ti": ("WR", True)}
#: the sector's figures the program bounds (module docstring), each with its bottom block
SECTOR_FIGURES = {"sector_S": "S", "sector_T": "-S", "sector_U": "WR"}
TINY = 1e-20
#: every axis's own poles (roots of ``S_i'``) have ``Re p <= -CTRL_DECAY w0``: the integral
#: gain ``R(0)/S'(0)`` cannot grow by pushing a pole of ``S'`` to the origin (a second
#: integrator in disguise)
CTRL_DECAY = 0.2
#: weight of the sum of the axes' log integral gains beside the least of them
TIE_BREAK = 0.01
#: ``Re(det P / det P_0)`` at every point stays above this (the half-plane condition)
NYQUIST_FLOOR = 0.05
#: the half-plane rows of a solve: points where a figure is at least this share of its
#: bound (the others join by exchange when a solution leaves the half-plane there)
HALFPLANE_NEAR = 0.5
#: a solve moves the sector's scalings by at most this factor's logarithm (a trust region:
#: far from the start a scaling can only make the rows' singular values overflow)
LOG_SCALE_STEP = np.log(30.0)


@dataclass(frozen=True, eq=False)
class Sector:
    """The sector's rows of a grid (:class:`GridRows`, module docstring).

    Parameters
    ----------
    delta : float
        The sector's half-width (``input_gain_deviation``).
    bounds : dict
        ``{figure: gamma}``: the bounded figures of :data:`SECTOR_FIGURES`.
    segments : numpy.ndarray
        ``(K,)``: the loop of every point (one scaling ``D`` per loop and figure).
    """

    delta: float
    bounds: dict
    segments: np.ndarray

    @property
    def loops(self) -> int:
        """How many loops (segments) the points belong to."""
        return int(np.max(self.segments)) + 1 if len(self.segments) else 0


@dataclass(frozen=True)
class AxisParam:
    """The parametrisation of one axis (module docstring).

    Parameters
    ----------
    w0 : float
        The frequency scale [rad/s].
    F : numpy.ndarray
        The fixed roll-off factor of ``S`` in the scaled variable (``[1.0]``: none).
    d : int
        Degree of ``S'``.
    deg_r : int
        Degree of ``R``.

    Attributes
    ----------
    n_x : int
        Free coefficients: ``d`` of ``S'`` and ``deg_r + 1`` of ``R``.
    """

    w0: float
    F: np.ndarray
    d: int
    deg_r: int

    @classmethod
    def of(cls, w0: float, extra_degree: int, relative_degree: int = 0,
           roll_off_order: int = 0, roll_off_hz: float | None = None) -> AxisParam:
        """The parametrisation of a structure.

        Parameters
        ----------
        w0 : float
            Frequency scale [rad/s].
        extra_degree : int
            Degree of ``S'``.
        relative_degree : int
            ``deg R = deg S - relative_degree``.
        roll_off_order : int
            Order of the fixed roll-off ``(s / w_r + 1)^order``.
        roll_off_hz : float, optional
            Its corner [Hz].

        Returns
        -------
        AxisParam
        """
        F = np.ones(1)
        if roll_off_order:
            F = poly.pprod(*([np.array([w0 / (2 * np.pi * roll_off_hz), 1.0])]
                             * roll_off_order))
        deg_s = 1 + (len(F) - 1) + extra_degree
        return cls(float(w0), F, int(extra_degree), int(deg_s - relative_degree))

    @property
    def n_x(self) -> int:
        return self.d + self.deg_r + 1

    def basis(self, nu: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``R(j nu) = ER @ xR``, ``S(j nu) = ES @ xS + eS0`` at loop frequencies ``nu``.

        Parameters
        ----------
        nu : array_like
            Frequencies [rad/s] of the loop variable.

        Returns
        -------
        ER : numpy.ndarray
            ``(F, deg_r + 1)`` complex.
        ES : numpy.ndarray
            ``(F, d)`` complex.
        eS0 : numpy.ndarray
            ``(F,)`` complex.
        """
        p = 1j * np.asarray(nu, float) / self.w0
        ER = p[:, None] ** np.arange(self.deg_r, -1, -1)[None, :]
        pre = p * np.polyval(self.F, p)
        ES = pre[:, None] * p[:, None] ** np.arange(self.d - 1, -1, -1)[None, :] if self.d \
            else np.zeros((p.size, 0), complex)
        return ER, ES, pre * p ** self.d

    def polynomials(self, x: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """``(R, S)`` in s (highest power first) of this axis's part of ``x``.

        Parameters
        ----------
        x : array_like
            ``n_x`` values: ``S'`` (lower coefficients), then ``R``.

        Returns
        -------
        R, S : numpy.ndarray
        """
        x = np.asarray(x, float)
        Sp = np.concatenate([[1.0], x[:self.d]])
        Rp = x[self.d:]
        Ss = poly.pprod(np.array([1.0, 0.0]), self.F, Sp)
        sc = poly.Scaling(self.w0)
        return sc.undo(Rp), sc.undo(Ss)

    def controller(self, x: ArrayLike, T_mode: str = "feedback") -> RSTController:
        """The axis's RST law.

        Parameters
        ----------
        x : array_like
            Its part of the decision vector.
        T_mode : {"feedback", "static"}
            ``T = R`` or ``T = R(0)``.

        Returns
        -------
        RSTController
        """
        R, S = self.polynomials(x)
        T = R if T_mode == "feedback" else np.array([R[-1]])
        return RSTController(R, S, T)

    def integral_gain(self, x: ArrayLike) -> float:
        """``R(0) / S'(0)`` in the scaled variable (times ``w0`` it is ``lim s K(s)``).

        Parameters
        ----------
        x : array_like

        Returns
        -------
        float
        """
        x = np.asarray(x, float)
        s0 = x[self.d - 1] if self.d else 1.0
        return float(x[-1] / s0)

    def start(self, gain: float, pole: float = 10.0) -> np.ndarray:
        """``x`` of ``K = gain / (p (p / pole + 1)^d)``: an integral law rolled off by ``d``
        poles at ``pole`` (scaled).

        Parameters
        ----------
        gain : float
            The scaled integral gain (its sign the loop's).
        pole : float
            Where the roll-off poles sit, in units of ``w0``.

        Returns
        -------
        numpy.ndarray
        """
        Sp = poly.pprod(*([np.array([1.0, pole])] * self.d)) if self.d else np.ones(1)
        R = np.zeros(self.deg_r + 1)
        R[-1] = gain * Sp[-1]
        return np.concatenate([Sp[1:], R])


class GridRows:
    """The grid rows of the program, evaluated in numpy with their exact Jacobian.

    Parameters
    ----------
    axes : sequence of AxisParam
    nu : numpy.ndarray
        ``(K,)`` loop frequencies [rad/s].
    G : numpy.ndarray
        ``(K, m, m)``: the plant's response.
    W : numpy.ndarray
        ``(K, m, m)``: the decoupler's.
    bounds : dict
        ``{figure: bound}`` (keys of :data:`PROGRAM_FIGURES`).
    crosstalk : float or None
        The crosstalk bound (``T_mode = "feedback"`` only).
    xt_mask : numpy.ndarray
        ``(K,)``: the points inside the crosstalk band.
    sector : Sector, optional
        The sector's figures and the points' loops (their rows' bound is 1: ``gamma`` is
        inside the matrix).

    Notes
    -----
    ``rows`` holds the selected rows: ``(figure, point)``, ``("crosstalk", point, i, j)``
    or ``("nyquist", point)``; ``scales`` the sector's ``D``: ``{figure: (loops, m)}``.
    """

    def __init__(self, axes: Sequence[AxisParam], nu: np.ndarray, G: np.ndarray,
                 W: np.ndarray, bounds: dict, crosstalk: float | None,
                 xt_mask: np.ndarray, sector: Sector | None = None) -> None:
        self.axes = tuple(axes)
        self.m = m = len(self.axes)
        self.offsets = np.cumsum([0] + [a.n_x for a in self.axes])
        self.nx = int(self.offsets[-1])
        self.nu, self.G, self.W = np.asarray(nu, float), np.asarray(G), np.asarray(W)
        self.M = self.G @ self.W
        with np.errstate(all="ignore"):
            Gi = np.linalg.inv(self.G)
        self.Gi = np.where(np.isfinite(Gi), Gi, 0.0)
        self.bounds = dict(bounds)
        self.crosstalk = crosstalk if m > 1 else None
        self.xt_mask = np.asarray(xt_mask, bool)
        self.sector = sector if sector is not None and sector.bounds else None
        self.scales = ({} if self.sector is None else
                       {f: np.ones((self.sector.loops, m)) for f in self.sector.bounds})
        #: the program's variables: ``x``, then the sector's ``log D`` (loop by loop, per
        #: figure in :attr:`scales`' order)
        self.nd = sum(v.size for v in self.scales.values())
        ends = np.cumsum([0] + [v.size for v in self.scales.values()])
        self._slots = {f: slice(int(a), int(b))
                       for f, a, b in zip(self.scales, ends[:-1], ends[1:])}
        self.bases = [a.basis(self.nu) for a in self.axes]
        self.K = len(self.nu)
        self.d0 = None
        self.select(None)
        self._cache = (None, None)

    def set_reference(self, x: np.ndarray) -> None:
        """Hold ``det P`` of every point in the half-plane of ``x``'s (a stable loop).

        Parameters
        ----------
        x : numpy.ndarray
        """
        R, S = self._parts(x)
        P = self._P(R, S)
        self.d0 = np.linalg.det(P)
        self._cache = (None, None)

    def _P(self, R, S):
        """``P = diag(S) + G W diag(R)`` at every point ``(K, m, m)`` (``R, S``: ``(K, m)``)."""
        return self.M * R[:, None, :] + np.eye(self.m)[None] * S[:, None, :]

    def _parts(self, x):
        """``R (K, m)``, ``S (K, m)`` of ``x``."""
        R, S = [], []
        for i, (a, (ER, ES, e0)) in enumerate(zip(self.axes, self.bases)):
            xi = x[self.offsets[i]:self.offsets[i + 1]]
            R.append(ER @ xi[a.d:])
            S.append((ES @ xi[:a.d] if a.d else 0.0) + e0)
        return np.stack(R, 1), np.stack(S, 1)

    def ratios(self, x: np.ndarray) -> dict:
        """Every point's ratio to its bound, per figure (``inf`` where ``P`` is singular).

        Parameters
        ----------
        x : numpy.ndarray

        Returns
        -------
        dict
            ``{figure: (K,)}``, and ``"crosstalk"``: ``(K, m, m)`` (zeros off the band and
            on the diagonal).
        """
        out = {}
        R, S = self._parts(x)
        m = self.m
        P = self._P(R, S)
        with np.errstate(all="ignore"):
            Pi = np.linalg.inv(P)
            for f, b in self.bounds.items():
                X = self._N(f, R, S) @ Pi
                if PROGRAM_FIGURES[f][1]:
                    X = X @ self.G
                out[f] = np.linalg.norm(X, 2, axis=(1, 2)) / b
            if self.crosstalk is not None:
                T = (self.M * R[:, None, :]) @ Pi
                T = np.abs(T) * (1 - np.eye(m))[None] * self.xt_mask[:, None, None]
                out["crosstalk"] = T / self.crosstalk
            for f in self.scales:
                L, Q, E = self._sector(f, R, S)
                out[f] = np.linalg.norm(L @ Pi @ Q + E, 2, axis=(1, 2))
        return {k: np.where(np.isfinite(v), v, np.inf) for k, v in out.items()}

    def _sector(self, f, R, S, ks=slice(None), scales=None):
        """``L (n, 2m, m)``, ``Q (n, m, 2m)`` and ``E (2m, 2m)`` of the sector figure
        ``f``'s matrix ``N = L P^-1 Q + E`` at the points ``ks`` (``R, S`` of those points;
        ``scales``: ``(n, m)`` instead of the points' own ``D``)."""
        m, sec = self.m, self.sector
        gamma = sec.bounds[f]
        D = self.scales[f][sec.segments[ks]] if scales is None else scales
        WR = self.W[ks] * R[:, None, :]
        Sm = np.eye(m)[None] * S[:, None, :]
        bottom = {"S": Sm, "-S": -Sm, "WR": WR}[SECTOR_FIGURES[f]] / gamma
        L = np.concatenate([sec.delta * D[:, :, None] * WR, bottom], axis=1)
        Q = np.concatenate([self.G[ks] / D[:, None, :],
                            np.broadcast_to(np.eye(m), (len(D), m, m))], axis=2)
        E = np.zeros((2 * m, 2 * m))
        if SECTOR_FIGURES[f] == "-S":
            E[m:, m:] = np.eye(m) / gamma
        return L, Q, E

    @property
    def log_scales(self) -> np.ndarray:
        """``(nd,)``: the sector's ``log D`` as program variables."""
        return np.concatenate([np.log(v).ravel() for v in self.scales.values()] or
                              [np.zeros(0)])

    def _unpack(self, logd):
        """:attr:`scales` of program variables ``log D``."""
        return {f: np.exp(np.asarray(logd[sl], float)).reshape(self.scales[f].shape)
                for f, sl in self._slots.items()}

    def set_scaling(self, x: np.ndarray | None = None, scales: dict | None = None) -> None:
        """The sector's ``D``, one per loop and figure: given (``scales``, as
        :attr:`scales`), or minimising each loop's largest ``sigma_max(N)`` over its points
        at ``x`` (Nelder-Mead in ``log D`` from the blocks' balance: the function is convex
        in ``log D``).

        Parameters
        ----------
        x : numpy.ndarray, optional
        scales : dict, optional
        """
        if self.sector is None:
            return
        self._cache = (None, None)
        if scales is not None:
            self.scales = {f: np.array(scales[f], float) for f in self.scales}
            return
        from scipy import optimize      # SciPy loads with the first sector row asked

        R, S = self._parts(x)
        P = self._P(R, S)
        with np.errstate(all="ignore"):
            Pi = np.linalg.inv(P)
        m = self.m
        for f in self.scales:
            for seg in range(self.sector.loops):
                ks = np.flatnonzero(self.sector.segments == seg)
                if not ks.size:
                    continue
                Rk, Sk, Pk = R[ks], S[ks], Pi[ks]
                L, Q, E = self._sector(f, Rk, Sk, ks, np.ones((len(ks), m)))
                N = L @ Pk @ Q + E
                # the blocks' balance: |top right| D = |bottom left| / D
                tr = np.linalg.norm(N[:, :m, m:], 2, axis=(1, 2))
                bl = np.linalg.norm(N[:, m:, :m], 2, axis=(1, 2))
                ok = np.isfinite(tr) & np.isfinite(bl)
                if not np.any(ok) or np.max(tr[ok]) <= 0 or np.max(bl[ok]) <= 0:
                    continue
                d0 = 0.5 * np.log(np.max(bl[ok]) / np.max(tr[ok]))

                def worst(logd):
                    D = np.broadcast_to(np.exp(logd), (len(ks), m))
                    Lk, Qk, Ek = self._sector(f, Rk, Sk, ks, D)
                    v = np.linalg.norm(Lk[ok] @ Pk[ok] @ Qk[ok] + Ek, 2, axis=(1, 2))
                    return float(np.max(v))

                x0 = np.full(m, d0)
                res = optimize.minimize(worst, x0, method="Nelder-Mead",
                                        options={"initial_simplex": x0 + np.vstack(
                                            [np.zeros(m), 0.5 * np.eye(m)]),
                                            "xatol": 1e-3, "fatol": 1e-4, "maxfev": 200 * m})
                self.scales[f][seg] = np.exp(res.x)

    def _N(self, f, R, S, ks=slice(None)):
        """The numerator of figure ``f`` at the points ``ks`` (``R, S`` of those points)."""
        num = PROGRAM_FIGURES[f][0]
        m = self.m
        if num == "S":
            return np.eye(m)[None] * S[:, None, :]
        if num == "MR":
            return self.M[ks] * R[:, None, :]
        return self.W[ks] * R[:, None, :]

    def worst(self, x: np.ndarray) -> float:
        """The largest ratio over every point and figure.

        Parameters
        ----------
        x : numpy.ndarray

        Returns
        -------
        float
        """
        r = self.ratios(x)
        return float(max((np.max(v) for v in r.values()), default=0.0))

    def select(self, x: np.ndarray | None, floor: float = 0.3,
               keep: Iterable[tuple] = ()) -> int:
        """Choose the rows of the next solve: every point whose ratio is at least
        ``floor`` (``x = None``: every point), and the rows ``keep``.

        Parameters
        ----------
        x : numpy.ndarray or None
        floor : float
        keep : iterable of tuple
            Rows to keep whatever their ratio.  With a reference (:meth:`set_reference`),
            the half-plane rows of the points where a figure reaches
            :data:`HALFPLANE_NEAR` of its bound (every point when ``x`` is None).

        Returns
        -------
        int
            How many rows.
        """
        rows = {k for k in keep if k[0] != "nyquist"}
        r = None if x is None else self.ratios(x)
        for f in list(self.bounds) + list(self.scales):
            idx = range(self.K) if r is None else np.flatnonzero(r[f] >= floor)
            rows.update((f, int(k)) for k in idx)
        if self.crosstalk is not None:
            for k in np.flatnonzero(self.xt_mask):
                for i in range(self.m):
                    for j in range(self.m):
                        if i != j and (r is None or r["crosstalk"][k, i, j] >= floor):
                            rows.add(("crosstalk", int(k), i, j))
        nyq = {k for k in keep if k[0] == "nyquist"}
        if self.d0 is not None:
            if r is None:
                nyq.update(("nyquist", k) for k in range(self.K))
            else:
                near = np.max(np.stack([v.reshape(self.K, -1).max(1) for v in r.values()]),
                              axis=0)
                nyq.update(("nyquist", int(k)) for k in np.flatnonzero(near >= HALFPLANE_NEAR))
            nyq = {k for k in nyq if self.d0[k[1]] != 0}
        self.rows = sorted(rows, key=lambda t: (t[0], t[1:])) + sorted(nyq)
        self._cache = (None, None)
        # the rows by figure, once per selection (not per evaluation): figure, rows, points
        # and, of the crosstalk, the entries
        by = {}
        for n, row in enumerate(self.rows):
            by.setdefault(row[0], []).append(n)
        self._groups = [(f, ns, np.array([self.rows[n][1] for n in ns]),
                         np.array([self.rows[n][2:] for n in ns]).reshape(len(ns), -1))
                        for f, ns in by.items()]
        return len(self.rows)

    def halfplane(self, x: np.ndarray) -> np.ndarray:
        """``Re(det P / det P_0)`` at every point (``inf`` without a reference).

        Parameters
        ----------
        x : numpy.ndarray

        Returns
        -------
        numpy.ndarray
        """
        if self.d0 is None:
            return np.full(self.K, np.inf)
        R, S = self._parts(x)
        P = self._P(R, S)
        with np.errstate(all="ignore"):
            r = (np.linalg.det(P) / self.d0).real
        return np.where(self.d0 != 0, r, np.inf)

    @property
    def spec_mask(self) -> np.ndarray:
        """1 for a spec row (``ratio - t <= 0``), 0 for a half-plane row."""
        return np.array([0.0 if r[0] == "nyquist" else 1.0 for r in self.rows])

    def evaluate(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The selected rows' ratios and their Jacobian ``(rows, nx + nd)``.

        Parameters
        ----------
        x : numpy.ndarray
            ``x``, then the sector's ``log D`` (``nd`` of them; :attr:`scales` is set).

        Returns
        -------
        g, J : numpy.ndarray
        """
        key = x.tobytes()
        if self._cache[0] == key:
            return self._cache[1]
        m, nx = self.m, self.nx
        if self.nd:
            self.scales = self._unpack(x[nx:])
            x = x[:nx]
        R, S = self._parts(x)
        P = self._P(R, S)
        with np.errstate(all="ignore"):
            Pi = np.linalg.inv(P)
        # dP/dx and dN/dx as (K, nx, m, m)
        dR = np.zeros((self.K, nx, m), complex)
        dS = np.zeros((self.K, nx, m), complex)
        for i, (a, (ER, ES, _)) in enumerate(zip(self.axes, self.bases)):
            o = self.offsets[i]
            if a.d:
                dS[:, o:o + a.d, i] = ES
            dR[:, o + a.d:self.offsets[i + 1], i] = ER
        eye = np.eye(m)
        dP = self.M[:, None] * dR[:, :, None, :] + eye[None, None] * dS[:, :, None, :]
        g = np.zeros(len(self.rows))
        J = np.zeros((len(self.rows), nx + self.nd))
        for f, ns, ks, entries in self._groups:
            if f == "nyquist":
                r = np.linalg.det(P[ks]) / self.d0[ks]
                tr = np.einsum("kji,klij->kl", Pi[ks], dP[ks])
                g[ns] = NYQUIST_FLOOR - r.real
                J[ns, :nx] = -(r[:, None] * tr).real
                continue
            if f == "crosstalk":
                Mk, Rk, Pik = self.M[ks], R[ks], Pi[ks]
                N = Mk * Rk[:, None, :]
                X = N @ Pik
                dN = Mk[:, None] * dR[ks][:, :, None, :]
                dX = (dN - X[:, None] @ dP[ks]) @ Pik[:, None]
                ii, jj = entries[:, 0], entries[:, 1]
                a = np.arange(len(ns))
                xij = X[a, ii, jj]
                mag = np.abs(xij)
                g[ns] = mag / self.crosstalk
                ph = np.conj(xij) / np.where(mag > 0, mag, 1.0)
                J[ns, :nx] = (ph[:, None] * dX[a, :, ii, jj]).real / self.crosstalk
                continue
            if f in self.scales:
                g[ns], J[ns, :nx], dd = self._sector_rows(f, ks, R, S, Pi, dR, dS, dP)
                # d sigma / d log D: the column of the point's loop and input
                first = self._slots[f].start + self.sector.segments[ks] * m
                for i in range(m):
                    J[ns, nx + first + i] = dd[:, i]
                continue
            b = self.bounds[f]
            prime = PROGRAM_FIGURES[f][1]
            Pk = P[ks]
            Nk = self._N(f, R[ks], S[ks], ks)
            num = PROGRAM_FIGURES[f][0]
            dPk = dP[ks]
            if prime:
                Gik = self.Gi[ks]
                Pk = Gik @ Pk
                dPk = Gik[:, None] @ dPk
            with np.errstate(all="ignore"):
                Pik = np.linalg.inv(Pk)
            X = Nk @ Pik
            U, sv, Vh = np.linalg.svd(X)
            u, sig, v = U[:, :, 0], sv[:, 0], np.conj(Vh[:, 0, :])
            w = np.einsum("kij,kj->ki", Pik, v)
            if num == "S":
                dN = eye[None, None] * dS[ks][:, :, None, :]
            elif num == "MR":
                dN = self.M[ks][:, None] * dR[ks][:, :, None, :]
            else:
                dN = self.W[ks][:, None] * dR[ks][:, :, None, :]
            t1 = np.einsum("ki,klij,kj->kl", np.conj(u), dN, w)
            t2 = np.einsum("ki,klij,kj->kl", np.conj(v), dPk, w)
            g[ns] = sig / b
            J[ns, :nx] = (t1 - sig[:, None] * t2).real / b
        g = np.where(np.isfinite(g), g, 1e6)
        J = np.where(np.isfinite(J), J, 0.0)
        self._cache = (key, (g, J))
        return g, J

    def _sector_rows(self, f, ks, R, S, Pi, dR, dS, dP):
        """The sector figure ``f``'s rows at the points ``ks``: ``sigma_max(N)`` and its
        gradient (module docstring)."""
        m = self.m
        Rk, Sk, X = R[ks], S[ks], Pi[ks]
        L, Q, E = self._sector(f, Rk, Sk, ks)
        U, sv, Vh = np.linalg.svd(L @ X @ Q + E)
        u, sig, v = U[:, :, 0], sv[:, 0], np.conj(Vh[:, 0, :])
        a = np.einsum("kij,kj->ki", X, np.einsum("kij,kj->ki", Q, v))     # P^-1 Q v
        b = np.einsum("ki,kij,kjl->kl", np.conj(u), L, X)                 # u^H L P^-1
        sec = self.sector
        D = self.scales[f][sec.segments[ks]]
        WdR = self.W[ks][:, None] * dR[ks][:, :, None, :]                # (n, nx, m, m)
        kind = SECTOR_FIGURES[f]
        if kind == "WR":
            bottom = WdR
        else:
            bottom = (1.0 if kind == "S" else -1.0) * np.eye(m)[None, None] \
                * dS[ks][:, :, None, :]
        dL = np.concatenate([sec.delta * D[:, None, :, None] * WdR,
                             bottom / sec.bounds[f]], axis=2)            # (n, nx, 2m, m)
        t1 = np.einsum("ki,klij,kj->kl", np.conj(u), dL, a)
        t2 = np.einsum("ki,klij,kj->kl", b, dP[ks], a)
        dlogd = sig[:, None] * (np.abs(u[:, :m]) ** 2 - np.abs(v[:, :m]) ** 2)
        return sig, (t1 - t2).real, dlogd


class _Rows(ca.Callback):
    """The grid rows as a CasADi function of ``x`` (numpy inside)."""

    def __init__(self, grid: GridRows):
        ca.Callback.__init__(self)
        self.grid, self.n = grid, len(grid.rows)
        self.construct("mimo_rows", {"enable_fd": False})

    def get_n_in(self):
        return 1

    def get_n_out(self):
        return 1

    def get_sparsity_in(self, i):
        return ca.Sparsity.dense(self.grid.nx + self.grid.nd, 1)

    def get_sparsity_out(self, i):
        return ca.Sparsity.dense(self.n, 1)

    def eval(self, arg):
        return [self.grid.evaluate(np.array(arg[0], float).ravel())[0]]

    def has_jacobian(self):
        return True

    def get_jacobian(self, name, inames, onames, opts):
        self._jac = _RowsJacobian(name, self.grid, self.n, opts)
        return self._jac


class _RowsJacobian(ca.Callback):
    """The Jacobian of :class:`_Rows` (inputs ``x`` and the nominal rows)."""

    def __init__(self, name, grid, n, opts):
        ca.Callback.__init__(self)
        self.grid, self.n = grid, n
        self.construct(name, opts)

    def get_n_in(self):
        return 2

    def get_n_out(self):
        return 1

    def get_sparsity_in(self, i):
        return (ca.Sparsity.dense(self.grid.nx + self.grid.nd, 1) if i == 0
                else ca.Sparsity.dense(self.n, 1))

    def get_sparsity_out(self, i):
        return ca.Sparsity.dense(self.n, self.grid.nx + self.grid.nd)

    def eval(self, arg):
        return [self.grid.evaluate(np.array(arg[0], float).ravel())[1]]


class MimoProgram:
    """One solve of the joint program on the selected rows of a grid (module docstring).

    Parameters
    ----------
    grid : GridRows
        The rows (already selected).
    ipopt : dict
        IPOPT options (the Hessian is always IPOPT's limited-memory approximation).
    """

    def __init__(self, grid: GridRows, ipopt: dict) -> None:
        self.grid = grid
        nx, nd, m = grid.nx, grid.nd, grid.m
        X = ca.MX.sym("X", nx + nd + 2)
        x, t, z = X[:nx], X[nx + nd], X[nx + nd + 1]
        self._rows = _Rows(grid)
        coef = ca.MX.sym("coef", 3)
        signs = ca.MX.sym("sign", m)
        xref = ca.MX.sym("xref", nx)
        # the axes' integral gains: the least of their logarithms (z) first, their sum as a
        # tie-break
        obj = coef[0] * t + coef[2] * ca.sumsqr(x - xref) - coef[1] * z
        extra = []
        for i, a in enumerate(grid.axes):
            xi = x[int(grid.offsets[i]):int(grid.offsets[i + 1])]
            if a.d:
                sh = shift_matrix(a.d, CTRL_DECAY)
                extra.append(routh_column(ca.mtimes(ca.DM(sh), ca.vertcat(1, xi[:a.d])))[1:])
            r0 = signs[i] * xi[-1]
            s0 = xi[a.d - 1] if a.d else 1
            extra.append(r0)
            logk = ca.log(ca.fmax(r0, TINY)) - ca.log(ca.fmax(s0, TINY))
            extra.append(logk - z)
            obj -= coef[1] * TIE_BREAK * logk
        self.n_extra = int(sum(e.numel() for e in extra))
        self.n_rows = len(grid.rows)
        g = ca.vertcat(self._rows(X[:nx + nd]) - t * ca.DM(grid.spec_mask), *extra)
        ip = {"hessian_approximation": "limited-memory",
              "limited_memory_initialization": "constant", "limited_memory_init_val": 1e-4,
              **dict(ipopt)}
        # a signal stops IPOPT at its next iteration (raised inside the rows' callback, CasADi
        # swallowed it as a failed solve and the design ran on to its end)
        self._stop = StopWhenAsked(X.numel(), g.numel())
        opts = {"ipopt": ip, "print_time": False, "calc_lam_p": False,
                "iteration_callback": self._stop}
        self.solver = ca.nlpsol("mimo", "ipopt",
                                {"x": X, "p": ca.vertcat(coef, signs, xref), "f": obj,
                                 "g": g}, opts)

    def solve(self, x0: np.ndarray, t0: float, signs: ArrayLike, phase: str,
              reg: float = 1e-8) -> dict:
        """Solve from ``x0``.

        Parameters
        ----------
        x0 : numpy.ndarray
        t0 : float
            The start's ratio (soft phase).
        signs : array_like
            Each axis's integral-gain sign.
        phase : {"soft", "hard"}
            Minimise ``t``; or ``t = 1`` and the integral gains maximised.
        reg : float
            Weight of ``|x - x0|^2``.

        Returns
        -------
        dict
            ``status, x, t, f, iterations``; the sector's scalings at the solution are
            the grid's (:attr:`GridRows.scales`).
        """
        nx, nd = self.grid.nx, self.grid.nd
        coef = np.array([1.0, 1e-3, reg]) if phase == "soft" else np.array([0.0, 1.0, reg])
        p = np.concatenate([coef, np.asarray(signs, float), x0])
        lbg = np.concatenate([np.full(self.n_rows, -np.inf), np.full(self.n_extra, 1e-9)])
        ubg = np.concatenate([np.zeros(self.n_rows), np.full(self.n_extra, np.inf)])
        lbx, ubx = np.full(nx + nd + 2, -np.inf), np.full(nx + nd + 2, np.inf)
        logd = self.grid.log_scales
        lbx[nx:nx + nd], ubx[nx:nx + nd] = logd - LOG_SCALE_STEP, logd + LOG_SCALE_STEP
        if phase == "hard":
            lbx[nx + nd] = ubx[nx + nd] = 1.0
        else:                   # down to the bounds, then the gains (not more robustness)
            lbx[nx + nd] = 1.0
        ks = [np.asarray(signs, float)[i] * self.grid.axes[i].integral_gain(
            x0[self.grid.offsets[i]:self.grid.offsets[i + 1]]) for i in range(self.grid.m)]
        z0 = float(np.log(max(min(ks), 1e-300))) - 1e-6
        X0 = np.concatenate([x0, logd, [1.0 if phase == "hard" else t0, z0]])
        with solver_call():     # a signal inside stops IPOPT, then raises Interrupted
            sol = self.solver(x0=X0, p=p, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg)
        st = self.solver.stats()
        X = np.array(sol["x"]).ravel()
        if nd:
            self.grid.set_scaling(scales=self.grid._unpack(X[nx:nx + nd]))
        return {"status": st["return_status"], "x": X[:nx], "t": float(X[nx + nd]),
                "f": float(sol["f"]), "iterations": int(st.get("iter_count", 0))}
