"""Exchange method for the grid constraints of the robust NLP (semi-infinite programming).

A peak bound ``|N(j nu)| <= M |Delta(j nu)|`` on a frequency grid of every model
is a large set of constraints of which only a few are active at the optimum: the
points next to each peak.  Imposing all of them makes every IPOPT iteration factor
a KKT matrix with a dense ``(models x frequencies) x variables`` Jacobian block,
whose cost grows faster than the grid.  The exchange method solves the NLP on an
*active subset* of grid points, evaluates every grid point numerically at the
solution (cheap: a matrix-vector product per block), adds the local maxima that
violate — or nearly reach — their bound, and solves again from the previous
solution, until no grid point is violated.

The active set only grows, so the loop ends after finitely many rounds; the final
point satisfies every grid constraint, and since it is a (local) optimum of a
relaxation of the full-grid program it is a (local) optimum of the full-grid
program too.
"""

from dataclasses import dataclass, replace

import numpy as np

from robrst.synthesis.nlp import build_and_solve, grid_blocks

__all__ = ["ExchangeInfo", "solve_exchange", "local_maxima"]
NEAR_ACTIVE = 0.02      # local maxima within 2 % below the bound join the active set
COARSE_POINTS = 16     # evenly spaced starting points per block (plus local maxima)


@dataclass(frozen=True)
class ExchangeInfo:
    """How the exchange went: rounds, IPOPT iterations, active and total grid points."""

    rounds: int
    iterations: int
    active_points: int
    grid_points: int
    max_grid_ratio: float   # max over every grid point of |N| / (M |Delta|) at the result


def local_maxima(r):
    """Indices of the local maxima of ``r`` (end points included, plateaus once)."""
    r = np.asarray(r, float)
    if r.size <= 2:
        return np.arange(r.size)
    left = np.r_[True, r[1:] > r[:-1]]
    right = np.r_[r[:-1] >= r[1:], True]
    return np.flatnonzero(left & right)


def _gamma(setup, x):
    return float(x[-1]) if setup.objective == "min_Ms" else None


def _initial_active(blocks, x, gamma, coarse_points):
    active = []
    for b in blocks:
        n = len(b.nu)
        coarse = np.unique(np.linspace(0, n - 1, min(n, coarse_points)).round().astype(int))
        active.append(np.union1d(coarse, local_maxima(b.ratio(x, gamma))))
    return active


def _grow(blocks, active, x, gamma):
    """Add the near-active (or violated) local maxima.

    Returns ``(new active, number added, largest ratio over the whole grid)``.
    """
    added, out, worst = 0, [], 0.0
    for b, idx in zip(blocks, active):
        r = b.ratio(x, gamma)
        worst = max(worst, float(r.max()))
        peaks = local_maxima(r)
        # a violated point lies below a violated local maximum, so peaks cover violations
        new = np.setdiff1d(peaks[r[peaks] > 1.0 - NEAR_ACTIVE], idx)
        added += new.size
        out.append(np.union1d(idx, new))
    return out, added, worst


def solve_exchange(setup, x0, ipopt_opts, max_rounds=50, coarse_points=COARSE_POINTS):
    """Solve the NLP of ``setup`` on its whole grid by constraint exchange.

    Parameters
    ----------
    setup : NLPSetup
    x0 : ndarray
        Starting point (scaled decision vector); also the point whose closed-loop
        ``|Delta|^2`` weights every grid constraint.
    ipopt_opts : dict
    max_rounds : int
        Safety cap on exchange rounds (the active set grows every round, so the
        loop ends anyway once the whole grid is active).
    coarse_points : int
        Evenly spaced grid points per block in the first active set, next to the
        local maxima of each constraint at ``x0``.

    Returns
    -------
    SolveResult
        The last subproblem's result with ``iterations`` summed over the rounds and
        ``exchange`` an :class:`ExchangeInfo`.
        A subproblem that fails is returned at once: it is a relaxation of the
        full-grid program, so infeasibility IPOPT reports for it holds for the
        full program as well (as far as IPOPT's local verdict goes).  If the
        round cap is hit first, the certificate of the caller has the last word.
    """
    x0 = np.asarray(x0, float)
    blocks = grid_blocks(setup, x0)
    total = sum(len(b.nu) for b in blocks)
    active = _initial_active(blocks, x0, _gamma(setup, x0), coarse_points)
    x, iters = x0, 0
    for rnd in range(1, max_rounds + 1):
        res = build_and_solve(setup, x, ipopt_opts, blocks, active)
        x = res.x
        iters += res.iterations
        if not res.success:
            worst = max((float(b.ratio(x, _gamma(setup, x)).max()) for b in blocks), default=0.0)
            break
        active, added, worst = _grow(blocks, active, x, _gamma(setup, x))
        if added == 0:
            break
    info = ExchangeInfo(rounds=rnd, iterations=iters,
                        active_points=int(sum(a.size for a in active)), grid_points=total,
                        max_grid_ratio=worst)
    return replace(res, iterations=iters, exchange=info)
