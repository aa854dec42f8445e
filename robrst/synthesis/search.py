"""The global phase of the robust synthesis: search the controller space, then polish.

The robust program is non-convex: a local solver from one start ends at one local
optimum, and which one depends on the start, on the bounds and on luck.  The global phase
searches the whole space of controllers of the structure *before* the local program
polishes:

1. **A well-scaled space that covers every controller.**  A controller is named by the
   nominal closed-loop poles it places and its free Youla degrees (:class:`PoleSpace`):
   the poles as pairs ``p^2 + 2 zeta w p + w^2`` (log ``w`` over the frequencies of the
   plant and the start, log ``zeta`` from the damping floor to 30: ``zeta > 1`` is a pair
   of real poles) and one real pole for an odd degree; the Diophantine equation at the
   nominal model (the scaled Sylvester map, :func:`robrst.synthesis._nlp.closed_loop_maps`)
   gives the controller with those poles, and the Youla degrees move along its null
   space, relative to the size of that controller.  Every controller that stabilises the
   nominal model has exactly one such name; every name stabilises the nominal model.
2. **A population method.**  A CMA-ES (:mod:`robrst.synthesis._cmaes`) from the problem's
   own design, then from seeded random means (:class:`SearchOptions`), each run's
   population ``growth`` times the previous one's (IPOP-CMA-ES, Auger and Hansen 2005: a
   larger population smooths a multimodal landscape and finds the global structure;
   ``restarts`` runs in all, each with its own random stream spawned from the seed, so
   one run's length never changes another's samples); every population judged at once
   by :class:`~robrst.synthesis._screen.Screen`
   (the program's constraints on its grid and modes, every model at once) and ranked by
   Deb's feasibility rules (feasible candidates by objective, the others by violation).
3. **Polish and certify.**  The best distinct candidates are certified as they are and
   polished by the robust program with every coefficient free
   (:meth:`robrst.synthesis.attempts.Run.hard`: IPOPT, constraint exchange, certification
   rounds; a polish keeps its start's integral gain); the best certified objective is
   kept.

Why this method (see the synthesis background page for the references): HIFOO and
systune run a local non-smooth (or smooth, here IPOPT) method from a few random starts;
the starts are the weak point — a handful of them missed optima 1.5-300x better on the
stages tried.  Karimi's convex iterations are local too (a convex inner approximation
around a stabilising start).  An evolution strategy explores the whole space with a
population whose evaluations vectorise (a generation costs about as much as one IPOPT
iteration), needs no gradients of the non-smooth peak figures, and ranks instead of
weighting penalties, so it does not care how the objective or the constraint violations
are scaled; its covariance adapts to the coupling of the poles.  The local program then
does what it does well: converge to the exact KKT point of the constraints that bind.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from robrst.core import poly
from robrst.synthesis.attempts import GLOBAL_START
from robrst.synthesis._cmaes import CMAES
from robrst.synthesis._nlp import closed_loop_maps

if TYPE_CHECKING:
    from robrst.synthesis.context import Context
    from robrst.synthesis._nlp import NLPSetup
    from robrst.synthesis._screen import Screen

__all__ = ["PoleSpace", "EdgeSpace", "Candidate", "GlobalSearch", "global_search", "move_inside",
           "SearchOptions", "SEARCH", "ZETA_MAX", "EDGE_ROOTS"]

@dataclass(frozen=True)
class SearchOptions:
    """The global phase's settings, each with why (:func:`global_search`,
    :func:`move_inside`).

    Attributes
    ----------
    seed : int
        The random numbers (``numpy.random.SeedSequence``): one stream per run spawned
        from it, so a design is reproducible and one run's length never changes another's.
    restarts : int
        CMA-ES runs: the first from the problem's design, then from random means (four
        runs: populations 14, 28, 56 and 112; on the stages tried five runs of 28 found
        nothing more, two of 84 less).
    generations : int
        At most per run; a run stops earlier once it stalls (``stall``) or narrows
        (``min_spread``).
    stall : int
        Generations without progress that end a run.
    min_spread : float
        A run's distribution this narrow (box units) has converged.
    popsize : int
        The first run's population (at least ``4 + 3 ln d``, Hansen's default).
    growth : int
        Run ``r``'s population is ``growth ** r`` times the first's (IPOP-CMA-ES, Auger and
        Hansen 2005: a larger population smooths a multimodal landscape).
    seed_sigma : float
        The first run's step size: local around its seed (BIPOP's local regime).
    random_sigma : float
        The random runs' step size: a third of the box.
    distinct : float
        Candidates closer than this (box units) are the same.
    inside_sigma : float
        :func:`move_inside`: a narrow distribution around the candidate ...
    inside_generations : int
        ... for at most this many generations (a run's) ...
    inside_stall : int
        ... or this many without progress once inside (a run's rules: once inside, the
        narrow run goes on to the best point near the candidate).
    progress : float
        A run's best objective (``log`` of the integral gain: relative) must grow by more
        than this to count as progress.
    active : bool
        The active covariance update (:mod:`robrst.synthesis._cmaes`): the infeasible
        and worse samples shrink the variance along their directions, and a run on a
        bound's ridge climbs instead of creeping.  Off by default: measured at ``Ms_max``
        1.5 / 1.75 / 2.0 / 2.25 / 2.5 it raised the objectives (geometric mean +4.3 % over
        25 points, ``paper_robust`` 636,429 -> 665,233) but moved which basin each design
        reaches, and the tested monotone scans of stages 102 and 204 lost 8 % and 9 %
        (docs/background/synthesis.md).
    edge_roots : tuple of int
        ``max_integral_gain`` with a controller-pole strip: after the runs above, runs on
        the controllers whose free ``S`` has this many roots at the strip's edge
        (:class:`EdgeSpace`; a count above that polynomial's degree is skipped; ``()``,
        the default here, none; ``[solver] edge_runs``, true by default: :data:`EDGE_ROOTS`).  The
        integral gain grows as the controller's slow poles approach the strip (a lag at
        its edge multiplies it), and the optima seen sit there with two; the pole space
        names the nominal closed-loop poles, not the controller's, and its runs reached
        such a basin by luck.  Measured on seeded 4th-order stages at ``Ms_max`` 1.5 /
        1.75 / 2.0 / 2.25 / 2.5: 315 k / 430 k / 788 k / 411 k / 471 k -> 376 k / 722 k /
        994 k / 1,088 k / 1,062 k, 87 k / 115 k / 128 k / 139 k / 130 k -> 123 k / 227 k /
        324 k / 344 k / 364 k; not yet the default (docs/background/synthesis.md: stage
        102's tested monotone scan keeps it only with the best basin polished on,
        ``PolishOptions.again``, and both double ``paper_robust``'s CPU).
    edge_sigma : float
        The step size of the first run of each count, from the best point found so far
        (the second from a random mean at ``random_sigma``).
    edge_sizes : tuple of int
        Their populations, times the first run's.
    """

    seed: int = 20261128
    restarts: int = 4
    generations: int = 400
    stall: int = 40
    min_spread: float = 2e-4
    popsize: int = 14
    growth: int = 2
    seed_sigma: float = 0.05
    random_sigma: float = 0.3
    distinct: float = 0.02
    inside_sigma: float = 0.01
    inside_generations: int = 400
    inside_stall: int = 40
    progress: float = 1e-4
    active: bool = False
    edge_roots: tuple = ()
    edge_sigma: float = 0.1
    edge_sizes: tuple = (2, 4)


SEARCH = SearchOptions()   # the defaults: robrst.synthesis.robust's global phase
ZETA_MIN, ZETA_MAX = 0.005, 30.0   # damping range of a pole pair (zeta > 1: two real poles)
YOULA_RANGE = 30.0       # Youla degrees within +- this times |controller| ...
YOULA_SHAPE = 4.0        # ... on a sinh scale: |v| <= 1.3 |controller| over half the box
FREQ_PAD = 30.0          # pole frequencies within the plant's and start's / and x this
EDGE_ROOTS = (1, 2)      # [solver] edge_runs: one and two roots at the strip's edge
EDGE_INSIDE = 1e-3       # EdgeSpace: the roots this much (relative) inside the strip
SEED_GRID = 1e-2         # the first run's mean is rounded to this grid of the box (a fifth of
#                          its step size)


@dataclass(frozen=True, eq=False)
class PoleSpace:
    """Nominal closed-loop poles and Youla degrees -> controller vectors (module docstring).

    Use :meth:`of` to build it.

    Parameters
    ----------
    n_pairs : int
        Pole pairs.
    n_real : int
        Real poles (0 or 1).
    n_youla : int
        Free Youla degrees.
    log_w : tuple of float
        ``(lo, hi)`` of ``log w`` (scaled).
    log_zeta : tuple of float
        ``(lo, hi)`` of ``log zeta``.
    lead : float
        The nominal closed-loop polynomial's leading coefficient.
    pinv : numpy.ndarray
        Minimum-norm solution of the Diophantine rows.
    null : numpy.ndarray
        Their null space (columns).
    Dm, Dc : numpy.ndarray
        The nominal closed loop ``Delta = Dm x + Dc``.

    Attributes
    ----------
    dim : int
        Dimension of the search box.
    """

    n_pairs: int
    n_real: int
    n_youla: int
    log_w: tuple
    log_zeta: tuple
    lead: float
    pinv: np.ndarray
    null: np.ndarray
    Dm: np.ndarray
    Dc: np.ndarray

    @classmethod
    def of(cls, ctx: Context, setup: NLPSetup) -> PoleSpace | None:
        """The space of ``setup``'s controllers (``None`` when the nominal closed loop's
        leading coefficient depends on the controller, e.g. a biproper plant).

        Parameters
        ----------
        ctx : Context
            The synthesis's context (the plant family and the start).
        setup : NLPSetup
            The program with every coefficient free.

        Returns
        -------
        PoleSpace or None
        """
        (Dm, Dc), _ = closed_loop_maps(setup)(*setup.models[setup.ref][2:])
        if np.any(Dm[0] != 0) or Dc[0] == 0:
            return None
        M = Dm[1:]
        _, sv, Vt = np.linalg.svd(M)
        rank = int(np.sum(sv > 1e-10 * sv[0])) if sv.size else 0
        if rank < M.shape[0]:        # not coprime: some closed-loop polynomials unreachable
            return None
        N = M.shape[0]
        freqs = [np.abs(np.roots(ctx.Am)) / ctx.w0]
        for m in ctx.problem.family.models:
            freqs.append(np.abs(m.poles()) / ctx.w0)
            if m.m:
                freqs.append(np.abs(m.zeros()) / ctx.w0)
        f = np.concatenate(freqs)
        f = f[(f > 0) & np.isfinite(f)]
        lo, hi = (f.min() / FREQ_PAD, f.max() * FREQ_PAD) if f.size else (1e-2, 1e2)
        reg = setup.region
        zlo = max(ZETA_MIN, reg.zeta if reg is not None and reg.zeta else 0.0)
        return cls(n_pairs=N // 2, n_real=N % 2, n_youla=setup.n_x - rank,
                   log_w=(float(np.log(lo)), float(np.log(hi))),
                   log_zeta=(float(np.log(zlo)), float(np.log(ZETA_MAX))),
                   lead=float(Dc[0]), pinv=np.linalg.pinv(M), null=Vt[rank:].T, Dm=Dm, Dc=Dc)

    @property
    def dim(self):
        """Dimension of the search box."""
        return 2 * self.n_pairs + self.n_real + self.n_youla

    def _w(self, u):
        return np.exp(self.log_w[0] + (self.log_w[1] - self.log_w[0]) * u)

    def poles(self, theta: np.ndarray) -> np.ndarray:
        """The monic nominal closed-loop polynomials of the points ``theta``.

        Parameters
        ----------
        theta : numpy.ndarray
            ``(K, dim)`` in ``[0, 1]``.

        Returns
        -------
        numpy.ndarray
            ``(K, N + 1)`` coefficients (scaled), highest power first.
        """
        K = theta.shape[0]
        out = np.ones((K, 1))
        zl, zh = self.log_zeta
        for i in range(self.n_pairs):
            w = self._w(theta[:, 2 * i])
            z = np.exp(zl + (zh - zl) * theta[:, 2 * i + 1])
            new = np.zeros((K, out.shape[1] + 2))
            new[:, :-2] += out
            new[:, 1:-1] += out * (2 * z * w)[:, None]
            new[:, 2:] += out * (w * w)[:, None]
            out = new
        if self.n_real:
            w = self._w(theta[:, 2 * self.n_pairs])
            new = np.zeros((K, out.shape[1] + 1))
            new[:, :-1] += out
            new[:, 1:] += out * w[:, None]
            out = new
        return out

    def controllers(self, theta: np.ndarray) -> np.ndarray:
        """The decision vectors of the points ``theta``.

        Parameters
        ----------
        theta : numpy.ndarray
            ``(K, dim)`` in ``[0, 1]``.

        Returns
        -------
        numpy.ndarray
            ``(K, n_x)``.
        """
        am = self.poles(theta)
        X = (self.lead * am[:, 1:] - self.Dc[1:]) @ self.pinv.T
        if self.n_youla:
            size = np.linalg.norm(X, axis=1, keepdims=True)
            u = 2.0 * theta[:, -self.n_youla:] - 1.0
            v = np.sinh(YOULA_SHAPE * u) / np.sinh(YOULA_SHAPE) * YOULA_RANGE * size
            X = X + v @ self.null.T
        return X

    def symbolic(self, theta: ca.MX) -> ca.MX:
        """The decision vector of the point ``theta`` as a CasADi expression
        (:meth:`controllers` written again in CasADi: the polish over the poles,
        :class:`robrst.synthesis.template.MappedTemplate`).

        Parameters
        ----------
        theta : casadi.MX
            ``(dim, 1)``.

        Returns
        -------
        casadi.MX
            ``(n_x, 1)``.
        """
        (wl, wh), (zl, zh) = self.log_w, self.log_zeta
        am = [1.0]
        for i in range(self.n_pairs):
            w = ca.exp(wl + (wh - wl) * theta[2 * i])
            z = ca.exp(zl + (zh - zl) * theta[2 * i + 1])
            am = poly.conv_generic(am, [1.0, 2 * z * w, w * w])
        if self.n_real:
            am = poly.conv_generic(am, [1.0, ca.exp(wl + (wh - wl) * theta[2 * self.n_pairs])])
        X = ca.mtimes(ca.DM(self.pinv), self.lead * ca.vertcat(*am[1:]) - ca.DM(self.Dc[1:]))
        if self.n_youla:
            u = 2.0 * theta[self.dim - self.n_youla:] - 1.0
            v = ca.sinh(YOULA_SHAPE * u) * (YOULA_RANGE / np.sinh(YOULA_SHAPE)) * ca.norm_2(X)
            X = X + ca.mtimes(ca.DM(self.null), v)
        return X

    def point(self, xc: np.ndarray) -> np.ndarray | None:
        """The point of the box nearest to the controller ``xc`` (its nominal poles paired,
        its Youla degrees; clipped to the box), or ``None`` if its nominal closed loop is
        not stable.

        Parameters
        ----------
        xc : numpy.ndarray
            A decision vector.

        Returns
        -------
        numpy.ndarray or None
        """
        D = self.Dm @ np.asarray(xc, float)[:self.Dm.shape[1]] + self.Dc
        if not np.all(np.isfinite(D)) or D[0] == 0:
            return None
        r = np.roots(D)
        if np.any(r.real >= 0):
            return None
        cplx = sorted([v for v in r if v.imag > 1e-9 * abs(v)], key=abs)
        reals = sorted(-v.real for v in r if abs(v.imag) <= 1e-9 * abs(v))
        pairs = [(abs(v), -v.real / abs(v)) for v in cplx]
        need = self.n_pairs - len(pairs)
        if need < 0 or len(reals) != 2 * need + self.n_real:
            return None
        best = None
        for extra, single in _pairings(reals, need, self.n_real):
            th = self._theta(pairs + extra, single)
            miss = float(np.sum(np.abs(th - np.clip(th, 0.0, 1.0))))
            if best is None or miss < best[0]:
                best = (miss, th)
        th = list(np.clip(best[1], 0.0, 1.0))
        if self.n_youla:
            base = self.controllers(np.array([th + [0.5] * self.n_youla]))[0]
            size = max(np.linalg.norm(base), 1e-300)
            v = self.null.T @ (np.asarray(xc, float)[:len(base)] - base) / (YOULA_RANGE * size)
            u = np.arcsinh(v * np.sinh(YOULA_SHAPE)) / YOULA_SHAPE
            th += list((u + 1.0) / 2.0)
        return np.clip(np.array(th, float), 0.0, 1.0)

    def _theta(self, pairs, reals):
        """The box coordinates (unclipped) of pole pairs ``(w, zeta)`` and real poles."""
        (wl, wh), (zl, zh) = self.log_w, self.log_zeta
        th = []
        for w, z in sorted(pairs):
            th += [(np.log(w) - wl) / (wh - wl), (np.log(max(z, 1e-300)) - zl) / (zh - zl)]
        th += [(np.log(w) - wl) / (wh - wl) for w in reals]
        return np.array(th, float)


def _pairings(reals, pairs, singles):
    """Every way to group the real poles ``reals`` into ``pairs`` pairs (as ``(w, zeta)``)
    and ``singles`` single poles (at most a few hundred ways for the degrees met)."""
    if not reals:
        yield [], []
        return
    if len(reals) > 9:            # too many to enumerate: consecutive pairs
        out = [(np.sqrt(a * b), (a + b) / (2 * np.sqrt(a * b)))
               for a, b in zip(reals[:2 * pairs:2], reals[1:2 * pairs:2])]
        yield out, list(reals[2 * pairs:])
        return
    first, rest = reals[0], reals[1:]
    if singles and len(rest) >= 2 * pairs:
        for p, s in _pairings(rest, pairs, singles - 1):
            yield p, [first] + s
    if pairs:
        for i, b in enumerate(rest):
            w = np.sqrt(first * b)
            for p, s in _pairings(rest[:i] + rest[i + 1:], pairs - 1, singles):
                yield [(w, (first + b) / (2 * w))] + p, s


@dataclass(frozen=True, eq=False)
class EdgeSpace:
    """The controllers of a :class:`PoleSpace` moved to those whose free ``S`` has
    ``roots`` roots at the controller-pole strip's edge ``Re s = -shift``.

    The free polynomial's coefficients are affine in the decision vector (``x rowsᵀ +
    offset``, highest power first), so a root at ``-shift`` (and, for two, a double root:
    the derivative too) is a linear constraint ``A x = b``: each controller of the pole
    space is projected onto it (the least change of its scaled coefficients).  The root
    sits ``EDGE_INSIDE`` inside the strip.  The box and its dimension are the pole
    space's; a point's nominal closed-loop poles are those of the projected controller.

    Use :meth:`of` to build it.

    Parameters
    ----------
    space : PoleSpace
        The search box.
    A, b : numpy.ndarray
        The constraints ``A x = b`` (``(roots, n_x)``, ``(roots,)``).
    roots : int
        Roots at the edge.
    """

    space: PoleSpace
    A: np.ndarray
    b: np.ndarray
    roots: int

    @classmethod
    def of(cls, space: PoleSpace, rows: np.ndarray, offset: np.ndarray, shift: float,
           roots: int) -> EdgeSpace | None:
        """The space, or ``None`` when the free polynomial has fewer than ``roots`` roots.

        Parameters
        ----------
        space : PoleSpace
            The search box.
        rows, offset : numpy.ndarray
            The free ``S``'s coefficients ``x rowsᵀ + offset`` (scaled, highest first).
        shift : float
            The strip's edge (scaled, positive).
        roots : int
            1 or 2.

        Returns
        -------
        EdgeSpace or None
        """
        m = rows.shape[0] - 1
        if m < roots or roots < 1 or shift <= 0:
            return None
        p = -shift * (1.0 + EDGE_INSIDE)
        k = np.arange(m, -1, -1)                       # the powers, highest first
        V = [p ** k.astype(float)]
        if roots >= 2:
            V.append(np.where(k > 0, k * p ** np.maximum(k - 1, 0).astype(float), 0.0))
        V = np.array(V)
        A = V @ rows
        if np.linalg.matrix_rank(A) < len(V):
            return None
        return cls(space=space, A=A, b=-V @ offset, roots=roots)

    @property
    def dim(self):
        """Dimension of the search box (the pole space's)."""
        return self.space.dim

    def controllers(self, theta: np.ndarray) -> np.ndarray:
        """The decision vectors of the points ``theta``, projected onto the edge.

        Parameters
        ----------
        theta : numpy.ndarray
            ``(K, dim)`` in ``[0, 1]``.

        Returns
        -------
        numpy.ndarray
            ``(K, n_x)``.
        """
        X = self.space.controllers(theta)
        r = X @ self.A.T - self.b
        return X - np.linalg.solve(self.A @ self.A.T, r.T).T @ self.A


@dataclass(frozen=True, eq=False)
class Candidate:
    """A point the global phase found.

    Parameters
    ----------
    name : str
        Where it came from.
    xc : numpy.ndarray
        Its decision vector.
    theta : numpy.ndarray
        Its point of the search box.
    objective : float
        Its screened objective (larger is better).
    violation : float
        Its screened violation (0: feasible on the grid and the modes).
    run : int
        The CMA-ES run whose best it is (from 1; 0: a start or a point moved inside).
    """

    name: str
    xc: np.ndarray
    theta: np.ndarray
    objective: float
    violation: float
    run: int = 0


@dataclass(frozen=True, eq=False)
class GlobalSearch:
    """What the global phase did (``design --json``: ``starts.global_search``).

    Parameters
    ----------
    candidates : tuple of Candidate
        The distinct best points, best first.
    method : str
        The method.
    dimension : int
        Dimension of the search box.
    evaluations : int
        Candidates judged.
    generations : int
        Generations over every run.
    runs : int
        CMA-ES runs.
    cpu_s : float
        CPU time of the search [s] (the polish not included).
    stopped : bool
        The search was asked to stop before its end.
    """

    candidates: tuple
    method: str
    dimension: int
    evaluations: int
    generations: int
    runs: int
    cpu_s: float
    stopped: bool = False

    def as_dict(self) -> dict:
        """The JSON form.

        Returns
        -------
        dict
        """
        return {"method": self.method, "dimension": self.dimension,
                "evaluations": self.evaluations, "generations": self.generations,
                "runs": self.runs, "cpu_s": self.cpu_s, "stopped": self.stopped,
                "candidates": [{"name": c.name, "screened_objective": c.objective,
                                "screened_violation": c.violation} for c in self.candidates]}


def _key(figs, i):
    viol, obj = figs.keys()        # rounded: the same path on every numerical build
    return (float(viol[i]), -(float(obj[i]) if np.isfinite(obj[i]) else -np.inf))


def _progress(key, best, options):
    """Whether the ranking key ``key`` is progress over ``best``: a smaller violation, or
    an objective more than ``options.progress`` larger."""
    return key[0] < best[0] or key[1] < best[1] - options.progress


def global_search(screen: Screen, space: PoleSpace, starts: Sequence[tuple] = (),
                  options: SearchOptions = SEARCH,
                  stop: Callable[[], bool] | None = None,
                  say: Callable[[str], None] | None = None) -> GlobalSearch:
    """Search ``space`` for the best point by ``screen``'s figures (module docstring).

    Parameters
    ----------
    screen : Screen
        Rates populations of decision vectors.
    space : PoleSpace
        The search box.
    starts : sequence of (str, numpy.ndarray)
        Named decision vectors: the first run starts from the best of them (the others
        join the first population).
    options : SearchOptions
        Seed, runs, populations and stopping rules.
    stop : callable, optional
        Checked once per generation: true ends the search with what it has.
    say : callable, optional
        Progress (one line per run).

    Returns
    -------
    GlobalSearch
    """
    t0 = time.process_time()
    # one random stream per run (and one for the first mean): a run's length never
    # changes another run's samples
    o = options
    edges = _edges(screen, space, o)
    streams = [np.random.default_rng(s) for s in
               np.random.SeedSequence(o.seed).spawn(o.restarts + 1 + 2 * len(edges))]
    say = say or (lambda msg: None)
    stop = stop or (lambda: False)
    d = space.dim
    lam = max(o.popsize, 4 + int(3 * np.log(d)))
    count = {"evals": 0, "gens": 0, "runs": 0, "stopped": False}
    found = []            # (key, theta, name, run, decision vector or None)
    seeds = [(name, space.point(x)) for name, x in starts]
    seeds = [(n, th) for n, th in seeds if th is not None]
    if seeds:
        X = space.controllers(np.array([th for _, th in seeds]))
        figs = screen.rate(X)
        count["evals"] += len(seeds)
        k = int(figs.order()[0])
        # the first mean on a grid of the box: a start a solver computed (its late digits
        # those of the BLAS build) gives the same first run on every machine
        first = np.round(seeds[k][1] / SEED_GRID) * SEED_GRID
        first_name = seeds[k][0]
        for i, (n, th) in enumerate(seeds):
            found.append((_key(figs, i), th, n, 0, None))
    else:
        first, first_name = streams[o.restarts].uniform(0.2, 0.8, d), None
    plan = [(first, o.seed_sigma, f"from {first_name}" if first_name else "random mean", lam)]
    plan += [(streams[r].uniform(0.1, 0.9, d), o.random_sigma, "random mean",
              o.growth ** r * lam) for r in range(1, o.restarts)]

    def one_run(mean, sigma, rng, size, mapped, what):
        """One CMA-ES run over ``mapped``'s controllers; its best joins ``found``."""
        es = CMAES(mean, sigma, rng, size, o.active)
        run_best, last_gain = None, 0
        for g in range(o.generations):
            if stop():
                count["stopped"] = True
                break
            TH = es.ask()
            figs = screen.rate(mapped.controllers(TH), top=es.mu)   # it recombines mu
            count["evals"] += len(TH)
            count["gens"] += 1
            order = figs.order()
            es.tell(TH, order)
            k = int(order[0])
            key = _key(figs, k)
            if run_best is None or key < run_best[0]:
                if run_best is None or _progress(key, run_best[0], o):
                    last_gain = g
                run_best = (key, TH[k].copy())
            if g - last_gain > o.stall or es.spread < o.min_spread:
                break
        count["runs"] += 1
        r = count["runs"]
        if run_best is None:
            return
        name = f"{GLOBAL_START} {r} ({what})"
        xc = theta = None
        if mapped is space:
            theta = run_best[1]
        else:         # the projected controller, at its own point of the pole space
            xc = mapped.controllers(run_best[1][None])[0]
            theta = space.point(xc)
        if theta is not None:
            found.append((run_best[0], theta, name, r, xc))
        v, ob = run_best[0]
        say(f"global phase: run {r} ({what}): {es.generation} generations, best"
            + (f" screened objective {-ob:.5g}" if v == 0 else f" violation {v:.3g}"))

    for r, (mean, sigma, what, size) in enumerate(plan):
        one_run(mean, sigma, streams[r], size, space, what)
        if count["stopped"]:
            break
    best = min(found, key=lambda f: f[0])[1] if found else None   # of the runs above
    for i, edge in enumerate(edges):
        if count["stopped"] or best is None:
            break
        where = f"{edge.roots} controller pole{'s' if edge.roots > 1 else ''} at the strip's edge"
        # no comma in a run's name: its outcomes carry it before their first comma
        for j, (mean, sigma, how) in enumerate((
                (best, o.edge_sigma, "from the best so far"),
                (streams[o.restarts + 2 + 2 * i].uniform(0.1, 0.9, d), o.random_sigma,
                 "from a random mean"))):
            if not count["stopped"]:
                one_run(mean, sigma, streams[o.restarts + 1 + 2 * i + j],
                        o.edge_sizes[j] * lam, edge, f"{where} {how}")
    found.sort(key=lambda f: f[0])
    cands = []
    for key, th, name, run, xc in found:
        if any(np.max(np.abs(th - c.theta)) < o.distinct for c in cands):
            continue
        xc = space.controllers(th[None])[0] if xc is None else xc
        cands.append(Candidate(name=name, xc=xc, theta=th, objective=-key[1],
                               violation=key[0], run=run))
    return GlobalSearch(candidates=tuple(cands), method="CMA-ES", dimension=d,
                        evaluations=count["evals"], generations=count["gens"],
                        runs=count["runs"], cpu_s=time.process_time() - t0,
                        stopped=count["stopped"])


def _edges(screen, space, options):
    """The :class:`EdgeSpace` of each of ``options.edge_roots`` (``max_integral_gain`` with
    a controller-pole strip; none otherwise)."""
    st = screen.setup
    if st.objective != "max_integral_gain" or not st.ctrl_shift or screen.Lq.shape[0] < 2:
        return []
    out = [EdgeSpace.of(space, screen.Lq, screen.q, st.ctrl_shift, k) for k in
           options.edge_roots]
    return [e for e in out if e is not None]


def move_inside(screen: Screen, space: PoleSpace, cand: Candidate,
                options: SearchOptions = SEARCH) -> Candidate | None:
    """The candidate ``cand`` moved inside the specs of ``screen`` (a screen with tightened
    bounds): a narrow CMA-ES from its point, ranked by Deb's rules, so the nearest points
    that meet the tightened specs are found and then the best of them.

    A candidate the search leaves sits on the boundary of the screen's specs; a peak
    between the screen's frequencies or a step sample between its instants may then put
    it just outside the certificate's.  Moved a little inside, it certifies as it is.

    Parameters
    ----------
    screen : Screen
        The screen with the tightened specs.
    space : PoleSpace
        The search box.
    cand : Candidate
        The candidate.
    options : SearchOptions
        Its seed, population and narrow runs' settings.

    Returns
    -------
    Candidate or None
        ``None`` when no point inside was found.
    """
    o = options
    rng = np.random.default_rng(o.seed)
    lam = max(o.popsize, 4 + int(3 * np.log(space.dim)))
    figs = screen.rate(space.controllers(cand.theta[None]))
    best = (_key(figs, 0), cand.theta.copy())
    es = CMAES(cand.theta, o.inside_sigma, rng, lam, o.active)
    last = 0
    for g in range(o.inside_generations):
        TH = es.ask()
        figs = screen.rate(space.controllers(TH))
        order = figs.order()
        es.tell(TH, order)
        k = int(order[0])
        key = _key(figs, k)
        if key < best[0]:
            if _progress(key, best[0], o):
                last = g
            best = (key, TH[k].copy())
        if best[0][0] == 0 and g - last > o.inside_stall:
            break
    if best[0][0] > 0:
        return None
    return Candidate(name=f"{cand.name}, moved inside", xc=space.controllers(best[1][None])[0],
                     theta=best[1], objective=-best[0][1], violation=0.0)
