"""A package's public face, resolved on first use: `from nnfmu.cosim import cosimulate` loads `nnfmu.cosim.master`
and what it needs, not the whole package, so a light import (the CLI's help, an FMU build) stays light."""

from __future__ import annotations

import sys
from collections.abc import Callable, Mapping
from importlib import import_module
from typing import Any


def face(package: str, homes: Mapping[str, tuple[str, ...]]) -> tuple[list[str], Callable[[str], Any]]:
    """`__all__` and the module `__getattr__` of `package`, whose public names live in its modules `homes` (the
    module's name under the package -> the names other floors may import from it)."""
    home = {name: module for module, names in homes.items() for name in names}

    def attribute(name: str) -> Any:
        if name not in home:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(import_module(f"{package}.{home[name]}"), name)
        setattr(sys.modules[package], name, value)  # found directly from now on
        return value

    return list(home), attribute
