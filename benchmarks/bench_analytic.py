"""Analytic pole placement: scaled Sylvester solve vs the unscaled solve a user writes."""

from fractions import Fraction

import numpy as np

from benchmarks.harness import BenchResult, alternate, median_ratio
from robrst.core import poly
from robrst.core.plant import paper_plant
from robrst.synthesis import analytic


def user_solve(A, B, Am):
    """The direct code: Sylvester matrix of ``A s`` and ``B``, ``numpy.linalg.solve``.

    Unknowns ``S'`` (monic, leading 1 moved to the right-hand side) and ``R``, with
    ``A s S' + B R = Am``; no scaling, no equilibration.
    """
    Ap = np.polymul(A, [1.0, 0.0])
    na = len(Ap) - 1
    ks = len(Am) - 1 - na
    N = na + ks
    cols = []
    for j in range(ks - 1, -1, -1):
        cols.append(np.concatenate([np.zeros(N - len(Ap) - j), Ap, np.zeros(j)])[-N:])
    for j in range(na - 1, -1, -1):
        col = np.concatenate([B, np.zeros(j)])
        cols.append(np.concatenate([np.zeros(N - len(col)), col]))
    M = np.column_stack(cols)
    rhs = (Am - np.concatenate([Ap, np.zeros(ks)]))[1:]
    x = np.linalg.solve(M, rhs)
    S = np.polymul([1.0, 0.0], np.concatenate([[1.0], x[:ks]]))
    R = x[ks:]
    return R, S


def exact_residual(A, B, R, S, Am):
    """``max_k |(A S + B R - Am)_k| / |Am_k|`` in exact rational arithmetic.

    Independent of both solvers and of floating-point cancellation: every
    coefficient of the closed-loop polynomial is compared with its own target.
    """
    A, B, R, S, Am = ([Fraction(float(x)) for x in c] for c in (A, B, R, S, Am))

    def mul(a, b):
        out = [Fraction(0)] * (len(a) + len(b) - 1)
        for i, x in enumerate(a):
            for j, y in enumerate(b):
                out[i + j] += x * y
        return out

    AS, BR = mul(A, S), mul(B, R)
    n = max(len(AS), len(BR), len(Am))
    pad = lambda c: [Fraction(0)] * (n - len(c)) + c  # noqa: E731
    lhs = [x + y for x, y in zip(pad(AS), pad(BR))]
    return max(float(abs(v - m) / abs(m)) for v, m in zip(lhs, pad(Am)) if m != 0)


def _cases(n_random, seed):
    """(label, A, B, Am): the paper's plant (eq. 4) and random stiff coprime plants."""
    rng = np.random.default_rng(seed)
    p = paper_plant()
    am = analytic.characteristic_polynomial(analytic.PoleSpec(wn=600.0, zeta=1.0), 2 * p.n)[0]
    cases = [("paper D(s)", p.A, p.B, am)]
    for i in range(n_random):
        n = int(rng.integers(2, 5))
        wr = 10.0 ** rng.uniform(1.5, 4.5, size=n)       # plant poles over three decades
        A = poly.from_roots(-wr)
        B = np.array([float(np.prod(wr)) * rng.uniform(0.3, 3.0)])
        wn = 10.0 ** rng.uniform(2, 3.5)
        Am = analytic.characteristic_polynomial(analytic.PoleSpec(wn=wn, zeta=0.8), 2 * n)[0]
        cases.append((f"random n={n}", A, B, Am))
    return cases


def run(tiny=False, repeats=15, seed=1):
    cases = _cases(2 if tiny else 20, seed)
    repeats = 2 if tiny else repeats
    ratios, res_ratio, worst_user, worst_robrst = [], [], 0.0, 0.0
    for _, A, B, Am in cases:
        fns = {"robrst": lambda: analytic.solve_diophantine(A, B, Am),
               "user": lambda: user_solve(A, B, Am)}
        times, out = alternate(fns, repeats)
        ratios.append(median_ratio(times, "robrst", "user"))
        sol = out["robrst"]
        r_user = exact_residual(A, B, *out["user"], Am)
        r_rob = exact_residual(A, B, sol.R, sol.S, Am)
        worst_user, worst_robrst = max(worst_user, r_user), max(worst_robrst, r_rob)
        res_ratio.append(r_user / max(r_rob, np.finfo(float).eps ** 2))
    t_ratio = float(np.median(ratios))
    gain = worst_user / worst_robrst
    figures = {"time_ratio_median": t_ratio, "time_ratio_per_case": ratios,
               "residual_ratio_worst_case": gain, "residual_ratio_per_case": res_ratio,
               "worst_residual_user": worst_user, "worst_residual_robrst": worst_robrst,
               "cases": len(cases)}
    return BenchResult(
        name="analytic pole placement", robrst_path="scaled, equilibrated Sylvester + checks",
        baseline="unscaled numpy.linalg.solve", goal="time ≤ 2×, residual ≥ 1e6× smaller",
        headline=(f"time {t_ratio:.2f}×; worst exact residual {worst_robrst:.1e} vs"
                  f" {worst_user:.1e} ({gain:.1e}× smaller; paper plant: both"
                  f" {res_ratio[0]:.1f}× apart)"),
        met=bool(t_ratio <= 2.0 and gain >= 1e6), figures=figures)
