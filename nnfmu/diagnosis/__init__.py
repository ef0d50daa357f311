"""Residual diagnosis, torch-free: classical residual tests and a library of physical effects ranked by the variance
each explains out of sample, beside every measured channel the model does not use (`input:<channel>`), each effect
with the model extension that would take it in (`effects`). Imports numpy,
scipy, `nnfmu.data` and `nnfmu.models.features` only (no torch, fmpy, compiler), so any stage can diagnose."""

from nnfmu.diagnosis.diagnose import FamilyGains, diagnose
from nnfmu.diagnosis.effects import (
    EFFECTS,
    ChannelInput,
    Effect,
    Extension,
    NoExtension,
    Regressors,
    channel_effects,
    effects_for,
    find_effect,
    select_effects,
)
from nnfmu.diagnosis.errors import DiagnosisError
from nnfmu.diagnosis.evidence import Diagnosis, EffectEvidence
from nnfmu.diagnosis.residual_tests import ResidualTest, residual_tests
from nnfmu.diagnosis.settings import DiagnosisSettings

__all__ = [
    "EFFECTS",
    "ChannelInput",
    "Diagnosis",
    "DiagnosisError",
    "DiagnosisSettings",
    "Effect",
    "EffectEvidence",
    "Extension",
    "FamilyGains",
    "NoExtension",
    "Regressors",
    "ResidualTest",
    "channel_effects",
    "diagnose",
    "effects_for",
    "find_effect",
    "residual_tests",
    "select_effects",
]
