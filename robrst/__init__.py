"""robrst — robust RST control of piezoelectric actuators.

Pipeline: problem file -> plant family -> synthesis -> certificate -> report.
"""

from robrst.errors import (CoprimeError, DataError, DegreeError, InfeasibleError,
                           RobrstError, SolverError, SpecError)
from robrst.family import PlantFamily, ThermalCoefficients, explicit_family, parametric_family
from robrst.plant import Plant, paper_plant
from robrst.rst import RSTController

__version__ = "0.1.0"

__all__ = [
    "Plant", "paper_plant", "PlantFamily", "ThermalCoefficients", "parametric_family",
    "explicit_family", "RSTController", "RobrstError", "SpecError", "DegreeError",
    "CoprimeError", "DataError", "SolverError", "InfeasibleError",
]
