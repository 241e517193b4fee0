"""A sorting line in physics: several robots on one loop, sharing the tracking, never taking the
same item, never touching each other, each loop closed; per-robot outputs."""

from __future__ import annotations

import time

import mujoco
import numpy as np
import pytest

from sim import config as episode_config
from sim.cell.robot import loop_closure_error
from sim.episode.loop import Episode
from sim.episode.runner import run_episode, shared_cell


def _line(robots: int, items: int, duration: float, **kw):
    config = episode_config.load(
        None, perception="truth", robots=robots, items=items, duration_s=duration, **kw
    )
    cell = shared_cell(config.cell_settings, config.item_catalogue, robots, config.line_cell)
    return config, cell


def _robot_of_body(model: mujoco.MjModel, prefixes) -> np.ndarray:
    """Per body, the index of the robot whose tree it is in (-1: none)."""
    out = np.full(model.nbody, -1)
    for b in range(model.nbody):
        root = model.body_rootid[b]
        name = model.body(root).name or ""
        for k, p in enumerate(prefixes):
            if name.startswith(p):
                out[b] = k
    return out


def _watch(episode: Episode, prefixes) -> tuple[int, float]:
    """(contacts between two robots, worst loop gap [m]) now."""
    model, data = episode.model, episode.data
    robot_of = _robot_of_body(model, prefixes)
    crossed = 0
    for c in data.contact[: data.ncon]:
        a, b = robot_of[model.geom_bodyid[c.geom1]], robot_of[model.geom_bodyid[c.geom2]]
        crossed += int(a >= 0 and b >= 0 and a != b)
    gap = max(loop_closure_error(model, data, prefix=p) for p in prefixes)
    return crossed, gap


@pytest.mark.parametrize("coordination", ["independent", "coordinated"])
def test_two_robots_share_the_belt_and_never_take_the_same_item(coordination):
    config, cell = _line(2, 60, 20.0, coordination=coordination, seed=3)
    result = run_episode(config, cell=cell)
    row, picks = result.episode_row, result.pick_rows
    assert row["robots"] == 2 and row["coordination"] == coordination
    assert row["mujoco_warnings"] == 0
    # both robots work, and their picks add up to the line's
    assert row["robot0_picked"] > 0 and row["robot1_picked"] > 0
    carried = [p for p in picks if p["success"]]
    assert row["robot0_picked"] + row["robot1_picked"] == len(carried)
    # picks.csv names the robot of every attempt
    assert {p["robot"] for p in picks} == {0, 1}
    ids = [p["item_id"] for p in carried]
    assert len(ids) == len(set(ids)), "an item carried to a bin twice"
    assert row["picked"] >= 0.9 * row["entered"]
    for k in (0, 1):
        assert 0.0 < row[f"robot{k}_utilisation"] < 1.0
        assert row[f"robot{k}_energy_elec_j"] > 0.0


def test_the_line_counts_add_up_and_every_robot_holds_together():
    """Stepped from outside decision by decision: at every decision no contact between two
    robots and every robot's loop closed within 0.1 mm; the accounting identities hold."""
    config, cell = _line(2, 50, 20.0, seed=5)
    prefixes = [rc.prefix for rc in cell.robots]
    worst_gap, crossings, decisions = 0.0, 0, 0
    with Episode(config, cell) as episode:
        episode.reset()
        while episode.step_until_decision():
            crossed, gap = _watch(episode, prefixes)
            crossings += crossed
            worst_gap = max(worst_gap, gap)
            decisions += 1
            episode.apply(episode.choose())
        assert episode.metrics.accounting_failures() == []
    assert decisions > 50
    assert crossings == 0
    assert worst_gap < 1e-4


def test_one_robot_on_a_dense_belt_gets_a_line_pool():
    config = episode_config.load(None, perception="truth", items=30, duration_s=12.0)
    assert config.line_cell  # 30 items in 12 s: 13.5 items per metre, over the single pool's 12
    sparse = episode_config.load(None, perception="truth", items=20, duration_s=12.0)
    assert not sparse.line_cell


@pytest.mark.slow
def test_four_robots_for_two_minutes():
    """The issue's check: a 4-robot line, 120 s of a 3.3 items/s flow (400 items), truth
    perception: 0 MuJoCo warnings, 0 robot-robot contacts, every loop within 0.1 mm; the
    real-time factor by CPU time is printed (the issue asks for 5x on the machine it set)."""
    config, cell = _line(4, 400, 120.0, seed=7)
    prefixes = [rc.prefix for rc in cell.robots]
    worst_gap, crossings = 0.0, 0
    cpu0 = time.process_time()
    with Episode(config, cell) as episode:
        episode.reset()
        while episode.step_until_decision():
            crossed, gap = _watch(episode, prefixes)
            crossings += crossed
            worst_gap = max(worst_gap, gap)
            episode.apply(episode.choose())
        cpu = time.process_time() - cpu0
        row = episode.metrics.row()
        sim_s = float(episode.data.time)
    print(
        f"4 robots, 400 items in 120 s: picked {row['picked']}, {sim_s:.1f} s simulated in "
        f"{cpu:.1f} s CPU ({sim_s / cpu:.2f}x real time by CPU), worst loop gap "
        f"{worst_gap * 1000:.3f} mm"
    )
    assert row["mujoco_warnings"] == 0
    assert crossings == 0
    assert worst_gap < 1e-4
    assert row["picked"] >= 0.85 * row["entered"]


@pytest.mark.slow
def test_a_path_the_executor_cannot_play_is_refused_before_the_pick():
    """Regression: in this episode a robot planned a pick whose path, checked every 2 ms, left
    the workspace between two checks at its edge; the executor's 1 ms set-points then failed
    inverse kinematics and the episode (and the sweep running it) stopped. Such a pick is now
    refused when planned (`PickController.plan`), and the episode runs to its end."""
    config, cell = _line(4, 225, 90.0, seed=404, coordination="coordinated")
    row = run_episode(config, cell=cell).episode_row
    assert row["mujoco_warnings"] == 0
    assert row["picked"] >= 0.95 * row["entered"]


@pytest.mark.parametrize(
    ("changes", "field"),
    [
        ({"robots": 5}, "robots"),
        ({"robots": 0}, "robots"),
        ({"coordination": "greedy"}, "coordination"),
    ],
)
def test_bad_line_settings_are_refused_naming_the_key(changes, field):
    from sim.errors import InvalidInput

    with pytest.raises(InvalidInput) as err:
        episode_config.load(None, **changes)
    assert err.value.field == field


def test_a_cell_of_another_robot_count_is_refused():
    from sim.errors import InvalidInput

    config, cell = _line(2, 20, 12.0)
    with pytest.raises(InvalidInput) as err:
        Episode(config.replace(robots=1), cell).reset()
    assert err.value.field == "robots"
