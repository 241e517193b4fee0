"""The video's own process: the MP4 it writes (frames, size, pictures), its failures, kills.

The episode's process sends each frame's state (joint positions, the model rows the item pool
changed, the overlay); the video process draws it on its own copy of the model and encodes it.
Its frames are checked against the same states drawn in this process (`FramePainter`), and
those against a plain `mujoco.Renderer` of the scene itself.
"""

from __future__ import annotations

import copy
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import imageio.v2 as imageio
import mujoco
import numpy as np
import pytest

from sim.cell.conveyor import Belt
from sim.cell.item_pool import ItemPool
from sim.errors import InvalidInput
from sim.paths import REPO_ROOT
from sim.render.encoder import VideoError
from sim.render.labels import Overlay
from sim.render.painter import FramePainter, ModelWatch, frame_state
from sim.render.video import VideoRecorder
from sim.render.view import finite_floors, ghost, ghosted_geoms, view_camera
from tests.utils import scene_at_home

SIZE = (320, 184)
FPS = 10.0
N_FRAMES = 12
SPAWN_AT = 4
"""Frame before which three large items are dropped on the belt (after the video started)."""


def _overlay(k: int) -> Overlay:
    return Overlay(
        items=[(1, -1.0 + 0.01 * k, 0.1, 0.03, 2, 0.9), (2, -0.5, -0.2, 0.03, 4, 1.0)],
        next_pick=2,
        counters=[f"frame {k}", "profit 1.00 EUR"],
    )


def _spawn(model, data, catalogue) -> None:
    pool = ItemPool(model, catalogue, Belt(model))
    big = (2.0, 2.0, 1.0)
    for i, (x, y) in enumerate([(-0.9, 0.1), (-0.6, -0.15), (-0.3, 0.2)]):
        pool.spawn(data, i, i % len(catalogue.types), x, y, 0.4 * i, (0.9, 0.2, 0.1, 1), scale=big)


def _record(tmp_path: Path, catalogue):
    """Frames sent to the video process, and the same states drawn in this process."""
    model, data = scene_at_home()
    start = copy.deepcopy(model)
    recorder = VideoRecorder(model, tmp_path / "clip.mp4", FPS, *SIZE)
    watch = ModelWatch(start)
    painter = FramePainter(start, *SIZE)
    expected, before_spawn = [], None
    for k in range(N_FRAMES):
        if k == SPAWN_AT:
            before_spawn = expected[-1]
            _spawn(model, data, catalogue)
        mujoco.mj_step(model, data, nstep=100)
        assert recorder.due(data.time)
        recorder.capture(data, _overlay(k))
        painter.apply(frame_state(model, data, watch))
        expected.append(painter.paint(_overlay(k)))
    painter.close()
    path = recorder.close()
    return path, recorder, np.array(expected), before_spawn, (model, data)


@pytest.fixture(scope="module")
def recorded(tmp_path_factory, catalogue):
    return _record(tmp_path_factory.mktemp("video"), catalogue)


def test_the_mp4_has_every_frame_at_its_size_and_nothing_else_is_left(recorded):
    path, recorder, expected, _, _ = recorded
    reader = imageio.get_reader(path)
    frames = np.array([f for f in reader])
    assert reader.get_meta_data()["fps"] == pytest.approx(FPS)
    reader.close()
    assert frames.shape == (N_FRAMES, SIZE[1], SIZE[0], 3)
    assert recorder.stats["frames"] == N_FRAMES
    assert recorder.stats["frames_cpu_s"] > 0 and recorder.stats["encoder_cpu_s"] > 0
    assert [p.name for p in path.parent.iterdir()] == [path.name]  # no temporary left
    assert not recorder._process.is_alive()


def test_the_video_process_draws_what_this_process_draws(recorded):
    """The decoded frames match the in-process drawings within H.264's loss, including the
    items spawned after the video process started (their model rows travel with the frames)."""
    path, _, expected, before_spawn, _ = recorded
    frames = np.array([f for f in imageio.get_reader(path)]).astype(float)
    error = np.abs(frames - expected).mean(axis=(1, 2, 3))
    assert error.max() < 3.5, error  # H.264 at crf 20 measured 2.1-2.4
    # Where the spawned items are, the frame changed far more than the encoding's error.
    changed = np.abs(expected[SPAWN_AT].astype(float) - before_spawn).max(axis=2) > 60
    assert changed.sum() > 200
    to_drawn = np.abs(frames[SPAWN_AT] - expected[SPAWN_AT])[changed].mean()
    to_empty = np.abs(frames[SPAWN_AT] - before_spawn)[changed].mean()
    assert to_drawn < 0.3 * to_empty, (to_drawn, to_empty)


