"""The design pipeline: a typed problem in, a :class:`DesignResult` out.

:func:`run_problem` (:mod:`robrst.design._pipeline`) runs the method the problem asks for,
certifies the controller on the whole family, analyses every family model, checks a
synthesised controller against the closed-form Diophantine solution and compares it with
an analytic design.  The modules, bottom to top:

* ``achieved``: what a design achieves (the analytic check, the comparison, the achieved
  specs, the factored controller, the solver's and the multi-start's summaries);
* ``result``: :class:`DesignResult`;
* ``contract``: the JSON contract of ``robrst design --json``, written from the records;
* ``candidate``: one synthesis -> feedback -> reference path -> certificate; the analytic
  design, the analytic check and the comparison;
* ``multistart``: the robust program from diverse starts on worker processes (no longer
  the default path: the robust synthesis's global phase runs in process);
* ``_single``: the design of one problem (no spread);
* ``fleet``: the scenario loop of a problem with a ``[spread]``;
* ``_pipeline``: :func:`run_problem`.
"""

from robrst.certificate.completion import with_time_domain
from robrst.design.candidate import analytic_check, analytic_design, comparison
from robrst.design.contract import ARTEFACT_FORMAT, artefact_record, design_json
from robrst.design._pipeline import run_problem
from robrst.design.achieved import AnalyticCheck, Comparison
from robrst.design.result import DesignResult

__all__ = ["DesignResult", "AnalyticCheck", "Comparison", "run_problem", "analytic_design",
           "analytic_check", "comparison", "with_time_domain", "artefact_record",
           "design_json", "ARTEFACT_FORMAT"]
