"""Design problems: frozen records (:mod:`~robrst.problem.records`), problem files
(:mod:`~robrst.problem.files`) and the checks of what keys mean together
(:mod:`~robrst.problem.checks`)."""
