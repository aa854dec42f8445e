"""The multi-axis global phase: a population search over every axis's law at once.

The joint program (:mod:`robrst.synthesis.mimo_program`) is local: from the per-axis
integral laws it ends at the optimum nearest its path (on a seeded three-axis stage 1,074
where a search over the whole structure finds twice that).  As the single loop's global
phase (:mod:`robrst.synthesis.search`), this one picks the basin and the program polishes:

1. **A space that covers every law of the structure, well scaled.**  Per axis, in the
   scaled variable ``p = s / w0`` of :class:`~robrst.synthesis.mimo_program.AxisParam`:
   the integral gain ``k = sign R(0) / S'(0)`` on a log scale (``10^-3 .. 10^4`` times the
   per-axis start's), the roots of ``S'`` as pairs ``(p + a)^2 + b^2`` and one real
   ``p + c`` for an odd degree, their real parts from ``CTRL_DECAY`` (the program's own
   strip, so every point meets that row) to ``10^3``, and ``R = R(0) (1 + sum_j a_j p^j)``
   with ``a_j`` on a sinh scale (zeros anywhere from ``10^-3`` to ``10^3`` crossover
   scales, either sign).  Every point is a law of the structure, and every law with its
   own poles inside the strip and the start's gain sign is a point.
2. **Hansen's CMA-ES** (:mod:`robrst.synthesis._cmaes`, the single loop's): one local run
   from the per-axis start (step 0.05 of the box), then runs from seeded random means with
   growing populations (IPOP-CMA-ES), each ranked by Deb's feasibility rules — feasible
   candidates by the program's objective (the least log integral gain, plus
   ``TIE_BREAK`` times their sum), the others by their summed relative violation, an
   unstable loop behind every stable one.
3. **Every population judged at once** (:class:`MimoScreen`): the closed-loop spectrum of
   every model's continuous and sampled loop (one batched eigenvalue call per loop), and
   for the stable candidates every bounded figure the program holds — ``sigma_S``,
   ``sigma_T``, ``sigma_U``, ``sigma_Sd``, the input sector's ``sigma_Ti``, the axes' own
   peaks and the crosstalk over its band — on the program's validation grid (dense
   across every resonance) and where each of the candidate's closed-loop modes peaks: the
   damped frequency of every lightly damped pole (damping below ``RESONANT_DAMPING``) and
   ``|p| sqrt(1 - 2 zeta^2)`` of every pole damped below ``PEAK_DAMPING`` (a closed-loop
   resonance peaks between the grid's points, where the certificate finds it), 0.5 %
   inside the program's bounds.

The screen proves nothing: its best point starts the joint program, and the certificate
judges what comes out.  The sector's scaled figures (``sector_*``) are left to the program.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from robrst.core.mimo import MimoPlant
from robrst.synthesis._cmaes import CMAES
from robrst.synthesis.mimo_design import GRID_MARGIN
from robrst.synthesis.mimo_program import CTRL_DECAY, TIE_BREAK, AxisParam
from robrst.synthesis.mimo_start import (RESONANT_DAMPING, loop_plants, nu_of,
                                          program_grid)

if TYPE_CHECKING:
    from robrst.problem.mimo import MimoSpecs

__all__ = ["MimoSpace", "MimoScreen", "MimoSearch", "search_mimo", "SCREEN_MARGIN", "PEAK_DAMPING"]

#: a closed-loop mode damped less than this peaks, at ``|p| sqrt(1 - 2 zeta^2)`` (second
#: order), where the screen evaluates it too
PEAK_DAMPING = 1 / np.sqrt(2)
#: the screen holds the bounds this much inside the program's (which are GRID_MARGIN inside
#: the certificate's): its best point starts the program inside its rows
SCREEN_MARGIN = 0.005
#: the runs: (population, step size, generations at most); the first from the start
RUNS = ((14, 0.05, 150), (28, 0.3, 200), (56, 0.3, 250))
#: a run stops after this many generations without 0.1 % progress of its best
STALL = 40
GAIN_DECADES = (-3.0, 4.0)      # the integral gain, relative to the start's
ROOT_DECADES = (-3.0, 3.0)      # S' roots' real parts beyond CTRL_DECAY (scaled)
PAIR_RATIO = (-3.0, 1.0)        # a pair's imaginary part over its real part
ZERO_SINH = (12.0, 1e-4)        # a_j = scale 10^(j-1) sinh(kappa (2u - 1))


def _decades(u, lo_hi):
    lo, hi = lo_hi
    return 10.0 ** (lo + (hi - lo) * np.asarray(u, float))


def _undecades(v, lo_hi):
    lo, hi = lo_hi
    return float(np.clip((np.log10(v) - lo) / (hi - lo), 0.0, 1.0))


@dataclass(frozen=True, eq=False)
class MimoSpace:
    """The search box of a structure (module docstring, step 1).

    Parameters
    ----------
    axes : sequence of AxisParam
        Every axis's structure.
    signs : sequence of float
        Every axis's integral-gain sign.
    gains : sequence of float
        Every axis's reference integral gain (scaled; the per-axis start's, > 0).
    """

    axes: tuple
    signs: tuple
    gains: tuple

    @property
    def dim(self) -> int:
        """Coordinates in all (as many as the program's coefficients)."""
        return int(sum(a.n_x for a in self.axes))

    def decode(self, U: np.ndarray) -> np.ndarray:
        """The program's decision vectors ``(P, dim)`` of box points ``U`` ``(P, dim)``.

        Parameters
        ----------
        U : numpy.ndarray
            Points of ``[0, 1]^dim``.

        Returns
        -------
        numpy.ndarray
        """
        U = np.atleast_2d(np.asarray(U, float))
        out, col = [], 0
        for a, sign, g in zip(self.axes, self.signs, self.gains):
            k = g * _decades(U[:, col], GAIN_DECADES)
            col += 1
            Sp = np.ones((U.shape[0], 1))
            for _ in range(a.d // 2):
                re = CTRL_DECAY + _decades(U[:, col], ROOT_DECADES)
                im = re * _decades(U[:, col + 1], PAIR_RATIO)
                Sp = _times(Sp, np.stack([np.ones_like(re), 2 * re, re * re + im * im], 1))
                col += 2
            if a.d % 2:
                c = CTRL_DECAY + _decades(U[:, col], ROOT_DECADES)
                Sp = _times(Sp, np.stack([np.ones_like(c), c], 1))
                col += 1
            R0 = sign * k * Sp[:, -1]
            kappa, scale = ZERO_SINH
            R = [R0]
            for j in range(1, a.deg_r + 1):
                aj = scale * 10.0 ** (j - 1) * np.sinh(kappa * (2 * U[:, col] - 1))
                R.insert(0, R0 * aj)
                col += 1
            out.append(np.column_stack([Sp[:, 1:], np.stack(R, 1)]))
        return np.hstack(out)

    def point(self, x: np.ndarray) -> np.ndarray:
        """The box point nearest the law ``x`` (a per-axis start: roll-off poles on the
        real axis, ``R`` constant); the laws outside the box land on its faces.

        Parameters
        ----------
        x : numpy.ndarray
            A decision vector of the program.

        Returns
        -------
        numpy.ndarray
        """
        u, offs = [], _offsets(self.axes)
        for i, (a, sign, g) in enumerate(zip(self.axes, self.signs, self.gains)):
            xi = np.asarray(x[offs[i]:offs[i + 1]], float)
            Sp = np.concatenate([[1.0], xi[:a.d]])
            R = xi[a.d:]
            k = max(sign * a.integral_gain(xi), 1e-300)
            u.append(_undecades(k / g, GAIN_DECADES))
            roots = np.roots(Sp) if a.d else np.zeros(0)
            pairs = sorted(roots[roots.imag > 1e-12 * np.abs(roots)], key=abs) \
                if roots.size else []
            reals = sorted((-r.real for r in roots if abs(r.imag) <= 1e-12 * abs(r)))
            for _ in range(a.d // 2):
                if pairs:
                    r = pairs.pop(0)
                    re, im = -r.real, abs(r.imag)
                else:               # two real roots as one pair (their mean, no spread)
                    re, im = (reals.pop(0) + reals.pop(0)) / 2, 0.0
                re = max(re - CTRL_DECAY, 1e-300)
                u += [_undecades(re, ROOT_DECADES),
                      _undecades(max(im / (re + CTRL_DECAY), 1e-300), PAIR_RATIO)]
            if a.d % 2:
                u.append(_undecades(max(reals.pop(0) - CTRL_DECAY, 1e-300), ROOT_DECADES))
            kappa, scale = ZERO_SINH
            for j in range(1, a.deg_r + 1):
                aj = R[-1 - j] / R[-1] if R[-1] else 0.0
                v = np.arcsinh(aj / (scale * 10.0 ** (j - 1))) / kappa
                u.append(float(np.clip((v + 1) / 2, 0.0, 1.0)))
        return np.array(u)

    def objective(self, X: np.ndarray) -> np.ndarray:
        """The program's objective of decision vectors ``X`` ``(P, dim)``: the least log
        integral gain plus ``TIE_BREAK`` times their sum.

        Parameters
        ----------
        X : numpy.ndarray

        Returns
        -------
        numpy.ndarray
            ``(P,)``; ``-inf`` where a gain has the wrong sign.
        """
        X = np.atleast_2d(X)
        offs = _offsets(self.axes)
        ks = np.column_stack([
            s * X[:, offs[i + 1] - 1] / (X[:, offs[i] + a.d - 1] if a.d else 1.0)
            for i, (a, s) in enumerate(zip(self.axes, self.signs))])
        with np.errstate(divide="ignore", invalid="ignore"):
            logk = np.where(ks > 0, np.log(np.where(ks > 0, ks, 1.0)), -np.inf)
        return logk.min(1) + TIE_BREAK * logk.sum(1)


def _offsets(axes):
    """Where each axis's coefficients start in the joint decision vector (and the end)."""
    return np.cumsum([0] + [a.n_x for a in axes])


def _times(A, B):
    """Row-wise products of polynomials ``A`` ``(P, n)`` and ``B`` ``(P, k)``."""
    out = np.zeros((A.shape[0], A.shape[1] + B.shape[1] - 1))
    for j in range(B.shape[1]):
        out[:, j:j + A.shape[1]] += A * B[:, j:j + 1]
    return out


class MimoScreen:
    """Every candidate of a population judged on every loop at once (module docstring,
    step 3).

    Parameters
    ----------
    models : sequence of MimoPlant
        Continuous models.
    specs : MimoSpecs
    axes : sequence of AxisParam
    W : numpy.ndarray or tuple
        Static decoupler ``(inputs, axes)`` or a dynamic one ``(A, B, C, D)``.
    T_mode : str
    w_design : float
        The crossover scale [rad/s] (the grids').
    n_freq : int
        Log-spaced grid points per loop.
    """

    def __init__(self, models: Sequence[MimoPlant], specs: MimoSpecs,
                 axes: Sequence[AxisParam], W: np.ndarray | tuple, T_mode: str,
                 w_design: float, n_freq: int) -> None:
        self.axes, self.T_mode = tuple(axes), T_mode
        self.m = len(axes)
        keep = ("sigma_S", "sigma_T", "sigma_U", "sigma_Sd", "sigma_Ti", "axis_S", "axis_T",
                "crosstalk")
        self.bounds = {f: b * (1 - SCREEN_MARGIN) / (1 + GRID_MARGIN)
                       for f, b in specs.bounded.items() if f in keep}
        lo, hi = specs.crosstalk_band_rad_s
        if isinstance(W, tuple):
            self.Wss = tuple(np.asarray(M, float) for M in W)
        else:
            Wm = np.asarray(W, float)
            self.Wss = (np.zeros((0, 0)), np.zeros((0, self.m)), np.zeros((Wm.shape[0], 0)), Wm)
        dec = MimoPlant(*self.Wss, "decoupler") if self.Wss[0].size else None
        self.decoupler = dec.modal_response() if dec is not None else None
        self.loops = []
        for lp in loop_plants(models, specs):
            w = program_grid(models[lp.model], lp.fs, w_design, n_freq, dense=True)
            nu = nu_of(w, lp.fs)
            G = lp.plant.freqresp(nu)
            Wj = dec.freqresp(nu) if dec is not None \
                else np.broadcast_to(self.Wss[3], (nu.size,) + self.Wss[3].shape)
            band = (w >= lo) & (w <= hi)
            # the kept response's scale is the plant's w0 (its eigenvalues, not again per
            # population)
            self.loops.append((lp.plant, lp.plant.modal_response(), nu, G, Wj, G @ Wj, band,
                               [a.basis(nu) for a in self.axes]))

    def _responses(self, X, basis):
        """``R_i(j nu)``, ``S_i(j nu)`` of every candidate: ``(P, F, m)`` each."""
        offs = _offsets(self.axes)
        Rs, Ss = [], []
        for i, (a, (ER, ES, eS0)) in enumerate(zip(self.axes, basis)):
            x = X[:, offs[i]:offs[i + 1]]
            Rs.append(x[:, a.d:] @ ER.T)
            Ss.append((x[:, :a.d] @ ES.T if a.d else 0.0) + eS0[None, :])
        return np.stack(Rs, -1), np.stack(Ss, -1)

    def _realisation(self, X):
        """The law ``u = C_K x + D_K y`` of every candidate, batched: ``(A, B, C, D)``."""
        P, m = X.shape[0], self.m
        offs = _offsets(self.axes)
        blocks = []
        for i, a in enumerate(self.axes):
            x = X[:, offs[i]:offs[i + 1]]
            Sp = np.column_stack([np.ones(P), x[:, :a.d]])
            S = _times(np.tile(np.polymul([1.0, 0.0], a.F), (P, 1)), Sp)     # p F(p) S'(p)
            lead = S[:, :1]
            S, R = S / lead, x[:, a.d:] / lead
            n = S.shape[1] - 1
            R = np.hstack([np.zeros((P, n + 1 - R.shape[1])), R])
            # controllable form in p, then physical time (x' = w0 (A x + B y))
            A = np.zeros((P, n, n))
            A[:, np.arange(n - 1), np.arange(1, n)] = 1.0
            A[:, -1, :] = -S[:, :0:-1]
            C = (R[:, :0:-1] - R[:, :1] * S[:, :0:-1])
            blocks.append((a.w0 * A, a.w0 * np.eye(n)[-1], -C, -R[:, 0]))
        nk = sum(b[0].shape[1] for b in blocks)
        Ak = np.zeros((P, nk, nk))
        Bk = np.zeros((P, nk, m))
        Ck = np.zeros((P, m, nk))
        Dk = np.zeros((P, m, m))
        r = 0
        for i, (A, B, C, D) in enumerate(blocks):
            n = A.shape[1]
            Ak[:, r:r + n, r:r + n] = A
            Bk[:, r:r + n, i] = B
            Ck[:, i, r:r + n] = C
            Dk[:, i, i] = D
            r += n
        Aw, Bw, Cw, Dw = self.Wss      # v -> u through the decoupler
        nw = Aw.shape[0]
        A = np.zeros((P, nk + nw, nk + nw))
        A[:, :nk, :nk] = Ak
        A[:, nk:, :nk] = Bw @ Ck
        A[:, nk:, nk:] = Aw
        B = np.concatenate([Bk, np.broadcast_to(Bw, (P,) + Bw.shape) @ Dk], 1)
        C = np.concatenate([Dw @ Ck, np.broadcast_to(Cw, (P,) + Cw.shape)], 2)
        return A, B, C, Dw @ Dk

    def __call__(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Judge decision vectors ``X`` ``(P, dim)``.

        Parameters
        ----------
        X : numpy.ndarray

        Returns
        -------
        violation : numpy.ndarray
            ``(P,)``: the summed relative violation of the screened bounds (0: meets them
            all on the grids), ``inf`` for a loop with a closed-loop pole in the right
            half-plane.
        abscissa : numpy.ndarray
            ``(P,)``: the largest real part of a closed-loop pole over every loop, over its
            loop's crossover scale (what ranks the unstable candidates).
        """
        X = np.atleast_2d(np.asarray(X, float))
        P = X.shape[0]
        Ak, Bk, Ck, Dk = self._realisation(X)
        viol = np.zeros(P)
        worst = np.full(P, -np.inf)
        for loop in self.loops:
            eig = self._loop_poles(loop[0], Ak, Bk, Ck, Dk)
            ev = eig.real.max(1) / loop[1].scale
            worst = np.maximum(worst, ev)
            live = np.flatnonzero((ev < 0) & np.isfinite(viol))
            viol[ev >= 0] = np.inf
            if live.size and self.bounds:
                for f, v in self._loop_peaks(X[live], loop, eig[live]).items():
                    viol[live] += np.maximum(v / self.bounds[f] - 1, 0)
        return viol, worst

    def _loop_poles(self, plant, Ak, Bk, Ck, Dk):
        """The closed loop's poles ``(P, n)`` in the loop's variable, batched (``inf`` where
        the loop is not well posed)."""
        P, m = Ak.shape[0], self.m
        Ap, Bp, Cp, Dp = plant.A, plant.B, plant.C, plant.D
        with np.errstate(all="ignore"):
            E = np.linalg.inv(np.eye(m)[None] - Dp @ Dk)
            Yp = E @ Cp
            Yk = E @ Dp @ Ck
            Up, Uk = Dk @ Yp, Ck + Dk @ Yk
            A = np.concatenate([
                np.concatenate([np.broadcast_to(Ap, (P,) + Ap.shape) + Bp @ Up, Bp @ Uk], 2),
                np.concatenate([Bk @ Yp, Ak + Bk @ Yk], 2)], 1)
            ok = np.all(np.isfinite(A), axis=(1, 2))
            ev = np.full((P, A.shape[1]), np.inf, complex)
            if ok.any():
                ev[ok] = np.linalg.eigvals(A[ok])
        return ev

    def figures(self, X: np.ndarray) -> dict:
        """The screened figures of decision vectors ``X``: each bounded figure's largest
        value over every loop's grid (``inf`` where a loop is unstable).

        Parameters
        ----------
        X : numpy.ndarray
            ``(P, dim)``.

        Returns
        -------
        dict
            ``{figure: (P,) array}`` for every figure the screen holds.
        """
        X = np.atleast_2d(np.asarray(X, float))
        out = {f: np.zeros(X.shape[0]) for f in self.bounds}
        Ak, Bk, Ck, Dk = self._realisation(X)
        eigs = [self._loop_poles(loop[0], Ak, Bk, Ck, Dk) for loop in self.loops]
        stable = np.max([e.real.max(1) for e in eigs], axis=0) < 0
        for f in out:
            out[f][~stable] = np.inf
        live = np.flatnonzero(stable)
        for loop, eig in zip(self.loops, eigs):
            if live.size:
                for f, v in self._loop_peaks(X[live], loop, eig[live]).items():
                    out[f][live] = np.maximum(out[f][live], v)
        return out

    def _loop_peaks(self, X, loop, eig):
        """Every bounded figure's peak on one loop (``loop``: an entry of ``self.loops``)
        for the stable candidates ``X`` with closed-loop poles ``eig``: on the loop's grid,
        and where a closed-loop mode peaks between the grid's points — the damped frequency
        of each lightly damped pole (damping below ``RESONANT_DAMPING``) and
        ``|p| sqrt(1 - 2 zeta^2)`` of each pole damped below ``PEAK_DAMPING`` (seeded stage
        2's ``sigma_T`` peaked 1.4 % over its bound below its modes damped 0.31-0.38).  The
        crosstalk on the grid only."""
        out = self._peaks(X, *loop[2:])
        with np.errstate(all="ignore"):
            mag = np.abs(eig)
            zeta = -eig.real / mag
            up = (eig.imag > 0) & np.isfinite(eig)
            lightly = up & (zeta < RESONANT_DAMPING)
            peaking = up & (zeta < PEAK_DAMPING)
        damped, peak = np.nonzero(lightly), np.nonzero(peaking)
        rows = np.concatenate([damped[0], peak[0]])
        nu = np.concatenate([eig[damped].imag,
                             mag[peak] * np.sqrt(np.maximum(1 - 2 * zeta[peak] ** 2, 0.0))])
        if rows.size:
            G = loop[1](nu)
            Wj = (self.decoupler(nu) if self.decoupler is not None
                  else np.broadcast_to(self.Wss[3], (nu.size,) + self.Wss[3].shape))
            R, S = self._responses_at(X[rows], nu)
            at = self._figures(X[rows], R[:, None], S[:, None], G[:, None], Wj[:, None],
                               (G @ Wj)[:, None], np.zeros(1, bool))
            for f, v in at.items():
                np.maximum.at(out[f], rows, v)
        return out

    def _responses_at(self, X, nu):
        """``R_i(j nu_k)``, ``S_i(j nu_k)`` of candidate ``k`` at its own frequency ``nu_k``:
        ``(K, m)`` each."""
        offs = _offsets(self.axes)
        Rs, Ss = [], []
        for i, a in enumerate(self.axes):
            ER, ES, eS0 = a.basis(nu)
            x = X[:, offs[i]:offs[i + 1]]
            Rs.append(np.einsum("kj,kj->k", x[:, a.d:], ER))
            Ss.append((np.einsum("kj,kj->k", x[:, :a.d], ES) if a.d else 0.0) + eS0)
        return np.stack(Rs, -1), np.stack(Ss, -1)

    def _peaks(self, X, nu, G, Wj, M, band, basis):
        """Every bounded figure's peak on one loop's grid: ``{figure: (P,)}``."""
        R, S = self._responses(X, basis)
        return self._figures(X, R, S, G[None], Wj[None], M[None], band)

    def _figures(self, X, R, S, G, Wj, M, band):
        """Every bounded figure's largest value over the frequencies of ``R``, ``S``
        (``(P, F, m)``), the plant ``G``, the decoupler ``Wj`` and ``M = G Wj`` (``(P or 1,
        F, ., .)``), the crosstalk over ``band`` (``(F,)``): ``{figure: (P,)}``."""
        m, b = self.m, self.bounds
        I = np.eye(m)
        out = {}
        with np.errstate(all="ignore"):
            Pm = S[..., None, :] * I + M * R[..., None, :]            # diag(S) + M diag(R)
            Pinv = np.linalg.inv(Pm)
            So = S[..., :, None] * Pinv                               # diag(S) P^-1
            T = I - So
            maps = {"sigma_S": lambda: So, "sigma_T": lambda: T,
                    "sigma_U": lambda: (Wj * R[..., None, :]) @ Pinv,
                    "sigma_Sd": lambda: So @ G,
                    "sigma_Ti": lambda: ((Wj * R[..., None, :]) @ Pinv) @ G}
            for fig, mk in maps.items():
                if fig in b:
                    out[fig] = _sigma_peak(mk())
            diag = np.arange(m)
            if "axis_S" in b:
                out["axis_S"] = np.abs(So[..., diag, diag]).max((1, 2))
            if "axis_T" in b:
                out["axis_T"] = np.abs(T[..., diag, diag]).max((1, 2))
            if "crosstalk" in b:
                if not band.any() or m == 1:
                    out["crosstalk"] = np.zeros(X.shape[0])
                else:
                    if self.T_mode == "feedback":
                        Tr = T
                    else:                   # T_i = R_i(0): Tr = S_o M diag(R_i(0) / S_i)
                        offs = _offsets(self.axes)
                        R0 = X[:, offs[1:] - 1]
                        Tr = So @ (M * (R0[:, None, :] / S)[..., None, :])
                    off = ~np.eye(m, dtype=bool)
                    out["crosstalk"] = np.abs(Tr[:, band][..., off]).max((1, 2))
        return {f: np.where(np.isfinite(v), v, np.inf) for f, v in out.items()}


def _sigma_peak(Xf):
    """``max_F sigma_max`` of ``(P, F, r, c)`` matrices (the largest eigenvalue of the
    Gram matrix in closed form up to 3 x 3: the screen's hot spot, 4x cheaper than
    batched SVDs)."""
    r, c = Xf.shape[-2:]
    Xh = np.conj(np.swapaxes(Xf, -1, -2))
    H = Xh @ Xf if r >= c else Xf @ Xh
    k = min(r, c)
    with np.errstate(all="ignore"):
        if k == 1:
            lam = H[..., 0, 0].real
        elif k == 2:
            a, d, b = H[..., 0, 0].real, H[..., 1, 1].real, H[..., 0, 1]
            lam = (a + d) / 2 + np.sqrt(((a - d) / 2) ** 2 + np.abs(b) ** 2)
        elif k == 3:
            d = np.stack([H[..., i, i].real for i in range(3)], -1)
            p1 = np.abs(H[..., 0, 1]) ** 2 + np.abs(H[..., 0, 2]) ** 2 + np.abs(H[..., 1, 2]) ** 2
            q = d.sum(-1) / 3
            p = np.sqrt((np.sum((d - q[..., None]) ** 2, -1) + 2 * p1) / 6)
            B = (H - q[..., None, None] * np.eye(3)) / np.where(p > 0, p, 1.0)[..., None, None]
            det = (B[..., 0, 0] * (B[..., 1, 1] * B[..., 2, 2] - B[..., 1, 2] * B[..., 2, 1])
                   - B[..., 0, 1] * (B[..., 1, 0] * B[..., 2, 2] - B[..., 1, 2] * B[..., 2, 0])
                   + B[..., 0, 2] * (B[..., 1, 0] * B[..., 2, 1] - B[..., 1, 1] * B[..., 2, 0]))
            phi = np.arccos(np.clip(det.real / 2, -1.0, 1.0)) / 3
            lam = q + 2 * p * np.cos(phi)
        else:
            lam = np.full(Xf.shape[:2], np.inf)
            ok = np.isfinite(Xf).all((-2, -1))
            lam[ok] = np.linalg.svd(Xf[ok], compute_uv=False)[:, 0] ** 2
        peak = np.sqrt(np.maximum(lam, 0.0))
    peak = np.where(np.isfinite(Xf).all((-2, -1)), peak, np.inf)
    return peak.max(1)


@dataclass(frozen=True)
class MimoSearch:
    """What the multi-axis search found.

    Parameters
    ----------
    x : numpy.ndarray
        The best decision vector (the program's coefficients).
    objective : float
        Its screened objective (least log integral gain plus the tie-break).
    violation : float
        Its screened violation (0: meets every screened bound on the grids).
    start_objective : float
        The per-axis start's objective (``-inf`` when the screen refuses the start).
    evaluations : int
        Candidates judged.
    runs : tuple of str
        One line per run (population, generations, best).
    space : MimoSpace
        The box searched (its :meth:`MimoSpace.objective` ranks other laws alike).
    """

    x: np.ndarray
    objective: float
    violation: float
    start_objective: float
    evaluations: int
    runs: tuple
    space: MimoSpace

    @property
    def feasible(self) -> bool:
        """Whether the best point meets every screened bound."""
        return self.violation == 0.0


def _key(viol, worst, obj):
    """Deb's ranking key: feasible by objective, then violation, then unstable."""
    return [(0, -o) if v == 0 else ((1, v) if np.isfinite(v) else (2, w))
            for v, w, o in zip(viol, worst, obj)]


def search_mimo(models: Sequence[MimoPlant], specs: MimoSpecs, axes: Sequence[AxisParam],
                W: np.ndarray | tuple, T_mode: str, signs: Sequence[float],
                x_start: np.ndarray, w_design: float, seed: int = 20261205,
                n_freq: int = 40, progress: Callable[[str], None] | None = None
                ) -> MimoSearch:
    """Search the structure's laws globally (module docstring).

    Parameters
    ----------
    models : sequence of MimoPlant
        Continuous models.
    specs : MimoSpecs
    axes : sequence of AxisParam
    W : numpy.ndarray or tuple
        The decoupler.
    T_mode : str
    signs : sequence of float
        Every axis's integral-gain sign.
    x_start : numpy.ndarray
        The per-axis start (the first run's mean, and the gains' reference).
    w_design : float
        The crossover scale [rad/s].
    seed : int
        The random numbers' seed (each run its own stream).
    n_freq : int
        Log-spaced grid points per loop (the resonances' points added).
    progress : callable, optional
        Receives one line per run.

    Returns
    -------
    MimoSearch
    """
    say = progress or (lambda msg: None)
    axes = tuple(axes)
    ks = [max(abs(a.integral_gain(x_start[o:o + a.n_x])), 1e-12)
          for a, o in zip(axes, _offsets(axes))]
    space = MimoSpace(axes, tuple(signs), tuple(ks))
    screen = MimoScreen(models, specs, axes, W, T_mode, w_design, n_freq)
    x0 = np.asarray(x_start, float)[None]
    v0, w0 = screen(x0)
    o0 = float(space.objective(x0)[0])
    best = (_key(v0, w0, [o0])[0], x0[0], float(v0[0]), o0)
    start_obj = o0 if v0[0] == 0 else -np.inf
    streams = [np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(len(RUNS))]
    evals, lines = 1, []
    for r, ((lam, sigma, gens), rng) in enumerate(zip(RUNS, streams)):
        mean = space.point(x0[0]) if r == 0 else rng.random(space.dim)
        es = CMAES(mean, sigma, rng, lam)
        run_best, last_gain = None, 0
        for g in range(gens):
            U = es.ask()
            X = space.decode(U)
            viol, worst = screen(X)
            obj = space.objective(X)
            keys = _key(viol, worst, obj)
            order = np.array(sorted(range(len(U)), key=keys.__getitem__))
            es.tell(U, order)
            evals += len(U)
            i = order[0]
            if run_best is None or keys[i] < run_best[0]:
                gained = run_best is None or keys[i][0] < run_best[0][0] or (
                    abs(keys[i][1] - run_best[0][1]) > 1e-3 * max(1.0, abs(run_best[0][1])))
                run_best = (keys[i], X[i].copy(), float(viol[i]), float(obj[i]))
                if gained:
                    last_gain = g
            if g - last_gain >= STALL or es.spread < 1e-6:
                break
        lines.append(f"run {r + 1}: population {lam}, {g + 1} generations, best "
                     + (f"screened objective {run_best[3]:.4g}" if run_best[2] == 0 else
                        f"violation {run_best[2]:.3g}"))
        say("  search " + lines[-1])
        if run_best[0] < best[0]:
            best = run_best
    return MimoSearch(best[1], best[3], best[2], start_obj, evals, tuple(lines), space)
