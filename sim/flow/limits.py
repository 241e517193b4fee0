"""The flow's numbers a config's schema checks against, in a module that imports no numerics
(`sim.config` and the command line's parser read them; `sim.flow.config`, `sim.flow.world` and
`sim.flow.catalogue` use them)."""

BELT_HALF_WIDTH = 0.4
BELT_WIDTH_M = 2 * BELT_HALF_WIDTH
"""The thesis's belt width [m]: the scene's belt (`models/cell/scene.xml`) and the default."""
BELT_WIDTH_RANGE_M = (0.4, 1.2)
"""Belt widths accepted [m]: 0.4 m (a narrow picking belt) to 1.2 m (wider than the IRB 360's
1.13 m working circle: its outer edges are out of the robot's reach)."""
BELT_X_RANGE = (-3.0, 1.5)
# The densest thesis flows carry about 11 items per metre of belt (400 items in ~190 s and
# 3000 items in 25 min at x1); we allow up to 12 and size the item pool for that.
MAX_ITEMS_PER_METRE = 12.0
LINE_MAX_ITEMS_PER_METRE = 30.0
"""The densest belt a line of several robots takes (its pool has `LINE_POOL_SIZE` bodies)."""
MASS_RANGE_KG = (1e-4, 3.0)
"""An item's mass [kg]: from 0.1 g (with the smallest size, an inertia of ~1e-10 kg m^2, far
above MuJoCo's mjMINVAL of 1e-15, under which a body is refused) to the robot's rated 3 kg
payload. The default cup holds 226 N (60 mm at 80 kPa): a 1 kg item is picked, a 3 kg one
seals and is lost to the pick's accelerations (it rides on, missed)."""
MAX_SIZE_JITTER = 0.3
"""Largest size jitter accepted: factors stay within 0.7..1.3."""
MAX_OVERLAP_DEPTH_M = 0.05
WORLD_LIMITS = {
    "size_jitter": MAX_SIZE_JITTER,
    "crushed_share": 1.0,
    "crumpled_share": 1.0,
    "folded_share": 1.0,
    "hue_jitter_deg": 30.0,
    "colour_jitter": 0.5,
    "label_share": 1.0,
    "min_gap_m": 0.05,
    "overlap_share": 1.0,
    "overlap_depth_m": MAX_OVERLAP_DEPTH_M,
}
"""Each setting of `sim.flow.world.WorldVariation`'s largest value (every one's smallest is 0);
crumpled_share + folded_share <= 1 besides."""
