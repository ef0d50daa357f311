"""Characterisations another workflow's report links to (the component loop's, the road test's): each model
characterised into its own sub-folder, quietly; a model the standard tests do not fit gets the reason instead."""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path

from nnfmu.errors import SettingsError
from nnfmu.workflows.characterise.kind import CharacteriseError
from nnfmu.workflows.characterise.run import characterise
from nnfmu.workflows.characterise.settings import CharacteriseSettings


@dataclass(frozen=True)
class LinkedCharacterisation:
    """One model's characterisation: the report's index.html, or None and why the model was not characterised."""

    index: Path | None
    reason: str = ""

    def link(self, page: Path) -> str | None:
        """The relative link from the report page `page` to the characterisation (None without one)."""
        return None if self.index is None else os.path.relpath(self.index, page.parent).replace(os.sep, "/")

    def describe(self) -> str:
        """The JSON summary's entry: the report's path or why there is none."""
        return str(self.index) if self.index is not None else f"not characterised: {self.reason}"


def characterise_models(
    models: Mapping[str, Path],
    folder: Path,
    settings: CharacteriseSettings,
    log: Callable[[str], None] = lambda _: None,
) -> dict[str, LinkedCharacterisation]:
    """Characterise each model (label -> ONNX or FMU) into `folder`/<label>; a model that is no damper or bushing,
    or that the tests do not fit (an input no test drives, too coarse a sample period), is reported, not raised."""
    found = {}
    for label, model in models.items():
        try:
            done = characterise(model, folder / label, settings=settings, log=lambda _: None)
        except (CharacteriseError, SettingsError) as error:
            found[label] = LinkedCharacterisation(None, str(error))
            log(f"{label}: not characterised: {error}")
        else:
            found[label] = LinkedCharacterisation(done.index)
            log(f"{label}: characterisation {done.index}")
    return found
