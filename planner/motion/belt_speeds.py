"""The conveyor's speeds: the one home of these facts, read by the planner and the cell.

The thesis runs its belt at x1, x1.2 and x1.5 (sections 2.1.1, 4.1.4); we set x1 = 0.185 m/s so
that x1.5 = 0.2775 m/s is the conveyor's top speed of 0.277 m/s, rounded. Its drive runs from
0.135 to 0.277 m/s.
"""

from __future__ import annotations

SPEED_X1_MPS = 0.185
"""Belt speed of speed factor x1 [m/s]."""
SPEED_FACTORS = (1.0, 1.2, 1.5)
"""The thesis's speed factors (section 4.1.4)."""
THESIS_SPEEDS_MPS = (0.185, 0.222, 0.2775)
"""The belt speeds of those factors [m/s]."""
SPEED_RANGE_MPS = (0.135, 0.277)
"""Slowest and fastest speed of the thesis's conveyor [m/s]."""
SPEED_TOLERANCE_MPS = 0.0005
"""Half of the rated range's last digit [m/s]: a speed within it of the range is inside (x1.5 =
0.2775 m/s rounds to the drive's 0.277). The one tolerance the config, the flow and the belt
all apply, so whatever a config accepts the belt runs."""
