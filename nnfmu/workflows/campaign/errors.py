"""The one error a campaign raises for bad input."""

from __future__ import annotations

from nnfmu.errors import NnfmuError


class CampaignError(NnfmuError, ValueError):
    """A campaign file or folder that cannot be run as given; the message names the file, the entry and the key."""
