"""The design pipeline: a typed problem in, a :class:`DesignResult` out.

:func:`run_problem` runs the method the problem asks for, certifies the controller on the
whole family, analyses every family model, checks a synthesised controller against the
closed-form Diophantine solution and compares it with an analytic design
(:mod:`robrst.design.pipeline`).
"""

from robrst.design.pipeline import (ARTEFACT_FORMAT, AnalyticCheck, Comparison, DesignResult,
                                    analytic_check, analytic_design, artefact_record,
                                    comparison, run_problem, with_time_domain)

__all__ = ["DesignResult", "AnalyticCheck", "Comparison", "run_problem", "analytic_design",
           "analytic_check", "comparison", "with_time_domain", "artefact_record",
           "ARTEFACT_FORMAT"]
