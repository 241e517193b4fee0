"""Soak checks: random episodes, each checked for what must never happen.

`draw_configs` draws episodes across the space the cell runs in (item density up to the flow's
limit of 12 items per metre, belt speeds x1 / x1.2 / x1.5, every built-in decision manager but
seen_best, every riding mode, random seeds and durations); `soak_episode` runs one and checks:

- the accounting identities of `sim.results.metrics` (entered = picked + missed + dropped, ...)
  and that every item of the flow entered the belt and left it before the time cap;
- no MuJoCo warning (`data.warning`, all kinds) during the episode;
- a finite state (positions, velocities, controls) at every decision and at the end;
- no item thrown off the belt (`sim.monitors.thrown`).

`benchmarks/soak.py` runs many of them in worker processes (`make soak`); `tests/test_soak.py`
runs a few.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from planner.decision.registry import COORDINATIONS
from sim import config as episode_config
from sim.config import EpisodeConfig
from sim.episode.loop import Episode
from sim.episode.runner import config_cell
from sim.flow.limits import LINE_MAX_ITEMS_PER_METRE, MAX_ITEMS_PER_METRE

PLANNERS = ("qlearning", "proximity", "fifo", "greedy")
SPEED_FACTORS = (1.0, 1.2, 1.5)
RIDINGS = episode_config.ITEM_RIDINGS
"""Every riding mode (`sim.cell.riding`), the default ("path") included."""
DURATION_S = (20.0, 60.0)
"""Range of the episodes' flow durations [s] (short, so that hundreds run in half an hour)."""
DENSITY_PER_M = (2.0, MAX_ITEMS_PER_METRE)
"""Range of the items per metre of belt drawn (the flow refuses more than 12)."""
LINE_DENSITY_PER_M = (MAX_ITEMS_PER_METRE, LINE_MAX_ITEMS_PER_METRE)
"""Range of the items per metre a line's soak draws: the belts one robot cannot clear."""
LINE_ITEMS = (100, 400)
"""Range of a line's flow [items]; its duration follows from the density drawn (about 12 s to
3 min)."""


def draw_configs(
    n: int, seed: int = 0, duration_s: tuple[float, float] = DURATION_S, lines: bool = False
) -> list[EpisodeConfig]:
    """`n` random truth-perception episode configs (reproducible from `seed`), their flows
    lasting `duration_s` (low, high) [s]. With `lines`, sorting lines: 2-4 robots, either
    coordination, flows of `LINE_ITEMS` items on belts of `LINE_DENSITY_PER_M` items per metre
    (`duration_s` unused)."""
    rng = np.random.default_rng(seed)
    configs = []
    for _ in range(n):
        speed = float(rng.choice(SPEED_FACTORS))
        low, high = LINE_DENSITY_PER_M if lines else DENSITY_PER_M
        if lines:  # the items first (a line's flows), their duration from the density
            density = rng.uniform(low, high)
            wanted = int(rng.integers(LINE_ITEMS[0], LINE_ITEMS[1] + 1))
            metres_wanted = wanted / density
            duration = float(np.round(metres_wanted / episode_config.belt_speed_mps(speed), 1))
        else:
            duration = float(np.round(rng.uniform(*duration_s), 1))
            density = rng.uniform(low, high)
        metres = duration * episode_config.belt_speed_mps(speed)
        most = int(high * metres + 1e-6)
        items = int(min(max(5, round(density * metres)), most))
        line = {}
        if lines:
            line = {
                "robots": int(rng.integers(2, episode_config.MAX_ROBOTS + 1)),
                "coordination": str(rng.choice(COORDINATIONS)),
            }
        configs.append(
            episode_config.load(
                None,
                seed=int(rng.integers(0, 2**31)),
                items=items,
                speed_factor=speed,
                planner=str(rng.choice(PLANNERS)),
                perception="truth",
                duration_s=duration,
                item_riding=str(rng.choice(RIDINGS)),
                **line,
            )
        )
    return configs


@dataclass
class SoakResult:
    """One soaked episode: its figures and what failed (empty `failures`: all checks passed)."""

    config: EpisodeConfig
    row: dict
    failures: list[str] = field(default_factory=list)
    throws: list[str] = field(default_factory=list)
    warning_kinds: dict[str, int] = field(default_factory=dict)
    nonfinite: bool = False
    identity_failures: int = 0
    peak_loose_speed: float = 0.0
    cpu_s: float = 0.0

    @property
    def ok(self) -> bool:
        """Every check passed."""
        return not self.failures

    def line(self) -> str:
        """One line of the soak's log."""
        c, r = self.config, self.row
        line = f"{c.robot_count} {c.coordination[:5]}  " if c.robot_count > 1 else ""
        head = (
            f"{line}seed {c.seed:>10}  {c.items:>3} items {c.duration_s:4.1f} s "
            f"x{c.speed_factor:<3g} "
            f"{c.planner:<9} {c.item_riding:<7}  picked {r['picked']:>3}/{r['entered']:<3} "
            f"missed {r['missed']:>2} dropped {r['dropped']:>2} failed {r['failed_picks']:>2}  "
            f"thrown {r['thrown_off']}  warnings {r['mujoco_warnings']}  "
            f"peak {self.peak_loose_speed:4.2f} m/s  cpu {self.cpu_s:5.1f} s"
        )
        return head + ("  OK" if self.ok else "  FAIL: " + "; ".join(self.failures))


def _finite(data) -> bool:
    return all(np.isfinite(a).all() for a in (data.qpos, data.qvel, data.ctrl))


def soak_episode(config: EpisodeConfig) -> SoakResult:
    """Run one episode on this process's cell and check it (see the module docstring)."""
    cpu0 = time.process_time()
    cell = config_cell(config)
    nonfinite = False
    with Episode(config, cell) as episode:
        episode.reset()
        while episode.step_until_decision():
            nonfinite |= not _finite(cell.data)
            episode.apply(episode.choose())
        nonfinite |= not _finite(cell.data)
    assert episode.parts is not None  # built by reset
    metrics = episode.metrics
    row = {**metrics.row(), "sim_s": float(cell.data.time)}
    failures = []
    identity = metrics.accounting_failures()
    if row["entered"] != config.items:
        identity.append(f"entered {row['entered']} of the flow's {config.items} items")
    if cell.data.time >= episode.parts.timeline.t_cap:
        identity.append(f"hit the time cap at {cell.data.time:.1f} s")
    failures += identity
    if metrics.mujoco_warnings:
        failures.append(f"MuJoCo warnings {metrics.warning_kinds}")
    if nonfinite:
        failures.append("non-finite state")
    throws = [
        f"item {t.item_id} {t.reason} at t {t.time:.2f} s, ({t.position[0]:.2f}, "
        f"{t.position[1]:.2f}, {t.position[2]:.2f}) m, {t.speed:.2f} m/s; robot: {doing}"
        for t, doing in metrics.throws
    ]
    if throws:
        failures.append(f"{len(throws)} thrown off: " + " | ".join(throws))
    return SoakResult(
        config=config,
        row=row,
        failures=failures,
        throws=throws,
        warning_kinds=dict(metrics.warning_kinds),
        nonfinite=nonfinite,
        identity_failures=len(identity),
        peak_loose_speed=episode.parts.throw_watch.peak_speed,
        cpu_s=time.process_time() - cpu0,
    )
