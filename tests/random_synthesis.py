"""Random synthesis problems: does robrst certify what a simple controller shows is possible?

:func:`evaluate` takes any problem generator ``gen(rng) -> Problem`` (the reliability
suite's, or :func:`local_problem` here), decides for each problem independently of the
synthesis whether a simple known controller meets its specs — the analytic pole
placement at the problem's poles, or an integral/PI controller from a small grid, each
checked by the exact certificate — and runs :func:`robrst.design.run_problem`.  Every
outcome must be an answer: a controller, ``status`` certified or not_certified, and
for the latter ``best_achievable`` (never a raw solver status).  :func:`table` formats
the counts for the README.
"""

import time
from dataclasses import dataclass, replace

import numpy as np

from robrst.certificate.proof import certify_problem
from robrst.design import analytic_design, run_problem
from robrst.base.errors import RobrstError
from robrst.core.family import parametric_family
from robrst.core.plant import Plant
from robrst.problem.records import ControllerStructure, PoleSpec, Problem, SolverOptions, Specs
from robrst.core.rst import RSTController
from robrst.core.thermal import ThermalCoefficients

__all__ = ["Case", "evaluate", "local_problem", "known_controller", "table"]


@dataclass(frozen=True)
class Case:
    """One random problem: what a simple controller shows, what robrst answered."""

    seed: int
    name: str
    known: str            # "analytic", "integral", "PI" or "" (none meets the specs)
    status: str           # "certified" | "not_certified" | "error: ..."
    answer: bool          # a controller came back with a status and, if uncertified, a summary
    seconds: float


def _pi_candidates(problem):
    """Integral and PI controllers by the loop crossover ``wc`` they give."""
    m = problem.family.reference_model
    dc = m.B[-1] / m.A[-1]
    poles = np.abs(np.roots(m.A))
    top = float(np.max(poles)) if poles.size else 1.0
    for wc in np.geomspace(top * 1e-4, top, 13):
        ki = wc / dc
        yield "integral", RSTController(R=[ki], S=[1.0, 0.0], T=[ki])
        for z in (1.0, 0.3):                              # PI zero at z * wc
            kp = ki / (z * wc)
            yield "PI", RSTController(R=[kp, ki], S=[1.0, 0.0], T=[ki])


def known_controller(problem):
    """The first simple controller that the exact certificate accepts ("" if none)."""
    try:
        if certify_problem(problem, analytic_design(problem).controller).certified:
            return "analytic"
    except RobrstError:
        pass
    m = problem.family.reference_model
    if m.A[-1] == 0 or m.B[-1] == 0:
        return ""
    for kind, ctrl in _pi_candidates(problem):
        if certify_problem(problem, ctrl).certified:
            return kind
    return ""


def local_problem(rng, index=0):
    """A random SISO problem: 1-4 poles (real, sometimes unstable, and resonant), maybe a
    zero, a thermal family, specs from loose to unreachable (``Mu_max`` below ``1/|D(0)|``
    in about 1 of 8)."""
    n_res = int(rng.integers(0, 3))
    n_real = int(rng.integers(1 if n_res == 0 else 0, 3))
    A = np.ones(1)
    for _ in range(n_res):
        w = 2 * np.pi * float(rng.uniform(200.0, 3000.0))
        z = float(10 ** rng.uniform(-2.3, -1.0))
        A = np.polymul(A, [1.0, 2 * z * w, w * w])
    for k in range(n_real):
        unstable = k == 0 and rng.uniform() < 0.15           # an unstable real pole
        A = np.polymul(A, [1.0, float(10 ** rng.uniform(1.5, 4.0)) * (-1.0 if unstable else 1.0)])
    B = np.ones(1)
    if len(A) > 2 and rng.uniform() < 0.3:                # one real zero, sometimes RHP
        zero = float(10 ** rng.uniform(3.0, 4.5)) * (-1.0 if rng.uniform() < 0.3 else 1.0)
        B = np.array([1.0, zero])
    gain = float(10 ** rng.uniform(-2, 1)) * (-1.0 if rng.uniform() < 0.15 else 1.0)
    B = B * gain * A[-1] / B[-1]
    nominal = Plant(B, A, label="T20C", temperature_C=20.0)
    temps = np.linspace(20.0, 40.0, int(rng.integers(1, 5)))
    coeffs = ThermalCoefficients(reference_C=20.0, gain_per_K=float(rng.uniform(0, 0.003)),
                                 resonance_per_K=-float(rng.uniform(0, 0.01)),
                                 damping_per_K=float(rng.uniform(0, 0.01)))
    family = parametric_family(nominal, temps, coeffs)
    poles_abs = np.abs(np.roots(A))
    wn = float(np.min(poles_abs)) * float(rng.uniform(0.1, 0.5))
    specs = Specs(Ms_max=float(rng.uniform(1.3, 2.5)), Mt_max=float(rng.uniform(1.1, 1.5)),
                  Mu_max=float(abs(1.0 / nominal.dc_gain) * 10 ** rng.uniform(-0.2, 1.5)))
    if rng.uniform() < 0.3 and float(np.max(poles_abs)) < 2 * np.pi * 2000.0:
        specs = replace(specs, sample_rate_hz=20000.0)
    objective = ("max_integral_gain", "max_integral_gain", "feasibility")[int(rng.integers(0, 3))]
    return Problem(name=f"random_{index}", family=family,
                   poles=PoleSpec(wn=wn, zeta=1.0),
                   controller=ControllerStructure(extra_degree=int(rng.integers(0, 3))),
                   specs=specs, solver=SolverOptions(method="nlp", objective=objective,
                                                     n_freq=80, cert_temperatures=15))


def evaluate(generator, n, seed=0, only_solvable=True, indices=None):
    """Run ``n`` problems of ``generator(rng) -> Problem``; returns the :class:`Case` list.

    Problem ``i`` uses ``numpy.random.default_rng([seed, i])`` (``indices`` picks some).
    With ``only_solvable`` the problems no simple controller solves are skipped (they
    still get an answer when run, but do not count for the certification rate).
    """
    cases = []
    for i in (range(n) if indices is None else indices):
        rng = np.random.default_rng([seed, i])
        try:
            problem = generator(rng)
        except RobrstError:
            continue
        known = known_controller(problem)
        if only_solvable and not known:
            continue
        t0 = time.process_time()
        try:
            res = run_problem(problem)
            status = res.status
            answer = res.controller is not None and (res.certified or bool(res.best_achievable))
        except RobrstError as exc:
            status, answer = f"error: {exc}", False
        cases.append(Case(seed=i, name=problem.name, known=known, status=status, answer=answer,
                          seconds=time.process_time() - t0))
    return cases


def table(cases):
    """Markdown rows: per simple controller, how many robrst certified."""
    rows = ["| known simple controller | problems | certified | answered (no raw status) |"
            " median CPU [s] |", "|---|---|---|---|---|"]
    for kind in sorted({c.known for c in cases}):
        sub = [c for c in cases if c.known == kind]
        rows.append(f"| {kind or 'none'} | {len(sub)} |"
                    f" {sum(c.status == 'certified' for c in sub)} |"
                    f" {sum(c.answer for c in sub)} |"
                    f" {np.median([c.seconds for c in sub]):.2f} |")
    return rows
