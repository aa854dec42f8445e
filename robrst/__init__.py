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
(:func:`load_sweep`, :func:`run_sweep`: Monte Carlo, trade-offs and fleets on Dask) and the
reports.  Names are loaded on first use, so
``import robrst`` stays cheap.
"""

import importlib

__version__ = "0.1.0"

_EXPORTS = {
    # errors
    "RobrstError": "robrst.errors", "SpecError": "robrst.errors", "DegreeError": "robrst.errors",
    "CoprimeError": "robrst.errors", "DataError": "robrst.errors",
    "SolverError": "robrst.errors", "InfeasibleError": "robrst.errors",
    "OutputError": "robrst.errors",
    # maths core
    "Plant": "robrst.plant", "paper_plant": "robrst.plant",
    "PlantFamily": "robrst.family", "parametric_family": "robrst.family",
    "explicit_family": "robrst.family", "ThermalCoefficients": "robrst.thermal",
    "RSTController": "robrst.rst", "discretize": "robrst.rst",
    "analyze": "robrst.analysis", "peak_gain": "robrst.hinf",
    "sampled_plant": "robrst.sampled",
    "tustin_polynomials": "robrst.rst", "closed_loop_control": "robrst.rst",
    "digital_controller": "robrst.digital", "DigitalController": "robrst.digital",
    # problems and design
    "Problem": "robrst.problem", "PoleSpec": "robrst.problem",
    "ControllerStructure": "robrst.problem", "Specs": "robrst.problem",
    "SolverOptions": "robrst.problem",
    "load_problem": "robrst.spec", "parse_problem": "robrst.spec",
    "certify": "robrst.certificate", "certify_problem": "robrst.certificate",
    "pole_placement": "robrst.synthesis.analytic",
    "run_problem": "robrst.design", "DesignResult": "robrst.design",
    "Synthesizer": "robrst.synthesis.synthesizer", "step_metrics": "robrst.timespec",
    # twin, data, diagnosis
    "default_twin": "robrst.twin.config", "load_twin": "robrst.twin.config",
    "simulate": "robrst.twin.simulate",
    "Dataset": "robrst.dataset", "load_dataset": "robrst.dataset",
    "save_dataset": "robrst.dataset",
    # the digital controller out, users' regression tests
    "export_controller": "robrst.export", "ExportedController": "robrst.export",
    "assert_margins": "robrst.testing",
    # sweeps
    "Sweep": "robrst.sweep.spec", "load_sweep": "robrst.sweep.spec",
    "run_sweep": "robrst.sweep.engine", "SweepResult": "robrst.sweep.engine",
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
