"""Gymnasium environments of the cell, registered when this package is imported.

    import gymnasium as gym
    import sim.envs  # registers the ids below
    env = gym.make("sortsim/PickOrder-v0")

(or `gym.make("sim.envs:sortsim/PickOrder-v0")`, which imports it for you).

- `sortsim/PickOrder-v0` (`sim.envs.pick_order.PickOrderEnv`): planner level, a kinematic belt
  and the cycle-time model, no physics.
- `sortsim/SortingCell-v0` (`sim.envs.sorting_cell.SortingCellEnv`): the physics of the cell,
  truth or camera perception.

A line of robots is a multi-agent environment in PettingZoo's parallel API, not a Gymnasium
one: `sim.envs.sorting_line.SortingLineParallelEnv(robots=2, ...)` (no PettingZoo needed to
run it; `pettingzoo.test.parallel_api_test` passes on it).
"""

from __future__ import annotations

import gymnasium as gym

ENVS = {
    "sortsim/PickOrder-v0": "sim.envs.pick_order:PickOrderEnv",
    "sortsim/SortingCell-v0": "sim.envs.sorting_cell:SortingCellEnv",
}

for _id, _entry in ENVS.items():
    if _id not in gym.registry:
        gym.register(id=_id, entry_point=_entry)
