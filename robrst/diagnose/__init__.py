"""Sim-to-real gap diagnosis: where the gap lies, which effects cause it, how far it shrinks."""

from robrst.diagnose._diagnosis import diagnose
from robrst.diagnose._effects import EFFECTS
from robrst.diagnose.result import Diagnosis, EffectScore

__all__ = ["Diagnosis", "EffectScore", "diagnose", "EFFECTS"]