def test_the_painter_draws_the_scene_as_a_renderer_of_the_scene_itself(recorded):
    """`FramePainter` on its own model copy, fed states, equals rendering the episode's own
    model and data (the frame the episode's process would have drawn); its cheaper drawing
    (boxes with fewer quads, the floor a square) changes a few pixels of a frame."""
    _, _, expected, _, (model, data) = recorded
    mujoco.mj_kinematics(model, data)
    drawn = {}
    for simplify in (False, True):
        painter = FramePainter(copy.deepcopy(model), *SIZE, simplify=simplify)
        painter.apply(frame_state(model, data))
        drawn[simplify] = painter.paint()
        painter.close()
    model.vis.quality.offsamples = 0
    vis = model.vis.global_
    vis.offwidth, vis.offheight = max(vis.offwidth, SIZE[0]), max(vis.offheight, SIZE[1])
    with mujoco.Renderer(model, SIZE[1], SIZE[0]) as renderer:
        renderer.update_scene(data, camera=view_camera())
        ghost(renderer.scene, ghosted_geoms(model))
        direct = renderer.render()
    np.testing.assert_array_equal(drawn[False], direct)
    changed = np.abs(drawn[True].astype(int) - direct).max(axis=2) > 8
    assert changed.mean() < 1e-3, changed.sum()
    # The last in-process frame is this state with its overlay drawn over it.
    overlay_free = np.abs(expected[-1].astype(int) - drawn[True]).max(axis=2) == 0
    assert overlay_free.mean() > 0.9


def test_an_infinite_floor_becomes_a_square_that_looks_the_same():
    model = mujoco.MjModel.from_xml_string(
        """<mujoco><asset><texture name="grid" type="2d" builtin="checker" width="64"
        height="64"/><material name="floor" texture="grid" texrepeat="8 8"/></asset>
        <worldbody><geom name="floor" type="plane" size="0 0 0.05" material="floor"/>
        </worldbody></mujoco>"""
    )
    floor = model.geom("floor").id
    repeat = model.mat_texrepeat[model.geom_matid[floor]].copy()
    assert finite_floors(model, 10.0) == [floor]
    assert model.geom_size[floor][:2] == pytest.approx([10.0, 10.0])
    assert model.mat_texrepeat[model.geom_matid[floor]] == pytest.approx(10.0 * repeat)
    assert finite_floors(model, 10.0) == []  # finite now
    assert finite_floors(scene_at_home()[0], 10.0) == []  # the cell's floor is finite


def test_a_failure_in_the_video_process_is_one_line_and_leaves_no_file(tmp_path):
    model, data = scene_at_home()
    other = mujoco.MjModel.from_xml_string("<mujoco><worldbody/></mujoco>")
    recorder = VideoRecorder(model, tmp_path / "clip.mp4", FPS, *SIZE)
    recorder.capture(data, Overlay())
    recorder.capture(mujoco.MjData(other), Overlay())  # a state of another model: nq differs
    with pytest.raises(VideoError) as failure:
        for _ in range(200):  # the failure arrives with a later frame, at the latest at close
            recorder.capture(data, Overlay())
            time.sleep(0.01)
        recorder.close()
    message = str(failure.value)
    assert message.startswith("video process: ValueError") and "\n" not in message
    assert list(tmp_path.iterdir()) == []
    assert not recorder._process.is_alive()


def test_an_encoder_that_cannot_write_is_a_refusal(tmp_path):
    model, data = scene_at_home()
    folder = tmp_path / "gone"
    folder.mkdir()
    recorder = VideoRecorder(model, folder / "clip.mp4", FPS, *SIZE)
    folder.rmdir()  # before ffmpeg opens its output (at the first frame)
    with pytest.raises(InvalidInput, match="video encoder can write") as refusal:
        for _ in range(200):
            recorder.capture(data, Overlay())
            time.sleep(0.01)
        recorder.close()
    assert "\n" not in str(refusal.value)
    assert not folder.exists()


def test_abort_drops_the_partial_video(tmp_path):
    model, data = scene_at_home()
    recorder = VideoRecorder(model, tmp_path / "clip.mp4", FPS, *SIZE)
    for _ in range(5):
        recorder.capture(data, Overlay())
    recorder.abort()
    assert list(tmp_path.iterdir()) == []
    assert not recorder._process.is_alive()


def test_a_killed_run_leaves_no_partial_video(tmp_path):
    """SIGKILL of `sortsim run`: its video process drops the temporary MP4 and ends."""
    out = tmp_path / "out"
    proc = subprocess.Popen(
        [sys.executable, "-m", "sim.cli.main", "run", "--perception", "truth",
         "--items", "20", "--duration", "20", "--out", str(out),
         "--video", str(out / "video.mp4"), "--quiet"],
        cwd=REPO_ROOT,
        env={**os.environ, "MUJOCO_GL": "egl", "PYOPENGL_PLATFORM": "egl"},
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )  # fmt: skip

    def hidden() -> list[str]:
        """The folder's hidden video files (a killed run's lock file and the temporaries of its
        streamed CSVs stay by design: the next run removes them, `tests/test_kill_recovery.py`)."""
        if not out.exists():
            return []
        return [p.name for p in out.iterdir() if p.name.startswith(".") and ".mp4" in p.name]

    end = time.monotonic() + 120
    while not any(n.endswith(".mp4") for n in hidden()):
        assert proc.poll() is None and time.monotonic() < end, "no video under way"
        time.sleep(0.05)
    time.sleep(1.0)  # frames are being encoded
    children = Path(f"/proc/{proc.pid}/task/{proc.pid}/children").read_text().split()
    assert children  # the video process
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait(timeout=30)
    end = time.monotonic() + 30
    while (hidden() or any(map(_running, children))) and time.monotonic() < end:
        time.sleep(0.1)
    assert hidden() == []
    assert not (out / "video.mp4").exists()
    assert not any(map(_running, children))


def _running(pid: str) -> bool:
    """Whether process `pid` still runs (a zombie waiting for its reaper does not)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"
