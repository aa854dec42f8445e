"""The design pipeline: problem -> plant family -> synthesis -> certificate -> result."""

from dataclasses import dataclass

import numpy as np

from robrst.analysis import analyze
from robrst.certify import certify
from robrst.synthesis import analytic

__all__ = ["DesignResult", "run_problem", "analytic_design", "sampled_summary"]


@dataclass(frozen=True, eq=False)
class DesignResult:
    """A certified (or explicitly uncertified) design and everything reported about it."""

    problem: object
    method: str
    controller: object
    target_char_poly: object
    analyses: tuple
    certificate: object
    solver: dict
    analytic_check: dict = None
    comparison: dict = None

    @property
    def certified(self):
        return self.certificate.certified

    def as_dict(self):
        """The public JSON contract of ``robrst design --json`` (fields are only added)."""
        p = self.problem
        models = [a.as_dict(m) for a, m in zip(self.analyses, p.family.models)]
        out = {
            "problem": p.name,
            "method": self.method,
            "controller": self.controller.as_dict(),
            "target_char_poly": None if self.target_char_poly is None
            else np.asarray(self.target_char_poly).tolist(),
            "specs": {**{k: p.specs.get(k) for k in ("Ms_max", "Mt_max", "Mu_max")},
                      **({k: p.specs[k] for k in ("sample_rate_hz", "delay_samples")}
                         if p.specs.get("sample_rate_hz") else {})},
            "models": models,
            "certified": bool(self.certified),
            "certificate": self.certificate.as_dict(),
            "solver": self.solver,
        }
        if self.analytic_check is not None:
            out["analytic_check"] = self.analytic_check
        if self.comparison is not None:
            out["comparison"] = self.comparison
        return out


def analytic_design(problem, poles=None):
    """Pole placement on the reference model of ``problem`` (the paper's method)."""
    c = problem.controller
    return analytic.design(
        problem.family.reference_model, poles or problem.poles, S_fixed=c["S_fixed"],
        R_fixed=c["R_fixed"], extra_degree=c["extra_degree"], t_mode=c["T_mode"],
        t_zeros=c["T_zeros"],
    )


def _certify(problem, ctrl):
    s = problem.solver
    return certify(problem.family, ctrl, problem.specs, n_sweep=s["cert_temperatures"],
                   rtol=s["cert_tol"])


def run_problem(problem, progress=None):
    """Run the design the problem file asks for and certify it.

    Parameters
    ----------
    problem : robrst.spec.Problem
    progress : callable, optional
        Called with one line of text per stage (certification rounds included).

    Returns
    -------
    DesignResult
        Raises :class:`robrst.errors.SolverError` (or a subclass) on failure.
    """
    say = progress or (lambda msg: None)
    method = problem.solver["method"]
    if method == "analytic":
        ctrl, info = analytic_design(problem)
        say(f"analytic pole placement: cond(scaled Sylvester) = {info['cond']:.3g}"
            f" (unscaled {info['cond_unscaled']:.3g})")
        solver = {"name": "sylvester", "w0_rad_s": info["w0"], "cond": info["cond"],
                  "cond_unscaled": info["cond_unscaled"], "residual": info["residual"]}
        Am = info["Am"]
        extra = {}
    else:
        from robrst.synthesis.robust import robust_design

        ctrl, Am, solver, extra = robust_design(problem, say)
    cert = extra.pop("certificate", None) or _certify(problem, ctrl)
    analyses = tuple(analyze(m, ctrl) for m in problem.family.models)
    return DesignResult(problem=problem, method=method, controller=ctrl, target_char_poly=Am,
                        analyses=analyses, certificate=cert, solver=solver, **extra)


def sampled_summary(d):
    """One line on the sampled loop's certificate (``None`` when not asked for)."""
    sp, models = d["specs"], d["certificate"]["models"]
    if not sp.get("sample_rate_hz") or not models or "Ms_sampled" not in models[0]:
        return None
    worst = {k: max(m[f"{k}_sampled"] for m in models) for k in ("Ms", "Mt", "Mu")}
    stable = all(m["stable_sampled"] for m in models)
    return (f"sampled loop (ZOH plant, Tustin controller at {sp['sample_rate_hz']:g} Hz,"
            f" {sp.get('delay_samples', 0)} samples delay): worst Ms {worst['Ms']:.4g},"
            f" Mt {worst['Mt']:.4g}, Mu {worst['Mu']:.4g} V/µm;"
            f" {'all stable' if stable else 'NOT all stable'}")
