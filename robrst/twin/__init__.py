"""Digital twin of the piezo actuator: config -> symbolic model -> compiled simulation."""

from robrst.twin.config import EFFECTS, TwinConfig, default_twin, load_twin, parse_twin
from robrst.twin.model import TwinModel, build_model
from robrst.twin.simulate import SimResult, Simulator, simulate

__all__ = ["EFFECTS", "TwinConfig", "default_twin", "load_twin", "parse_twin", "TwinModel",
           "build_model", "SimResult", "Simulator", "simulate"]
