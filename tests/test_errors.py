"""Every exception class nnfmu defines derives from the one base NnfmuError, the only error the command line reports
without a traceback; the few that do not are listed below with the reason."""

from __future__ import annotations

import importlib
import pkgutil

import pytest

import nnfmu
from nnfmu.errors import NnfmuError, SettingsError

# Exception classes that are not errors in the user's input or environment, each with why.
NOT_NNFMU_ERRORS = {
    # Private signal inside the master's step loop; the master always turns it into a CosimError naming the system
    # and the time, so it never leaves nnfmu.cosim.master.
    "nnfmu.cosim.master._Diverged",
    # A warning, issued with warnings.warn and printed by the CLI as a `warning:` line, never raised.
    "nnfmu.fmu.errors.PlatformSkippedWarning",
    # The same for a co-simulation: inputs held over the step, an output recorded in a unit it did not declare.
    "nnfmu.cosim.master.CosimWarning",
}


def _subclasses(cls: type) -> set[type]:
    """`cls`'s subclasses at any depth."""
    direct = set(cls.__subclasses__())
    return direct.union(*(_subclasses(c) for c in direct))


def _nnfmu_exception_classes() -> dict[str, type]:
    """{module.qualname: class} of every exception class defined in an nnfmu module, after importing them all."""
    for module in pkgutil.walk_packages(nnfmu.__path__, "nnfmu."):
        importlib.import_module(module.name)
    return {
        f"{c.__module__}.{c.__qualname__}": c
        for c in _subclasses(BaseException)
        if c.__module__ == "nnfmu" or c.__module__.startswith("nnfmu.")
    }


CLASSES = _nnfmu_exception_classes()


def test_the_walk_finds_the_package_errors() -> None:
    """A guard on the walk itself: errors of the lowest and highest stages are among those it finds."""
    for name in (
        "nnfmu.errors.SettingsError",
        "nnfmu.data.errors.DataError",
        "nnfmu.workflows.campaign.errors.CampaignError",
        "nnfmu.fmu.native.codegen.errors.UnsupportedGraphError",
        "nnfmu.cosim.master._Diverged",
    ):
        assert name in CLASSES, sorted(CLASSES)
    assert len(CLASSES) >= 25


@pytest.mark.parametrize("name", sorted(set(CLASSES) - NOT_NNFMU_ERRORS))
def test_every_error_class_derives_from_nnfmu_error(name: str) -> None:
    assert issubclass(CLASSES[name], NnfmuError), f"{name} bases: {CLASSES[name].__mro__[1:]}"


@pytest.mark.parametrize("name", sorted(NOT_NNFMU_ERRORS))
def test_the_exceptions_to_the_rule_still_exist_and_are_exceptions(name: str) -> None:
    """A stale entry (the class renamed, moved or given the base) fails here, so the list stays exact."""
    assert name in CLASSES
    assert not issubclass(CLASSES[name], NnfmuError)


def test_a_bad_setting_is_both_an_nnfmu_error_and_a_value_error() -> None:
    """Callers catching ValueError for a bad setting keep working; the CLI catches the same error as an NnfmuError."""
    from nnfmu.models.splits import SplitFractions

    with pytest.raises(ValueError, match="blocks must be an integer >= 1, got 0") as caught:
        SplitFractions(blocks=0)
    assert isinstance(caught.value, SettingsError) and isinstance(caught.value, NnfmuError)
