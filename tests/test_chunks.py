"""Busy stepping in chunks (`sim.episode.chunks`) gives the results of stepping one at a time."""

from __future__ import annotations

import pytest

from sim import config
from sim.cell.cell import Cell
from sim.episode.chunks import steps_until_due_stepwise
from sim.episode.loop import Episode
from sim.episode.scheduler import is_due


def _run(cell: Cell, seed: int, every_step: bool) -> tuple[dict, list[dict], int]:
    """(episode row, pick rows, steps seen by a hook) of a short truth episode; with
    `every_step` a user's after-step hook makes the loop step one at a time."""
    steps = []
    cfg = config.load(None, perception="truth", seed=seed, items=24, duration_s=12.0)
    with Episode(cfg, cell) as episode:
        if every_step:
            episode.add_hook("after_step", lambda ep: steps.append(ep.last_step_s))
        episode.reset()
        episode.run()
        row = episode.metrics.row()
        return row, episode.metrics.pick_rows(), len(steps)


@pytest.mark.parametrize("seed", [4, 31])
def test_chunks_give_the_results_of_one_step_at_a_time(seed):
    cell = Cell()
    chunked, chunked_picks, _ = _run(cell, seed, every_step=False)
    single, single_picks, hooked = _run(cell, seed, every_step=True)
    assert chunked_picks and hooked > 1000
    assert chunked == single
    assert chunked_picks == single_picks


def test_a_chunk_ends_where_a_loop_testing_every_step_finds_the_event_due():
    dt = 0.001
    for t0, when in ((0.0, 0.5), (0.123, 0.143), (12.3456, 12.3466), (3.0, 2.0), (7.25, 7.27)):
        n = steps_until_due_stepwise(t0, when, dt, 10_000)
        t, k = t0, 0
        while True:
            t += dt
            k += 1
            if is_due(t, when):
                break
        assert n == k
    assert steps_until_due_stepwise(0.0, 5.0, dt, 20) == 20
