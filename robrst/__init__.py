"""robrst — robust RST control of piezoelectric actuators.

The entry points a user needs, importable from the top level::

    import robrst
    problem = robrst.load_problem("paper_robust")     # a file path or a built-in name
    result = robrst.run_problem(problem)              # synthesis -> certificate
    robrst.write_design_report(result, "out/paper_robust")

Plants and controllers (:class:`Plant`, :class:`RSTController`, :func:`pole_placement`),
analysis (:func:`analyze`, :func:`certify`), the digital controller out
(:func:`export_controller`), margin regression tests (:func:`assert_margins`), the digital
twin (:func:`simulate`), the gap diagnosis (``robrst.diagnose.diagnose``), sweeps
(:func:`load_sweep`, :func:`run_sweep`: Monte Carlo, trade-offs and fleets on Dask),
multi-axis actuators (:func:`load_mimo_problem`, :func:`design_mimo`,
:func:`export_mimo`) and the reports.  Names are loaded on first use, so ``import robrst``
stays cheap.
"""

import importlib

__version__ = "0.1.0"

_EXPORTS = {
    # errors
    "RobrstError": "robrst.base.errors", "SpecError": "robrst.base.errors", "DegreeError": "robrst.base.errors",
    "CoprimeError": "robrst.base.errors", "DataError": "robrst.base.errors",
    "SolverError": "robrst.base.errors", "InfeasibleError": "robrst.base.errors",
    "OutputError": "robrst.base.errors",
    # maths core
    "Plant": "robrst.core.plant", "paper_plant": "robrst.core.plant",
    "PlantFamily": "robrst.core.family", "parametric_family": "robrst.core.family",
    "explicit_family": "robrst.core.family", "ThermalCoefficients": "robrst.core.thermal",
    "RSTController": "robrst.core.rst", "discretize": "robrst.core.rst",
    "analyze": "robrst.core.analysis", "peak_gain": "robrst.core.peaks",
    "sampled_plant": "robrst.core.sampled",
    "tustin_polynomials": "robrst.core.rst", "closed_loop_control": "robrst.core.rst",
    "digital_controller": "robrst.controller.digital", "DigitalController": "robrst.controller.digital",
    # problems and design
    "Problem": "robrst.problem.records", "PoleSpec": "robrst.problem.records",
    "ControllerStructure": "robrst.problem.records", "Specs": "robrst.problem.records",
    "SolverOptions": "robrst.problem.records",
    "load_problem": "robrst.problem.files", "parse_problem": "robrst.problem.files",
    "check_problem": "robrst.problem.documents",
    "certify": "robrst.certificate.proof", "certify_problem": "robrst.certificate.proof",
    "pole_placement": "robrst.synthesis.analytic",
    "run_problem": "robrst.design", "DesignResult": "robrst.design",
    "Synthesizer": "robrst.synthesis.synthesizer", "step_metrics": "robrst.certificate.steps",
    # twin, data, diagnosis
    "default_twin": "robrst.twin.config", "load_twin": "robrst.studies.twins",
    "simulate": "robrst.twin.simulate",
    "Dataset": "robrst.data.dataset", "load_dataset": "robrst.data.dataset",
    "save_dataset": "robrst.data.dataset",
    # the digital controller out, users' regression tests
    "export_controller": "robrst.controller.export",
    "ExportedController": "robrst.controller.export",
    "assert_margins": "robrst.testing",
    # saved designs: read back and certified again, never designed again
    "load_design": "robrst.controller.artefact", "recertify": "robrst.controller.artefact",
    # sweeps
    "Sweep": "robrst.studies.sweep.files", "load_sweep": "robrst.studies.sweep.files",
    "run_sweep": "robrst.studies.sweep.engine", "SweepResult": "robrst.studies.sweep.engine",
    # multi-axis actuators (MIMO plants, decentralised RST with a decoupler)
    "MimoPlant": "robrst.core.mimo", "MimoFamily": "robrst.core.mimo",
    "MimoController": "robrst.core.mimo_loop", "MimoProblem": "robrst.problem.mimo",
    "MimoSpecs": "robrst.problem.mimo", "MimoStructure": "robrst.problem.mimo",
    "MimoSolverOptions": "robrst.problem.mimo", "load_mimo_problem": "robrst.problem.mimo_files",
    "certify_mimo": "robrst.certificate.mimo", "design_mimo": "robrst.design.mimo",
    "MimoDesignResult": "robrst.design.mimo", "export_mimo": "robrst.controller.mimo_export",
    # reports
    "write_design_report": "robrst.report.design",
    "write_sweep_report": "robrst.report.sweep",
    "write_diagnosis_report": "robrst.report.diagnosis",
}

__all__ = ["__version__", *_EXPORTS]


def __getattr__(name):
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'robrst' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(__all__)
