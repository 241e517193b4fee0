"""The timeline (`sim.results.timeline`): rows every period whose counts add up, sampled without
changing the episode, streamed to disk as they are made, the faults and downtime read from a
schedule, and the report's figure of it."""

from __future__ import annotations

import imageio.v2 as imageio
import pytest

from sim import config
from sim.cell.cell import Cell
from sim.config.faults import Fault, FaultSchedule
from sim.episode.loop import Episode
from sim.episode.scheduler import TimelineEvent
from sim.experiments.reporting.timeline_figure import bands, series, timeline_figures
from sim.results import timeline
from sim.results.timeline import (
    TimelineWriter,
    downtime_row,
    read_timeline,
    robot_state,
    timeline_columns,
)


@pytest.fixture(scope="module")
def cell() -> Cell:
    return Cell()


def _episode(cell) -> Episode:
    cfg = config.load(None, perception="truth", items=12, duration_s=8.0, seed=5)
    episode = Episode(cfg, cell)
    episode.reset()
    return episode


def test_rows_add_up_and_the_episode_is_the_same_with_them(cell, tmp_path):
    plain = _episode(cell)
    plain.run()
    period = 2.0  # the config's [timeline] period is 10 s: a shorter one, registered here
    writer = TimelineWriter(tmp_path / "t.csv", timeline_columns(1))
    rows: list[dict] = []

    def both(row: dict) -> None:
        rows.append(row)
        writer(row)

    episode = _episode(cell)
    episode.scheduler.add(TimelineEvent(period, both))
    episode.run()
    writer.land(tmp_path / "t.csv")
    assert episode.metrics.pick_rows() == plain.metrics.pick_rows()  # to the bit
    assert episode.metrics.row() == plain.metrics.row()
    assert float(episode.data.time) == float(plain.data.time)
    assert writer.last is rows[-1] and writer.kept == []  # the writer keeps none in memory
    assert len(rows) >= 5
    for k, row in enumerate(rows):
        # sampled at the item checks' stop at each multiple of the period, to the step
        assert row["t_s"] == pytest.approx((k + 1) * period, abs=1e-6)
        assert row["entered"] == row["picked"] + row["missed"] + row["dropped"] + row["on_belt"]
        assert row["wrong_bin"] <= row["picked"] and row["faults"] == ""
    for a, b in zip(rows, rows[1:], strict=False):
        for c in ("entered", "picked", "missed", "dropped", "profit_eur"):
            assert b[c] >= a[c]
    assert {r["robot_0_state"] for r in rows} == {"picking", "idle"}
    on_disk = read_timeline(tmp_path / "t.csv")
    assert [float(r["t_s"]) for r in on_disk] == pytest.approx([r["t_s"] for r in rows])
    assert [int(r["on_belt"]) for r in on_disk] == [r["on_belt"] for r in rows]


def test_the_runs_last_row_is_the_episodes_end(cell, tmp_path):
    from sim.episode.runner import run_episode

    cfg = config.load(None, perception="truth", items=12, duration_s=8.0, seed=5)
    result = run_episode(cfg, cell=cell)
    rows, ep = result.timeline_rows, result.episode_row
    assert rows[-1]["t_s"] == pytest.approx(ep["sim_s"])
    for c in ("entered", "picked", "missed", "wrong_bin", "dropped"):
        assert rows[-1][c] == ep[c]
    assert rows[-1]["on_belt"] == ep["left_on_belt"] == 0
    assert rows[-1]["entered"] == sum(rows[-1][c] for c in ("picked", "missed", "dropped"))
    assert ep["availability"] == 1.0 and ep["downtime_robot_stop_s"] == 0.0


