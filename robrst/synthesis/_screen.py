"""Figures of a whole population of controllers at once: the global phase's judge.

:class:`Screen` rates many decision vectors ``X`` (one controller per row) of one
:class:`~robrst.synthesis._nlp.NLPSetup` against the program's constraints, vectorised over
the population, the models and the frequency grid:

* **peaks on the grid**: the controller's ``S(j nu)`` and ``R(j nu)`` are evaluated once on
  every grid point of the program (the models share them: a model only multiplies them by
  its own ``a(j nu)``, ``b(j nu)``), then ``|N| / (M |Delta|)`` for every bound of every
  model (``|S|``, ``|T|``, ``|U|``, the band and high-frequency bounds, ``Msd``,
  ``Mry``) — the same
  grids and bounds as the program's rows (:func:`robrst.synthesis._nlp.grid_blocks`);
* **stability** of every model's closed loop by the Routh test of its polynomial (the
  program's stability rows, :func:`robrst.synthesis.stability.stability_rows`, so a decay
  rate is included);
* **the controller's poles** (the strip the program imposes, a stable controller, the
  controller's damping floor) from their roots;
* for every stable candidate: **the closed-loop roots** of every model, their least damping against the floor (a sampled
  model's roots mapped to s by ``fs ln z``), the peaks at the resonant frequencies of the
  lightly damped ones (a sharp peak between grid points), and the **reference step** of the
  continuous models and of the sampled loops (at their samples) from the modal sum of the
  step response (overshoot, 2 % settling time and peak voltage against the time-domain
  specs).  Every stable candidate is examined so: a screen that examined only those near
  the specs on the grid ranked a candidate just outside that circle (its grid peaks only)
  ahead of one just inside it (the grid peaks, the resonant peaks and the steps), and the
  search stalled on the circle's edge.

The figures are those of the grid and of the modes, not a certificate: the global phase
only ranks candidates with them; every answer is certified exactly afterwards
(:mod:`robrst.certificate.proof`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from robrst.synthesis._nlp import affine_controller, closed_loop_maps, objective_rows
from robrst.synthesis.stability import stability_rows

if TYPE_CHECKING:
    from robrst.synthesis._nlp import NLPSetup
    from robrst.synthesis._timesamples import TimeSpecs

__all__ = ["Screen", "Figures", "batch_roots", "routh_columns", "quadratic_powers",
           "first_samples", "PEAK_SAMPLES",
           "RESONANT_DAMPING", "STEP_POINTS", "RANK_BITS", "RANK_VIOLATION_BITS", "RANK_VIOLATION",
           "OBJECTIVE_NOISE"]

RANK_BITS = 30           # the objective ranks on this many mantissa bits (1e-9 relative) ...
RANK_VIOLATION_BITS = 20  # ... the violation on this many (1e-6: an unstable candidate's
#                           violation is its roots' abscissa, a few digits on every build) ...
RANK_VIOLATION = 1e-9    # ... and below this it is 0: rounding error never ranks
OBJECTIVE_NOISE = 1e-9   # R(0), (S/s^k)(0) this small against their terms have no sign
RESONANT_DAMPING = 0.3   # closed-loop roots damped less than this add their frequency
STEP_POINTS = 120        # samples of each screened reference step (quadratically spaced)
PEAK_SAMPLES = 256       # ... and, of a sampled loop, every one of its first samples
PEAK_BLOCK = 16          # ... as blocks of this many samples (a divisor of PEAK_SAMPLES)
STEP_HORIZON = 10.0      # ... up to this many time constants of the slowest mode
UNSTABLE = 1e3           # the violation of an unstable loop (plus its abscissa)
# each bound's plant factor and controller factor: |a S|, |b R|, |a R|, |b S|, |b Vt r0|
_FACTORS = {"S": ("A", "S"), "T": ("B", "R"), "Tband": ("B", "R"), "U": ("A", "R"),
            "Uhf": ("A", "R"), "Sd": ("B", "S"), "Ry": ("B", "Ry")}


def batch_roots(C: np.ndarray) -> np.ndarray:
    """Roots of each row of ``C`` (polynomial coefficients, highest power first) from the
    eigenvalues of its companion matrix, all rows in one LAPACK batch.

    Parameters
    ----------
    C : numpy.ndarray
        ``(..., d + 1)`` real coefficients.

    Returns
    -------
    numpy.ndarray
        ``(..., d)`` complex roots; a row whose leading coefficient is zero or whose
        coefficients are not finite gets ``inf`` roots (a lost degree: infinitely fast,
        or for a sampled loop a pole at ``z = -1``).

    Examples
    --------
    >>> import numpy as np
    >>> from robrst.synthesis._screen import batch_roots
    >>> np.sort(batch_roots(np.array([[1.0, 3.0, 2.0]])).real).tolist()   # (s + 1)(s + 2)
    [[-2.0, -1.0]]
    """
    C = np.asarray(C, float)
    shape = C.shape[:-1]
    C = C.reshape(-1, C.shape[-1])
    d = C.shape[1] - 1
    if d == 0:
        return np.zeros(shape + (0,), complex)
    bad = ~(np.all(np.isfinite(C), axis=1) & (C[:, 0] != 0))
    lead = np.where(bad, 1.0, C[:, 0])
    comp = np.zeros((C.shape[0], d, d))
    comp[:, 0, :] = -np.where(bad[:, None], 0.0, C[:, 1:]) / lead[:, None]
    if d > 1:
        comp[:, np.arange(1, d), np.arange(d - 1)] = 1.0
    r = np.linalg.eigvals(comp)
    r[bad] = np.inf
    return r.reshape(shape + (d,))


def routh_columns(C: np.ndarray) -> np.ndarray:
    """The first column of the Routh array of each row of ``C``, normalised by its leading
    coefficient (the numeric, batched form of :func:`robrst.synthesis._nlp.routh_column`).

    Parameters
    ----------
    C : numpy.ndarray
        ``(K, d + 1)`` real coefficients, highest power first.

    Returns
    -------
    numpy.ndarray
        ``(K, d + 1)``; every entry positive exactly when the row is Hurwitz (``nan`` or
        non-positive entries: not Hurwitz, or a degenerate array).

    Examples
    --------
    >>> import numpy as np
    >>> from robrst.synthesis._screen import routh_columns
    >>> bool((routh_columns(np.array([[1.0, 3.0, 3.0, 1.0]])) > 0).all())   # (s + 1)^3
    True
    """
    C = np.asarray(C, float)
    with np.errstate(all="ignore"):
        c = C / C[:, :1]
        n = c.shape[1] - 1
        r0 = [c[:, i] for i in range(0, n + 1, 2)]
        r1 = [c[:, i] for i in range(1, n + 1, 2)]
        col = [r0[0]]
        while r1:
            col.append(r1[0])
            nxt = []
            for i in range(len(r0) - 1):
                b = r1[i + 1] if i + 1 < len(r1) else 0.0
                nxt.append((r1[0] * r0[i + 1] - r0[0] * b) / r1[0])
            r0, r1 = r1, nxt
    return np.stack(col, axis=1)


def _powers(nu, deg):
    """``(j nu)^deg ... 1`` as ``(len(nu), deg + 1)`` complex."""
    return (1j * np.asarray(nu, float)[:, None]) ** np.arange(deg, -1, -1)[None, :]


@dataclass(frozen=True)
class Figures:
    """What :meth:`Screen.rate` found for each candidate of a population.

    Parameters
    ----------
    objective : numpy.ndarray
        The program's objective, larger is better: ``log`` of the integral gain (scaled),
        ``-Ms`` (``min_Ms``) or 0 (``feasibility``); ``-inf`` where undefined.
    violation : numpy.ndarray
        The summed relative excess of every constraint (0: every screened constraint holds).
    worst : numpy.ndarray
        The worst peak ratio ``|N| / (M |Delta|)`` on the grid and at the resonances.
    stable : numpy.ndarray
        Every model's closed loop is stable (bool).
    damping : numpy.ndarray
        The least closed-loop damping (``nan`` where not examined).
    overshoot : numpy.ndarray
        The largest screened reference-step overshoot (fraction; ``nan`` where not
        examined).
    examined : numpy.ndarray
        The candidates whose roots and steps were examined (bool).
    """

    objective: np.ndarray
    violation: np.ndarray
    worst: np.ndarray
    stable: np.ndarray
    damping: np.ndarray
    overshoot: np.ndarray
    examined: np.ndarray

    def keys(self) -> tuple[np.ndarray, np.ndarray]:
        """The ranking keys ``(violation, objective)``, rounded (:data:`RANK_BITS` bits of
        the objective's mantissa, :data:`RANK_VIOLATION_BITS` of the violation's, a
        violation below :data:`RANK_VIOLATION` 0): candidates
        whose figures differ only by rounding error rank by their order in the population,
        so the search takes the same path whatever the BLAS or LAPACK build (a last-bit
        difference in a peak would otherwise reorder two near-equal candidates and send
        every later generation elsewhere).

        Returns
        -------
        (numpy.ndarray, numpy.ndarray)
        """
        obj = np.where(np.isfinite(self.objective), self.objective, -np.inf)
        m, e = np.frexp(obj)
        scale = float(2 ** RANK_BITS)
        with np.errstate(invalid="ignore"):
            obj = np.where(np.isfinite(obj), np.ldexp(np.round(m * scale) / scale, e), obj)
        viol = np.asarray(self.violation, float)
        m, e = np.frexp(viol)
        scale = float(2 ** RANK_VIOLATION_BITS)
        viol = np.where(viol < RANK_VIOLATION, 0.0, np.ldexp(np.round(m * scale) / scale, e))
        # Deb's rules rank a candidate outside the specs by its violation alone
        return viol, np.where(viol > 0, -np.inf, obj)

    def order(self) -> np.ndarray:
        """Indices from the best candidate to the worst: feasible ones first by objective,
        then the others by violation (Deb's feasibility rules), on the rounded
        :meth:`keys` (ties: population order).

        Returns
        -------
        numpy.ndarray
        """
        viol, obj = self.keys()
        return np.lexsort((np.arange(obj.size), -obj, viol))


class Screen:
    """Rates populations of decision vectors of ``setup`` (module docstring).

    Parameters
    ----------
    setup : NLPSetup
        The program (its models, grids, bounds, pole region, controller strip).
    time : TimeSpecs, optional
        Reference-step specs to screen (:func:`robrst.synthesis._timesamples.time_specs`).
    two_dof : (float, float, float), optional
        The reference path is a reference model designed after the feedback
        (``T_mode = "reference_model"``): its scaled bandwidth, damping and the damping
        from which ``T`` cancels a nominal closed-loop root.
    """

    def __init__(self, setup: NLPSetup, time: TimeSpecs | None = None,
                 two_dof: tuple | None = None) -> None:
        self.setup, self.time, self.two_dof = setup, time, two_dof
        nx = setup.n_x
        self.ks, self.kr = setup.ks, setup.kr
        cl = closed_loop_maps(setup)
        maps = [cl(a, b) for _, _, a, b in setup.models]
        self.maps = maps
        self.fs = [setup.fs_of[j] if setup.fs_of else None for j in range(len(maps))]
        rows = stability_rows(setup)
        self.rows = []          # per degree: the stability rows of its models, stacked
        self.loops = []         # per degree: models, Delta maps, plants, rates
        for deg in sorted({r[0] for r in rows}):
            js = [j for j, r in enumerate(rows) if r[0] == deg]
            self.rows.append((np.stack([rows[j][1] for j in js]),
                              np.stack([rows[j][2] for j in js])))
        for deg in sorted({m[0][0].shape[0] for m in maps}):
            js = [j for j, m in enumerate(maps) if m[0][0].shape[0] == deg]
            lims = {k: np.array([np.inf if setup.bound(k, j) is None else setup.bound(k, j)
                                 for j in js]) for k in ("S", "T", "U", "Sd")}
            pa = max(len(setup.models[j][2]) for j in js)
            pb = max(len(setup.models[j][3]) for j in js)
            self.loops.append((js, np.stack([maps[j][0][0] for j in js]),
                               np.stack([maps[j][0][1] for j in js]),
                               np.stack([_pad(setup.models[j][2], pa) for j in js]),
                               np.stack([_pad(setup.models[j][3], pb) for j in js]),
                               np.array([np.nan if self.fs[j] is None else self.fs[j]
                                         for j in js]), lims))
        self.r0, self.q0, self.q0c = objective_rows(setup)
        Ls, s0, Lr = affine_controller(setup)
        k = setup.integrators
        self.Lq, self.q = Ls[:len(s0) - k], s0[:len(s0) - k]
        self.Lr0 = Lr[-1]                         # R(0) (scaled) = Lr0 @ x
        self.nx = nx
        self._grids(setup)
        self.cont = [j for j, f in enumerate(self.fs) if f is None]

    def _grids(self, setup):
        """Group every (model, bound) by its grid: per distinct grid the models' plant
        values, and per bound the models and their limits."""
        keys = (("S", "grid"), ("T", "grid"), ("U", "grid"), ("Sd", "grid"), ("Ry", "grid"),
                ("Tband", "band"), ("Uhf", "hf"))
        found = {}
        for j, (label, T, a, b) in enumerate(setup.models):
            arrays = {"grid": setup.grids[j] if setup.grids else setup.nu,
                      "band": setup.bands[j] if setup.bands else (),
                      "hf": setup.hf[j] if setup.hf else ()}
            for key, which in keys:
                bound = setup.bound(key, j)
                if key == "S" and bound is None and setup.objective == "min_Ms":
                    bound = 1.0
                nu = np.asarray(arrays[which], float)
                if bound is None or nu.size == 0:
                    continue
                g = found.setdefault(nu.tobytes(), {"nu": nu, "models": [], "keys": {}})
                if j not in g["models"]:
                    g["models"].append(j)
                g["keys"].setdefault(key, []).append((j, float(bound)))
        self.groups = []
        for g in found.values():
            nu, models = g["nu"], g["models"]
            pos = {j: i for i, j in enumerate(models)}
            A = np.array([np.polyval(setup.models[j][2], 1j * nu) for j in models])
            B = np.array([np.polyval(setup.models[j][3], 1j * nu) for j in models])
            keys = {k: (np.array([pos[j] for j, _ in v]), np.array([m for _, m in v]))
                    for k, v in g["keys"].items()}
            Vs = _powers(nu, self.ks) * np.polyval(setup.Sf, 1j * nu)[:, None]
            Vr = _powers(nu, self.kr) * np.polyval(setup.Rf, 1j * nu)[:, None]
            shape = np.ones(1) if setup.T_shape is None else np.asarray(setup.T_shape, float)
            Vt = np.polyval(shape, 1j * nu)
            # every bound is |plant factor| |controller factor| / (bound |Delta|): per
            # controller factor (|S|, |R|, the reference's |Vt r0|) one weight per model
            # and frequency, the largest plant factor / bound over the keys it enters
            mag = {"A": np.abs(A), "B": np.abs(B)}
            weights = {}
            for key, (idx, bound) in keys.items():
                model, ctrl = _FACTORS[key]
                w = weights.setdefault(ctrl, np.zeros(A.shape))
                w[idx] = np.maximum(w[idx], mag[model][idx] / bound[:, None])
            self.groups.append((A, B, keys, Vs, Vr, Vt, models, weights))

    def controllers(self, X: np.ndarray, nu: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``S(j nu)`` and ``R(j nu)`` (scaled) of each row of ``X`` at its own frequencies.

        Parameters
        ----------
        X : numpy.ndarray
            ``(K, n_x)`` decision vectors.
        nu : numpy.ndarray
            ``(K, m)`` scaled frequencies.

        Returns
        -------
        (numpy.ndarray, numpy.ndarray)
            ``(K, m)`` complex each.
        """
        s = 1j * nu
        S = np.ones(nu.shape, complex)
        for c in X[:, :self.ks].T:
            S = S * s + c[:, None]
        R = np.zeros(nu.shape, complex)
        for c in X[:, self.ks:self.nx].T:
            R = R * s + c[:, None]
        return S * np.polyval(self.setup.Sf, s), R * np.polyval(self.setup.Rf, s)

    def peaks(self, X: np.ndarray) -> np.ndarray:
        """The worst ``|N| / (M |Delta|)`` over every bound, model and grid point.

        Parameters
        ----------
        X : numpy.ndarray
            ``(K, n_x)`` decision vectors.

        Returns
        -------
        numpy.ndarray
            ``(K,)``.
        """
        K = X.shape[0]
        worst = np.zeros(K)
        lead = np.concatenate([np.ones((K, 1)), X[:, :self.ks]], axis=1)
        r0 = X @ self.Lr0
        with np.errstate(all="ignore"):
            for A, B, _, Vs, Vr, Vt, _, weights in self.groups:
                S = lead @ Vs.T                                   # (K, F)
                R = X[:, self.ks:self.nx] @ Vr.T
                inv = 1.0 / np.abs(A[None] * S[:, None] + B[None] * R[:, None])  # 1/|Delta|
                ctrl = {"S": S, "R": R, "Ry": Vt[None] * r0[:, None]}
                for c, w in weights.items():
                    r = (w[None] * (np.abs(ctrl[c])[:, None] * inv)).max(axis=(1, 2))
                    worst = np.maximum(worst, np.where(np.isnan(r), np.inf, r))
        return worst

    def stable(self, X: np.ndarray) -> np.ndarray:
        """How many models' closed loops fail the Routh test (the program's stability rows,
        decay-shifted with a decay rate).

        Parameters
        ----------
        X : numpy.ndarray
            ``(K, n_x)``.

        Returns
        -------
        numpy.ndarray
            ``(K,)`` counts (0: every loop stable).
        """
        K = X.shape[0]
        bad = np.zeros(K)
        for Dm, Dc in self.rows:
            D = np.einsum("kx,mdx->kmd", X, Dm) + Dc[None]
            col = routh_columns(D.reshape(-1, D.shape[-1])).reshape(K, len(Dm), -1)
            bad += np.sum(~np.all(col > 0, axis=2), axis=1)
        return bad

    def controller_excess(self, X: np.ndarray) -> np.ndarray:
        """Relative excess of the controller's poles beyond the program's strip, a stable
        controller and the controller's damping floor.

        Parameters
        ----------
        X : numpy.ndarray
            ``(K, n_x)``.

        Returns
        -------
        numpy.ndarray
            ``(K,)``, 0 where every condition holds.
        """
        st = self.setup
        out = np.zeros(X.shape[0])
        if self.Lq.shape[0] < 2:
            return out
        r = batch_roots(X @ self.Lq.T + self.q)
        re = np.where(np.isfinite(r), r.real, np.inf)
        if st.objective == "max_integral_gain" and st.ctrl_shift:
            out += np.maximum(re.max(axis=1) + st.ctrl_shift, 0.0) / st.ctrl_shift
        if st.stable_controller:
            out += np.maximum(re.max(axis=1), 0.0) * 10.0 + (re.max(axis=1) >= 0)
        if st.placement == "free" and st.ctrl_max:
            out += np.maximum(-st.ctrl_max - re.min(axis=1), 0.0) / st.ctrl_max
        cz = st.region.ctrl_zeta if st.region is not None else None
        if cz:
            with np.errstate(all="ignore"):
                z = np.where(np.abs(r) > 0, -r.real / np.abs(r), 1.0)
            z = np.where(np.isfinite(z), z, 1.0)
            out += np.maximum(cz / np.maximum(z.min(axis=1), 1e-12) - 1.0, 0.0)
        return out

    def objective(self, X: np.ndarray, worst_s: np.ndarray | None = None) -> np.ndarray:
        """The program's objective (larger is better) of each row.

        Parameters
        ----------
        X : numpy.ndarray
            ``(K, n_x)``.
        worst_s : numpy.ndarray, optional
            ``min_Ms``: the worst ``|S|`` (else unused).

        Returns
        -------
        numpy.ndarray
            ``log`` of the scaled integral gain (``-inf`` where ``R(0)`` or ``(S/s^k)(0)``
            is not positive), ``-Ms`` or 0.
        """
        obj = self.setup.objective
        if obj == "max_integral_gain":
            num, den = X @ self.r0, X @ self.q0 + self.q0c
            # positive beyond rounding error (a sum of terms that cancel to 1e-16 of their
            # size has no sign: the same verdict on every numerical build)
            ok = ((num > OBJECTIVE_NOISE * (np.abs(X) @ np.abs(self.r0)))
                  & (den > OBJECTIVE_NOISE * (np.abs(X) @ np.abs(self.q0) + abs(self.q0c))))
            with np.errstate(all="ignore"):
                return np.where(ok, np.log(np.where(ok, num, 1.0) / np.where(ok, den, 1.0)),
                                -np.inf)
        if obj == "min_Ms":
            return -worst_s
        return np.zeros(X.shape[0])

    def rate(self, X: np.ndarray, top: int | None = None) -> Figures:
        """Every screened figure of each row of ``X`` (module docstring).

        Parameters
        ----------
        X : numpy.ndarray
            ``(K, n_x)`` decision vectors.
        top : int, optional
            Only the first ``top`` places of :meth:`Figures.order` are needed (a CMA-ES
            recombines its best ``mu``): the roots and steps, the costly part, are examined
            only for candidates that can reach them.  The figures without them bound a
            candidate's violation from below (the objective is exact), so once the
            examined (the best bounds first) fill place ``top`` with a better key than
            every bound left, the rest are skipped: their violation stays that bound,
            ``examined`` false.  The first ``top`` places are exactly those of the full
            rating.

        Returns
        -------
        Figures
        """
        X = np.asarray(X, float)
        K = X.shape[0]
        st = self.setup
        finite = np.all(np.isfinite(X), axis=1)
        X = np.where(finite[:, None], X, 0.0)
        worst = self.peaks(X)
        unstable = self.stable(X)
        viol = np.maximum(worst - 1.0, 0.0) + self.controller_excess(X)
        bad = unstable > 0
        if bad.any():      # unstable: behind every stable candidate, graded by how unstable
            # (by the largest real part of the roots, not by how many models are unstable:
            # a model's verdict on a wild candidate turns on rounding error)
            viol[bad] = UNSTABLE + self._abscissa(X[bad])
        obj = self.objective(X, self._worst_s(X) if st.objective == "min_Ms" else None)
        if st.objective == "max_integral_gain":   # (an unstable one is behind already)
            viol += np.where(np.isfinite(obj) | bad, 0.0, UNSTABLE)
        viol = np.where(finite, np.nan_to_num(viol, nan=1e6, posinf=1e6), 1e6)
        damping, over = np.full(K, np.nan), np.full(K, np.nan)
        near = (unstable == 0) & finite
        examined = np.zeros(K, bool)

        def examine(idx):
            if idx.size:
                extra, damping[idx], over[idx], w_res = self._modes(X[idx])
                viol[idx] += extra
                worst[idx] = np.maximum(worst[idx], w_res)
                examined[idx] = True

        idx = np.flatnonzero(near)
        if top is None or idx.size <= top:
            examine(idx)
        else:
            # the ranking's key (violation, -objective): the objective is exact, the
            # violation without the modes a lower bound; the best bounds first, in batches
            # of top, until every bound left ranks after place top of the examined
            neg = -np.where(np.isfinite(obj), obj, -np.inf)
            idx = idx[np.lexsort((neg[idx], viol[idx]))]
            while idx.size:
                examine(idx[:top])
                idx = idx[top:]
                d = np.flatnonzero(~near | examined)      # every final violation
                if d.size < top or not idx.size:
                    continue
                k = d[np.lexsort((neg[d], viol[d]))[top - 1]]     # at place top
                v, n = viol[idx], neg[idx]
                idx = idx[(v < viol[k]) | ((v == viol[k]) & (n <= neg[k]))]
        return Figures(objective=obj, violation=viol, worst=worst, stable=unstable == 0,
                       damping=damping, overshoot=over, examined=examined)

    def _abscissa(self, X):
        """The largest real part of the closed-loop roots over the models (scaled; the
        program's stability rows: decay-shifted with a decay rate), at most 100."""
        out = np.full(X.shape[0], -np.inf)
        for Dm, Dc in self.rows:
            r = batch_roots(np.einsum("kx,mdx->kmd", X, Dm) + Dc[None])
            re = np.where(np.isfinite(r), r.real, 100.0)
            out = np.maximum(out, re.max(axis=(1, 2)))
        return np.clip(out, 0.0, 100.0)

    def _worst_s(self, X):
        """The worst ``|S|`` (``min_Ms``'s objective) over the grid."""
        K = X.shape[0]
        out = np.zeros(K)
        lead = np.concatenate([np.ones((K, 1)), X[:, :self.ks]], axis=1)
        with np.errstate(all="ignore"):
            for A, B, keys, Vs, Vr, Vt, _, _ in self.groups:
                if "S" not in keys:
                    continue
                idx, bound = keys["S"]
                S, R = lead @ Vs.T, X[:, self.ks:self.nx] @ Vr.T
                aS = A[None, idx] * S[:, None]
                r = np.abs(aS) / np.abs(aS + B[None, idx] * R[:, None])
                out = np.maximum(out, r.max(axis=(1, 2)))
        return out

    def _modes(self, X):
        """The closed-loop roots of the candidates ``X`` (all stable): their damping excess,
        peaks at their resonant frequencies and reference-step excess.

        Returns
        -------
        (excess, least damping, overshoot, worst resonant peak ratio), each ``(K,)``.
        """
        st = self.setup
        K = X.shape[0]
        excess, w_res, zmin = np.zeros(K), np.zeros(K), np.ones(K)
        Ds, roots = {}, {}
        for js, Dm, Dc, A, B, fs, lims in self.loops:
            D = np.einsum("kx,mdx->kmd", X, Dm) + Dc[None]      # (K, M, d + 1)
            r = batch_roots(D)                                    # (K, M, d)
            for i, j in enumerate(js):
                Ds[j], roots[j] = D[:, i], r[:, i]
            w = r * st.w0
            h = 2.0 * np.nan_to_num(fs, nan=1.0)[None, :, None]
            with np.errstate(all="ignore"):
                s = np.where(np.isnan(fs)[None, :, None], w,
                             h / 2.0 * np.log((h + w) / (h - w)))
                z = np.where(np.abs(s) > 0, -s.real / np.abs(s), 1.0)
            z = np.where(np.isfinite(z), z, 1.0)
            zmin = np.minimum(zmin, z.min(axis=(1, 2)))
            nu = np.where((z < RESONANT_DAMPING) & np.isfinite(r), np.abs(r.imag), 0.0)
            if np.any(nu > 0):
                w_res = np.maximum(w_res, self._at(X, A, B, nu, lims))
        floor = st.region.zeta if st.region is not None else None
        if floor:
            excess += np.maximum(floor / np.maximum(zmin, 1e-12) - 1.0, 0.0)
        excess += np.maximum(w_res - 1.0, 0.0)
        over = np.full(K, np.nan)
        if self.time is not None:
            t_excess, over = self._steps(X, Ds, roots)
            excess += t_excess
        return excess, zmin, over, w_res

    def _at(self, X, A, B, nu, lims):
        """Worst ratio of the models' main bounds (``lims``: per key, per model) at the
        frequencies ``nu`` (``(K, M, m)`` scaled, 0 entries ignored); ``A``, ``B`` the
        models' plant polynomials (``(M, .)``)."""
        K, M, m = nu.shape
        S, R = self.controllers(X, nu.reshape(K, M * m))
        S, R = S.reshape(K, M, m), R.reshape(K, M, m)
        s = 1j * nu
        a = _horner_rows(A, s)
        b = _horner_rows(B, s)
        D = np.abs(a * S + b * R)
        out = np.zeros(K)
        nums = {"S": a * S, "T": b * R, "U": a * R, "Sd": b * S}
        with np.errstate(all="ignore"):
            for key, N in nums.items():
                bound = lims[key][None, :, None]
                if np.all(np.isinf(bound)):
                    continue
                r = np.where(nu > 0, np.abs(N) / (bound * D), 0.0)
                out = np.maximum(out, np.nan_to_num(r.max(axis=(1, 2)), nan=0.0))
        return out

    def _steps(self, X, Ds, roots):
        """Excess of the screened reference steps over the time specs, and the largest
        overshoot (fraction): the continuous models, and with the structure's own ``T`` the
        sampled loops at their samples too (the certificate checks both, and a sampled loop
        overshoots more than its continuous model by the hold's phase lag).

        The step of ``N / (s D)`` is the modal sum ``N(0)/D(0) + sum_i c_i exp(p_i t)``,
        ``c_i = N(p_i) / (p_i D'(p_i))`` over the poles ``p_i`` of the loop.  A sampled
        loop's plant is the bilinear (w-plane) equivalent: its step at sample ``k`` is
        ``N(0)/D(0) + sum_i c_i / (1 - p_i h / 2) z_i^k`` with ``z_i = (1 + p_i h/2) /
        (1 - p_i h/2)`` and ``h`` the sample period (the residues of ``H(z) z / (z - 1)``).
        With the structure's ``T`` the loop is ``B T / Delta``; with a reference model
        (``two_dof``) it is ``B Delta_wd / (Delta Am_ref)`` (:mod:`robrst.synthesis.tracking`:
        ``T`` cancels the nominal closed-loop roots damped at least ``cancel``, the reference
        model adds its poles, spread apart by a few per cent so the modal sum holds), screened
        on the continuous models.
        """
        groups = [(None, self.cont)]
        if self.two_dof is None:
            for f in sorted({f for f in self.fs if f is not None}):
                groups.append((self.setup.w0 / f, [j for j, g in enumerate(self.fs) if g == f]))
        excess, over = np.zeros(X.shape[0]), np.full(X.shape[0], -np.inf)
        for h, js in groups:
            js = [j for j in js if Ds[j].shape[1] == Ds[js[0]].shape[1]] if js else js
            if not js:
                continue
            e, o = self._group_steps(X, Ds, roots, js, h)
            excess, over = excess + e, np.maximum(over, o)
        return excess, over

    def _group_steps(self, X, Ds, roots, js, h):
        """:meth:`_steps` of the models ``js`` (one degree; ``h``: their sample period,
        scaled, ``None`` for continuous models)."""
        ts = self.time
        D = np.stack([Ds[j] for j in js], axis=1)                   # (K, M, d + 1)
        p = np.stack([roots[j] for j in js], axis=1)                # (K, M, d)
        A = np.stack([_pad(self.setup.models[j][2], D.shape[2]) for j in js])
        B = np.stack([_pad(self.setup.models[j][3], D.shape[2]) for j in js])
        lead = D[:, :, 0]
        if self.two_dof is None:
            shape = (np.ones(1) if self.setup.T_shape is None
                     else np.asarray(self.setup.T_shape, float))
            r0 = (X @ self.Lr0)[:, None, None]
            fy = lambda z: r0 * _horner_rows(B, z) * np.polyval(shape, z)   # noqa: E731
            fu = lambda z: r0 * _horner_rows(A, z) * np.polyval(shape, z)   # noqa: E731
            poles = p
        else:
            wn, zeta, cancel = self.two_dof
            nom = roots[self.setup.ref]                                  # (K, d)
            with np.errstate(all="ignore"):
                z_nom = -nom.real / np.abs(nom)
            wd = (z_nom >= cancel) & (nom.real < 0)

            def delta_wd(z):          # the cancelled nominal factor at z: (K, M, n)
                f = np.where(wd[:, None, None, :], z[..., None] - nom[:, None, None, :], 1.0)
                return np.prod(f, axis=-1)

            ref = _reference_roots(wn, zeta, max(2, D.shape[2] - len(self.setup.Sf)
                                                 - self.ks + 1))
            poles = np.concatenate([p, np.broadcast_to(ref, p.shape[:2] + ref.shape)], axis=2)
            fy = lambda z: _horner_rows(B, z) * delta_wd(z)             # noqa: E731
            fu = lambda z: _horner_rows(A, z) * delta_wd(z)             # noqa: E731
        return _modal_steps(poles, lead, fy, fu, ts, h)


def _reference_roots(wn, zeta, degree):
    """The reference model's poles (scaled), spread apart by a few per cent."""
    z = min(zeta, 0.98)
    pair = wn * np.array([-z + 1j * np.sqrt(1 - z * z), -z - 1j * np.sqrt(1 - z * z)])
    reals = -2.0 * wn * (1.0 + 0.05 * np.arange(max(degree, 2) - 2))
    return np.concatenate([pair, reals.astype(complex)])


def _modal_steps(poles, lead, fy, fu, ts, h=None):
    """Excess over the time specs ``ts`` of the steps ``N/(s D)`` (modal sums; ``poles``
    ``(K, M, n)`` of ``D``, its leading coefficient ``lead``, ``fy``/``fu`` the output's and
    the voltage's numerators at given points) and the largest overshoot, per candidate;
    with a sample period ``h`` (scaled) the discrete loops' steps at their samples, ``D``
    and ``N`` being their bilinear (w-plane) equivalents (:meth:`Screen._steps`).

    The voltage is scaled by the output's final value (a unit output step)."""
    K, M, n = poles.shape
    tgrid = np.linspace(0.0, 1.0, STEP_POINTS) ** 2
    excess = np.zeros(K)
    with np.errstate(all="ignore"):
        diff = poles[..., :, None] - poles[..., None, :]
        diff[..., np.arange(n), np.arange(n)] = 1.0
        dprime = lead[..., None] * np.prod(diff, axis=-1)              # D'(p_i)
        d0 = lead * np.prod(-poles, axis=-1)                            # D(0)
        zero = np.zeros((K, M, 1), complex)
        y_inf = (fy(zero)[..., 0] / d0).real
        cy = fy(poles) / (poles * dprime)
        rate = poles                  # continuous: exp(p t); sampled: z^k = exp(log(z) k)
        if h is not None:
            hold = 1.0 - 0.5 * h * poles
            cy = cy / hold
            rate = np.log((1.0 + 0.5 * h * poles) / hold) / h
        sig = np.min(-rate.real, axis=2)
        t_end = np.minimum(STEP_HORIZON / np.maximum(sig, 1e-9), 1e4)
        # a real loop's roots come in exact conjugate pairs (LAPACK's eigenvalues of a real
        # matrix) with conjugate weights: the modes with Im p >= 0 carry the sum, those with
        # Im p > 0 twice (the costly exponentials and products halved)
        half = np.argsort(poles.imag < 0, axis=2, kind="stable")
        half = half[..., :int(np.max(np.sum(~(poles.imag < 0), axis=2)))]
        p_half = np.take_along_axis(poles, half, 2)
        twice = np.where(p_half.imag > 0, 2.0, np.where(p_half.imag < 0, 0.0, 1.0))
        rate = np.take_along_axis(rate, half, 2)
        cy = np.take_along_axis(cy, half, 2) * twice
        tau = t_end[..., None] * tgrid                                  # (K, M, T)
        if h is not None:                                               # at the samples
            tau = np.round(tau / h) * h
        def output(modal):    # the unit step's output from its modes' sum (K, M, T)
            return (y_inf[..., None] + modal) / y_inf[..., None]

        if h is None:
            e = quadratic_powers(rate, t_end)                          # (K, M, n, T)
        else:
            e = np.exp(rate[..., None] * tau[..., None, :])
        y = output(_weigh(cy, e))
        ok = np.all(np.isfinite(y), axis=2)
        peak = y.max(axis=2)
        if h is not None:     # every one of the first samples: the peak of a loop that rings
            # near Nyquist falls between the grid's samples
            peak = np.maximum(peak, output(first_samples(cy, np.exp(rate * h))).max(axis=2))
        o = np.where(ok, peak - 1.0, 0.0)
        over = o.max(axis=1)
        if ts.overshoot is not None:
            excess += np.maximum(over - ts.overshoot, 0.0) / max(ts.overshoot, 0.01)
        if ts.settling is not None:
            out = np.abs(y - 1.0) > 0.02
            idx = STEP_POINTS - 1 - np.argmax(out[:, :, ::-1], axis=2)
            last = np.where(out.any(axis=2),
                            np.take_along_axis(tau, idx[:, :, None], 2)[:, :, 0], 0.0)
            excess += np.where(ok, np.maximum(last / ts.settling - 1.0, 0.0), 0.0).sum(1)
        if ts.u_max is not None:
            u_inf = (fu(zero)[..., 0] / d0).real
            cu = fu(poles) / (poles * dprime) / (1.0 if h is None else hold)
            cu = np.take_along_axis(cu, half, 2) * twice
            u = (u_inf[..., None] + _weigh(cu, e)) / y_inf[..., None]
            pk = np.abs(u).max(axis=2).max(axis=1) * ts.step_um
            excess += np.where(np.isfinite(pk), np.maximum(pk / ts.u_max - 1.0, 0.0), 0.0)
    return excess, over


def first_samples(c: np.ndarray, z: np.ndarray) -> np.ndarray:
    """``Re sum_i c_i z_i^k`` for ``k < PEAK_SAMPLES``: the modal sum at a sampled loop's
    first samples, in blocks of ``k = B a + b`` (``B = PEAK_BLOCK``).

    ``sum_i (c_i z_i^(B a)) z_i^b`` is one matrix product per candidate and model, of the
    weights times the block powers ``z^(B a)`` (rows ``a``) with the powers ``z^b`` within
    a block (columns ``b``): ``B + PEAK_SAMPLES / B`` powers per mode, not
    ``PEAK_SAMPLES``, and no array of every mode at every sample.

    Parameters
    ----------
    c : numpy.ndarray
        ``(K, M, n)`` complex weights.
    z : numpy.ndarray
        ``(K, M, n)`` complex modes (``z_i`` per sample).

    Returns
    -------
    numpy.ndarray
        ``(K, M, PEAK_SAMPLES)`` real.

    Examples
    --------
    >>> import numpy as np
    >>> z = np.array([[[0.9 + 0.1j, 0.5 + 0j]]])
    >>> c = np.array([[[1.0 + 2.0j, -0.5 + 0j]]])
    >>> k = np.arange(PEAK_SAMPLES)
    >>> direct = (c[..., None] * z[..., None] ** k).sum(axis=2).real
    >>> bool(np.allclose(first_samples(c, z), direct, rtol=1e-12, atol=1e-12))
    True
    """
    B = PEAK_BLOCK
    within = np.empty(z.shape + (B,), complex)                  # z^b, b < B
    within[..., 0] = 1.0
    within[..., 1:] = z[..., None]
    np.cumprod(within, axis=-1, out=within)
    blocks = np.empty(z.shape + (PEAK_SAMPLES // B,), complex)  # z^(B a)
    blocks[..., 0] = 1.0
    blocks[..., 1:] = (within[..., -1] * z)[..., None]
    np.cumprod(blocks, axis=-1, out=blocks)
    rows = np.swapaxes(c[..., None] * blocks, -1, -2)          # (K, M, A, n)
    return np.matmul(rows, within).real.reshape(z.shape[:2] + (PEAK_SAMPLES,))


def quadratic_powers(rate: np.ndarray, t_end: np.ndarray) -> np.ndarray:
    """``exp(rate t_j)`` on the screened steps' quadratic grid ``t_j = t_end (j / (T - 1))^2``
    (``T`` = :data:`STEP_POINTS`), by two running products instead of one complex
    exponential per instant.

    With ``q = exp(rate t_end / (T - 1)^2)`` the value at ``j`` is ``q^(j^2)``, and
    ``q^(j^2) = q^((j-1)^2) q^(2j-1)``, where ``q^(2j-1)`` is itself a running product of
    ``q^2``.  The rounding errors grow with ``j^2``: a few 1e-12 relative at ``T = 120``,
    far below the ranking's resolution (:data:`RANK_BITS`).

    Parameters
    ----------
    rate : numpy.ndarray
        ``(K, M, n)`` complex rates (the modes' poles, scaled).
    t_end : numpy.ndarray
        ``(K, M)`` horizons.

    Returns
    -------
    numpy.ndarray
        ``(K, M, n, T)``; a mode whose rate is not finite keeps the exponential's ``nan``
        at ``t = 0`` (and so is not finite throughout, as the exponential would be).
    """
    T = STEP_POINTS
    q = np.exp(rate * (t_end / (T - 1) ** 2)[..., None])
    e = np.empty(rate.shape + (T,), complex)
    e[..., 0] = 1.0
    e[..., 1] = q
    e[..., 2:] = (q * q)[..., None]
    np.cumprod(e, axis=-1, out=e)           # 1, q, q^3, q^5, ...: the odd powers' steps
    np.cumprod(e, axis=-1, out=e)           # 1, q, q^4, q^9, ...
    e[..., 0] = np.exp(rate * 0.0)
    return e


def _weigh(c, e):
    """``Re sum_i c_i e_i(t)``: the modal sum of the weights ``c`` ``(K, M, n)`` over the
    modes' values ``e`` ``(K, M, n, T)`` (a batched product, not an ``einsum`` loop)."""
    return np.matmul(c[..., None, :], e)[..., 0, :].real


def _pad(c, n):
    """``c`` with leading zeros to length ``n``."""
    c = np.asarray(c, float)
    return np.concatenate([np.zeros(n - len(c)), c])


def _horner_rows(c, s):
    """Model ``m``'s polynomial ``c[m]`` at ``s[:, m, :]`` (``s``: ``(K, M, m)``)."""
    out = np.zeros(s.shape, complex) + c[None, :, :1]
    for i in range(1, c.shape[1]):
        out = out * s + c[None, :, i:i + 1]
    return out
