"""Defaults the CLI's options show in `--help`, read from their owners at start-up: light, as the faces load only the
module that owns each (`nnfmu.cosim.settings` for the communication step)."""

from nnfmu.cosim import DEFAULT_STEP

__all__ = ["DEFAULT_STEP"]