def test_rows_are_on_disk_as_soon_as_they_are_made(tmp_path):
    writer = TimelineWriter(tmp_path / "timeline.csv", timeline_columns(2))
    row = {"t_s": 10.0, "entered": 3, "picked": 1, "missed": 0, "wrong_bin": 0, "dropped": 0}
    row |= {"profit_eur": 0.25, "on_belt": 2, "robot_0_state": "idle"}
    row |= {"robot_1_state": "stopped", "faults": "robot_stop 1; belt_stop"}
    writer(row)
    [staged] = [p for p in tmp_path.iterdir() if p.name.startswith(".timeline.csv")]
    text = staged.read_text()  # not closed: the rows are on the disk already
    assert writer.land(tmp_path / timeline.INTERRUPTED_FILE).read_text() == text  # Ctrl-C
    assert text == (
        "t_s,entered,picked,missed,wrong_bin,dropped,profit_eur,on_belt,robot_0_state,"
        "robot_1_state,faults\n10.000,3,1,0,0,0,0.2500,2,idle,stopped,robot_stop 1; belt_stop\n"
    )
    writer.close()
    assert timeline.to_text(writer.columns, [row]) == text


def test_robot_states_faults_and_downtime_from_a_schedule():
    schedule = FaultSchedule(
        (
            Fault("robot_stop", 10.0, 30.0, robot=1),
            Fault("camera_outage", 20.0, 10.0, camera=0),
            Fault("belt_stop", 50.0, 5.0),
        )
    )
    assert robot_state(True, 1, 15.0, schedule) == "stopped"
    assert robot_state(True, 0, 15.0, schedule) == "picking"
    assert robot_state(False, 1, 40.0, schedule) == "idle"  # the stop ends at 40 s
    assert robot_state(False, 0, 5.0, None) == "idle"
    labels = [f.label() for f in schedule.active(25.0)]
    assert labels == ["robot_stop 1", "camera_outage 0"]
    row = downtime_row(schedule, robots=2, end_s=100.0)
    assert row["downtime_robot_stop_s"] == 30.0 and row["downtime_belt_stop_s"] == 5.0
    assert row["downtime_camera_outage_s"] == 10.0 and row["downtime_vacuum_drop_s"] == 0.0
    # robot 0 loses the belt's 5 s, robot 1 its 30 s and the belt's 5 s: 40 of 200 robot-s
    assert row["availability"] == pytest.approx(1 - 40 / 200)
    assert downtime_row(None, 1, 100.0)["availability"] == 1.0


def _timeline_rows():
    out, picked, profit = [], 0, 0.0
    for k in range(1, 19):  # 3 minutes, a robot stopped from 60 s to 90 s
        t = 10.0 * k
        stopped = 60.0 < t <= 90.0
        picked += 2 if stopped else 5
        profit += 0.5 if stopped else 1.2
        faults = "robot_stop 1" if stopped else ""
        out.append({"t_s": f"{t:.3f}", "picked": str(picked), "profit_eur": f"{profit:.4f}"})
        out[-1]["faults"] = faults
    return out


def test_the_report_draws_the_timeline_with_fault_bands(tmp_path):
    rows = _timeline_rows()
    minutes, rates, profit = series(rows)
    assert minutes[1] == pytest.approx(10 / 60) and rates[1] == pytest.approx(30.0)  # 5 in 10 s
    assert rates[7] == pytest.approx(12.0)  # 2 picks in the 10 s to 70 s
    assert bands(rows) == [("robot_stop", pytest.approx(1.0), pytest.approx(1.5))]
    folder = tmp_path / "run"
    folder.mkdir()
    header = "t_s,picked,profit_eur,faults\n"
    lines = "".join(f"{r['t_s']},{r['picked']},{r['profit_eur']},{r['faults']}\n" for r in rows)
    (folder / "timeline.csv").write_text(header + lines)
    images = timeline_figures([folder])
    ((title, png),) = images.values()
    assert list(images) == ["timeline.png"] and "faults shaded" in title
    (tmp_path / "timeline.png").write_bytes(png)
    image = imageio.imread(tmp_path / "timeline.png")
    assert image.shape[0] > 300 and image.shape[1] > 400
    # the band: reddish pixels in the figure (no other red is drawn)
    red = (image[..., 0] > 200) & (image[..., 1] < 220) & (image[..., 2] < 220)
    red &= image[..., 0].astype(int) - image[..., 2].astype(int) > 25
    assert red.sum() > 1000
    assert timeline_figures([tmp_path]) == {}  # a folder without a timeline: nothing
