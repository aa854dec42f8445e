"""Sim-to-real gap diagnosis: where the gap lies, which effect causes it, how far it shrinks."""

from robrst.diagnose.core import Diagnosis, EffectScore, diagnose
from robrst.diagnose.effects import EFFECTS

__all__ = ["Diagnosis", "EffectScore", "diagnose", "EFFECTS"]
