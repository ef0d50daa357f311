"""Closing the loop: diagnose a model's residual with classical residual tests and a library of physical effects
ranked by the variance each explains out of sample."""

from .diagnose import diagnose
from .effects import EFFECTS, EffectFamily, Regressors, select_families
from .errors import DiagnosisError
from .evidence import Diagnosis, EffectEvidence
from .residual_tests import ResidualTest, residual_tests
from .settings import DiagnosisSettings

__all__ = [
    "EFFECTS",
    "Diagnosis",
    "DiagnosisError",
    "DiagnosisSettings",
    "EffectEvidence",
    "EffectFamily",
    "Regressors",
    "ResidualTest",
    "diagnose",
    "residual_tests",
    "select_families",
]
