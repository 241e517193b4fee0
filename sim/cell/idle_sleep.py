"""An idle robot's bodies asleep in MuJoCo's sleeping, awake for every pick.

A robot resting over a bin between picks holds its set-points: its arms, rods and platform
stand still while the physics still solves its four loop closures, integrates its dofs and
checks its geoms every millisecond (about 11 us a step a robot; a line of four robots is idle
about half the time at 400 items in 120 s). MuJoCo's sleeping (enabled for the item pool,
`models/cell/items.xml`) puts a tree whose speeds stay under `sleep_tolerance` for a few steps
to sleep and skips it until something wakes it: a contact with an awake body, an equality to
one, a write to its `qpos`, or its `tree_awake` flag. A robot's trees (three arms with their
rods, the platform with axis 4 and the cup) are actuated, so MuJoCo never lets them sleep by
default (`mjSLEEP_AUTO_NEVER`); `IdleSleep` allows it while the robot is idle and forbids it,
waking the robot, when a pick starts. It falls asleep once its speeds have stayed under the
model's `sleep_tolerance` (1 mm/s) for MuJoCo's few steps, and stands exactly there until woken
(about 40 ms after it stops moving; its servos' torques are then within about 1 % of where they
settle, `tests/test_idle_sleep.py`); its motors still hold it against gravity, which the energy
meter counts with the torques it came to rest with (`sim.monitors.energy`).

`IdleSleep(model, data, prefix, enabled=False)` restores the compiled policy: every result is
then the same to the bit as without it.
"""

from __future__ import annotations

import mujoco
import numpy as np

from sim.errors import InvalidInput

ROOT_BODIES = ("upper_arm_1_link", "upper_arm_2_link", "upper_arm_3_link", "platform_link")
"""The robot's bodies whose kinematic trees make up the robot (by name in the MJCF)."""
COMPILED_POLICY = int(mujoco.mjtSleepPolicy.mjSLEEP_AUTO_NEVER)
"""The policy MuJoCo's compiler gives the robot's actuated trees (the MJCF sets none)."""
_ALLOWED = int(mujoco.mjtSleepPolicy.mjSLEEP_ALLOWED)
_NEVER = int(mujoco.mjtSleepPolicy.mjSLEEP_NEVER)


def robot_trees(model: mujoco.MjModel, prefix: str = "") -> np.ndarray:
    """Ids of the kinematic trees of robot `prefix`'s moving bodies ("" for the robot's own
    names, "r1_" for robot r1_ of a sorting line)."""
    trees = []
    for name in ROOT_BODIES:
        body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, prefix + name)
        if body < 0:
            raise InvalidInput("model", f"a robot with a body {prefix + name!r}", None)
        trees.append(int(model.body_treeid[body]))
    return np.array(sorted(set(trees)))


class IdleSleep:
    """Whether robot `prefix` may sleep: only while idle, and only when `enabled`.

    Args:
        model, data: The cell's model (its `tree_sleep_policy` is switched) and data.
        prefix: Name prefix of the robot.
        enabled: Let the idle robot sleep; False restores the compiled policy.
    """

    def __init__(
        self, model: mujoco.MjModel, data: mujoco.MjData, prefix: str = "", enabled: bool = False
    ):
        self.model, self.data, self.enabled = model, data, bool(enabled)
        self.trees = robot_trees(model, prefix)
        self.tree = int(self.trees[0])
        """One of the robot's trees: all of them sleep and wake together (the loop closures
        join them into one island)."""
        if self.enabled:
            self.idle()
        else:  # as compiled (a model shared by episodes may have been switched by another)
            model.tree_sleep_policy[self.trees] = COMPILED_POLICY

    def idle(self) -> None:
        """The robot rests now: it may fall asleep once it has come to rest."""
        if self.enabled:
            self.model.tree_sleep_policy[self.trees] = _ALLOWED

    def busy(self) -> None:
        """A pick starts: the robot is woken (for the coming step) and kept awake."""
        if self.enabled:
            self.model.tree_sleep_policy[self.trees] = _NEVER
            self.data.tree_awake[self.trees] = 1

    def asleep(self) -> bool:
        """Whether the robot sleeps now."""
        return bool(self.data.tree_asleep[self.tree] >= 0)
