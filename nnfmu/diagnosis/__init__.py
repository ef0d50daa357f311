"""Residual diagnosis, torch-free: classical residual tests and a library of physical effects ranked by the variance
each explains out of sample, beside every measured channel the model does not use (`input:<channel>`), each effect
with the model extension that would take it in (`effects`), and the vehicle loop's effects with their terms in the
co-simulation (`SYSTEM_EFFECTS`). Imports numpy, scipy, `nnfmu.kinds`, `nnfmu.data` and `nnfmu.models.features` only
(no torch, fmpy, compiler), so any stage can diagnose. Other floors import only the names below."""

from nnfmu.diagnosis.correlation import newey_west_variance
from nnfmu.diagnosis.diagnose import FamilyGains, diagnose
from nnfmu.diagnosis.effects import (
    EFFECTS,
    SYSTEM_EFFECTS,
    ChannelInput,
    Effect,
    Extension,
    NoExtension,
    Regressors,
    SystemEffect,
    Term,
    channel_effects,
    effects_for,
    find_effect,
    select_effects,
)
from nnfmu.diagnosis.errors import DiagnosisError
from nnfmu.diagnosis.evidence import Diagnosis, EffectEvidence
from nnfmu.diagnosis.ranking import GainTest, cross_fit_errors, extend_base, fold_mask
from nnfmu.diagnosis.residual_tests import ResidualTest, residual_tests
from nnfmu.diagnosis.settings import DiagnosisSettings

__all__ = [
    "EFFECTS",
    "SYSTEM_EFFECTS",
    "ChannelInput",
    "Diagnosis",
    "DiagnosisError",
    "DiagnosisSettings",
    "Effect",
    "EffectEvidence",
    "Extension",
    "FamilyGains",
    "GainTest",
    "NoExtension",
    "Regressors",
    "ResidualTest",
    "SystemEffect",
    "Term",
    "channel_effects",
    "cross_fit_errors",
    "diagnose",
    "effects_for",
    "extend_base",
    "find_effect",
    "fold_mask",
    "newey_west_variance",
    "residual_tests",
    "select_effects",
]
