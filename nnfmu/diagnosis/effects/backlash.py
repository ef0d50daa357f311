"""Mechanical play at motion reversals: a dead zone where the force vanishes, then re-engagement once the gap is
crossed (the stop-operator family read as play)."""

from __future__ import annotations

from nnfmu.diagnosis.effects.stop_family import StopFamily


class Backlash(StopFamily):
    """Play: after a reversal the force stays flat until the gap is crossed, then the contact re-engages."""

    name = "backlash"
    description = "play at motion reversals: dead zone, then re-engagement over the gap's travel"
    shape = "dead_zone"
    meaning = "backlash (play) at motion reversals"
    state_meaning = "position inside the backlash gap (play-operator states)"
