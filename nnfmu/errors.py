"""The one base of nnfmu's errors, so the command line can tell a user's mistake from a programming error."""

from __future__ import annotations


class NnfmuError(Exception):
    """An error in the user's input or environment, reported without a traceback; the message names the file,
    channel, node or value."""


class SettingsError(NnfmuError, ValueError):
    """A setting, option or request value out of its range or at odds with another; the message names it."""


class OutputPathError(NnfmuError, ValueError):
    """An output path that would overwrite an input or someone else's files, or that cannot be a file or folder."""
