"""`nnfmu characterise`: the standard tests damper and bushing engineers accept a model on, run on the model through
its FMU and on a measurement, side by side (docs/characterise.md)."""

from nnfmu.workflows.characterise.kind import CharacteriseError, component_kind
from nnfmu.workflows.characterise.run import CharacteriseReport, characterise
from nnfmu.workflows.characterise.settings import BushingTestSettings, CharacteriseSettings, DamperTestSettings

__all__ = [
    "BushingTestSettings",
    "CharacteriseError",
    "CharacteriseReport",
    "CharacteriseSettings",
    "DamperTestSettings",
    "characterise",
    "component_kind",
]
