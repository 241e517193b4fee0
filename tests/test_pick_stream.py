"""picks.csv streamed as the picks happen: the same bytes as the rows kept to the end, and a
Ctrl-C leaves the finished picks readable beside the folder's earlier files."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from sim import config as episode_config
from sim.episode.runner import run_episode
from sim.paths import REPO_ROOT
from sim.results import outputs
from sim.results.pick_log import PickLog, PickRecord

ENV = {**os.environ, "MUJOCO_GL": "egl", "PYOPENGL_PLATFORM": "egl"}


class Rows:
    def __init__(self):
        self.rows = []

    def write_row(self, row):
        self.rows.append(row)


def _record(t0, t1, item, robot):
    return PickRecord(t0, t1, item, 2, 2, 2, True, robot=robot)


def test_rows_stream_in_start_order_while_a_long_pick_is_under_way():
    kept, streamed, sink = PickLog(), PickLog(), Rows()
    streamed.stream_to(sink)
    events = [  # robot 1's pick starts first and ends last
        ("start", 1, 1.0), ("start", 0, 2.0), ("end", _record(2.0, 2.7, 5, 0)),
        ("start", 0, 2.7), ("end", _record(2.7, 3.4, 6, 0)), ("end", _record(1.0, 4.0, 4, 1)),
        ("start", 0, 4.1), ("end", _record(4.1, 4.8, 7, 0)),
    ]  # fmt: skip
    written_before_robot_1_ended = None
    for event in events:
        for log in (kept, streamed):
            if event[0] == "start":
                log.started(event[1], event[2])
            else:
                log.add(event[1])
        if event[0] == "end" and event[1].item_id == 6:
            written_before_robot_1_ended = len(sink.rows)
    assert written_before_robot_1_ended == 0  # held: robot 1's pick started before them
    streamed.finish()
    assert sink.rows == kept.rows()
    assert [r["item_id"] for r in sink.rows] == [4, 5, 6, 7]
    assert (streamed.attempts, streamed.success_cycle_s) == (kept.attempts, kept.success_cycle_s)


def test_streamed_picks_csv_is_byte_identical_to_the_kept_rows(tmp_path):
    config = episode_config.load(None, perception="truth", items=16, duration_s=8.0, robots=2)
    kept = run_episode(config)
    with outputs.PickStream(tmp_path / "picks.csv") as picks:
        streamed = run_episode(config, picks=picks)
        picks.land()
    assert streamed.pick_rows == [] and len(kept.pick_rows) >= 10
    text = outputs.to_csv_text(outputs.PICK_COLUMNS, kept.pick_rows)
    assert (tmp_path / "picks.csv").read_text(encoding="utf-8") == text
    drop = set(outputs.WALL_COLUMNS)
    assert {k: v for k, v in streamed.episode_row.items() if k not in drop} == {
        k: v for k, v in kept.episode_row.items() if k not in drop
    }


def test_ctrl_c_leaves_the_finished_picks_and_the_earlier_run(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    earlier = {"episodes.csv": "seed,profit_eur\n0,12.5\n", "picks.csv": "t_start_s\n1.0\n"}
    for name, text in earlier.items():
        (out / name).write_text(text, encoding="utf-8")
    proc = subprocess.Popen(
        [sys.executable, "-m", "sim.cli.main", "run", "--perception", "truth", "--items", "200",
         "--duration", "200", "--out", str(out), "--quiet"],
        cwd=REPO_ROOT, env=ENV, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
        start_new_session=True, preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )  # fmt: skip

    def streamed_rows() -> int:
        hidden = [p for p in out.iterdir() if p.name.startswith(".picks.csv.")]
        return max((p.read_text().count("\n") - 1 for p in hidden), default=0)

    end = time.monotonic() + 240
    while streamed_rows() < 3:
        assert proc.poll() is None, proc.stderr.read()
        assert time.monotonic() < end, "no picks were streamed"
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGINT)
    assert proc.wait(timeout=60) == 130
    stderr = proc.stderr.read()
    assert "Traceback" not in stderr and stderr.splitlines()[-1] == "sortsim run: interrupted"
    rows = outputs.read_rows(out / outputs.INTERRUPTED_PICKS)
    assert len(rows) >= 3 and tuple(rows[0]) == outputs.PICK_COLUMNS
    starts = [float(r["t_start_s"]) for r in rows]
    assert starts == sorted(starts)
    assert f"the {len(rows)} picks finished are in" in stderr
    for name, text in earlier.items():  # the stopped run replaced nothing
        assert (out / name).read_text(encoding="utf-8") == text
    assert [p.name for p in out.iterdir() if p.name.startswith(".")] == []


def test_the_progress_bar_shows_the_wall_time_left():
    import io

    from sim.cli.run import Progress, eta

    assert eta(0.0, 0.0) == "ETA -"
    assert eta(600.0, 0.25) == "ETA 0:30:00"
    assert eta(3600.0, 1 / 9) == "ETA 8:00:00"
    now = [100.0]
    stream = io.StringIO()
    bar = Progress(stream, clock=lambda: now[0])
    now[0] += 120.0
    bar(0.5, "t 14400.0 s")
    assert stream.getvalue() == " 50% ETA 0:02:00 t 14400.0 s\n"


def test_latencies_are_kept_bounded_over_a_shift():
    """Past `MAX_LATENCIES` calls a stage keeps a uniform sample of that size (flat memory)."""
    from sim.episode.parts import MAX_LATENCIES, Timings

    timings = Timings()
    n = MAX_LATENCIES * 3
    for k in range(n):
        timings.add("decision", k / n, "decision")
    kept = timings.latencies["decision"]
    assert len(kept) == MAX_LATENCIES and timings.calls["decision"] == n
    assert timings.seconds["decision"] == pytest.approx(sum(k / n for k in range(n)), rel=1e-9)
    # a uniform sample of 0..1: its median within 0.02 of 0.5 (20,000 draws: sd about 0.004)
    assert sorted(kept)[MAX_LATENCIES // 2] == pytest.approx(0.5, abs=0.02)
