"""`nnfmu characterise`'s terminal lines for a bushing: every number with its unit, and within an 80-column terminal
(issue 31: amplitude and |K*| were printed without units)."""

from __future__ import annotations

from nnfmu.data.rigs import BUSHING_CHANNELS
from nnfmu.workflows.characterise.analysis import StiffnessPoint
from nnfmu.workflows.characterise.kind import BushingChannelPorts
from nnfmu.workflows.characterise.run import stiffness_line


def test_every_bushing_channels_line_carries_its_units_within_80_columns():
    for key, c in BUSHING_CHANNELS.items():
        channel = BushingChannelPorts(key, c.position, c.rate, c.force, c.position_unit, c.force_unit)
        line = stiffness_line(channel, StiffnessPoint(key, 12.5, 0.00125, 1234567.0, -12.34))  # the longest numbers
        unit = c.position_unit
        assert line == f"{key} 12.5 Hz, 0.00125 {unit}: |K*| 1.235e+06 {c.force_unit}/{unit}, loss -12.3 deg"
        assert len("  " + line) <= 80, line  # the CLI indents each line by two
