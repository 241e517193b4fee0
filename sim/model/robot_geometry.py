"""The delta robot's geometry read from a compiled model by element names (the MJCF the one
source of truth for the planner's `DeltaGeometry`): what the model's edits (the belt's width,
`sim.model.belt_width`) and the cell's robots (`sim.cell.robot`) both need."""

from __future__ import annotations

from typing import cast

import mujoco
import numpy as np

from planner.motion.kinematics import DeltaGeometry

LEGS = (1, 2, 3)
"""The robot's three legs, as its element names number them."""


def geometry_from_model(model: mujoco.MjModel, *, prefix: str = "") -> DeltaGeometry:
    """The robot's `DeltaGeometry`, read by element names from the compiled model.

    Args:
        model: A model containing the IRB 360 (`base_link`, `upper_arm_*_link`, rods, platform).
        prefix: Name prefix of the robot in `model` ("" for the robot's own names).

    Returns:
        Geometry of the robot as mounted in this model [m, rad].
    """
    p = prefix
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)  # at qpos0: motors at 0, platform at its body pose
    base = data.body(f"{p}base_link").xpos.copy()
    radii, azimuths, lows, highs = [], [], [], []
    for i in LEGS:
        offset = data.body(f"{p}upper_arm_{i}_link").xpos - base
        radii.append(np.hypot(offset[0], offset[1]))
        azimuths.append(float(np.arctan2(offset[1], offset[0])))
        lows.append(model.joint(f"{p}motor_{i}_joint").range[0])
        highs.append(model.joint(f"{p}motor_{i}_joint").range[1])
    rod_a, rod_b = model.body(f"{p}rod_1a_link").pos, model.body(f"{p}rod_1b_link").pos
    platform_mid = 0.5 * (model.site(f"{p}platform_1a").pos + model.site(f"{p}platform_1b").pos)
    tcp_offset = data.body(f"{p}platform_link").xpos[2] - data.site(f"{p}cup_site").xpos[2]
    return DeltaGeometry(
        base_radius=float(np.mean(radii)),
        upper_arm=float(0.5 * (rod_a[0] + rod_b[0])),
        forearm=float(np.linalg.norm(model.site(f"{p}rod_1a_tip").pos)),
        platform_radius=float(np.hypot(platform_mid[0], platform_mid[1])),
        rod_spacing=float(np.linalg.norm(rod_b - rod_a)),
        leg_azimuths=cast(
            tuple[float, float, float], tuple(float(a % (2.0 * np.pi)) for a in azimuths)
        ),
        base_height=float(base[2]),
        tcp_offset=float(tcp_offset),
        motor_lower=float(max(lows)),
        motor_upper=float(min(highs)),
        base_xy=(float(base[0]), float(base[1])),
    )
