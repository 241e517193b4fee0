"""`sortsim view`: the episode in MuJoCo's viewer on a virtual X display (Xvfb), its refusals.

The slow test starts its own Xvfb, runs a short truth episode in the viewer, grabs the X
display's pixels while the window shows the cell, and checks the picture and the exit code.
Where Xvfb is not installed (Debian: apt-get install xvfb) the display tests are skipped, but
not in CI (`CI` set, as `.ci/run` does; it installs Xvfb): there they fail.

The Xvfb runs with `-noreset`. An X server resets when its last client disconnects, and a
connection opened while it resets is dropped: the screen grabs below connect and disconnect
while the viewer opens its connections, and without `-noreset` one viewer start in a few
dozen had GLFW fail to open the display (more often on a loaded machine).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np
import pytest

SCREEN = (1024, 768)


def _view(*args, env=None):
    return subprocess.Popen(
        [sys.executable, "-m", "sim.cli.main", "view", *map(str, args)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )


def test_no_display_is_refused_in_one_line():
    env = {k: v for k, v in os.environ.items() if k != "DISPLAY"}
    out, err = _view("--items", "3", env=env).communicate(timeout=120)
    assert "DISPLAY" in err and "xvfb-run" in err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert out == ""


def _without_xvfb() -> None:
    """Skip, with the reason and the cure; in CI (`CI` set, as `.ci/run` sets it), fail."""
    reason = "Xvfb is not installed (Debian: apt-get install xvfb)"
    if os.environ.get("CI", "").strip().lower() not in ("", "0", "false"):
        pytest.fail(f"{reason}: CI runs the viewer's tests (.ci/run installs it)")
    pytest.skip(reason)


@pytest.fixture(scope="module")
def display():
    """A virtual X display of its own (Xvfb picks a free number and writes it once it listens;
    `-noreset`: see the module's docstring), stopped afterwards."""
    if shutil.which("Xvfb") is None:
        _without_xvfb()
    read, write = os.pipe()
    screen = f"{SCREEN[0]}x{SCREEN[1]}x24"
    log = tempfile.TemporaryFile()  # its messages, shown if it fails
    server = subprocess.Popen(
        ["Xvfb", "-displayfd", str(write), "-screen", "0", screen, "-nolisten", "tcp", "-noreset"],
        pass_fds=(write,),
        stdout=subprocess.DEVNULL,
        stderr=log,
    )
    os.close(write)
    with os.fdopen(read) as pipe:
        number = pipe.readline().strip()
    try:
        if not number:
            pytest.fail(f"Xvfb did not start: {_tail(log)}")
        try:
            _grab(f":{number}")  # a client connects and is answered
        except OSError as exc:
            pytest.fail(f"Xvfb :{number} does not answer a client ({exc}): {_tail(log)}")
        yield f":{number}"
    finally:
        server.terminate()
        server.wait(timeout=10)
        log.close()


def _tail(log) -> str:
    log.seek(0)
    return " ".join(log.read().decode(errors="replace").split())[-500:]


def _env(display: str, **extra) -> dict:
    return {
        **os.environ,
        "DISPLAY": display,
        "MUJOCO_GL": "egl",
        "PYOPENGL_PLATFORM": "egl",
        **extra,
    }


def _grab(display: str) -> np.ndarray:
    from PIL import ImageGrab

    return np.asarray(ImageGrab.grab(xdisplay=display).convert("RGB"))


@pytest.mark.slow
def test_the_viewer_shows_the_cell_and_the_episode_ends(display):
    proc = _view(
        "--items", 4, "--duration", 3, "--perception", "truth", "--seed", 1, "--quiet",
        env=_env(display),
    )  # fmt: skip
    frame = None
    deadline = time.monotonic() + 120
    while proc.poll() is None and time.monotonic() < deadline:
        shot = _grab(display)
        if shot.std() > 10:  # the window is up and drawn (the bare root window is black)
            time.sleep(2.0)  # a few seconds of the episode
            frame = _grab(display)
            break
        time.sleep(0.5)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err
    assert "accuracy SP/SI" in out and "entered the belt (SI)       4" in out
    assert frame is not None, "the viewer's window never showed"
    window = np.argwhere(frame.any(axis=2))  # the window's pixels (the root window is black)
    (top, left), (bottom, right) = window.min(axis=0), window.max(axis=0)
    width, height = right - left + 1, bottom - top + 1
    assert 0.4 * SCREEN[0] < width <= SCREEN[0] and 0.4 * SCREEN[1] < height <= SCREEN[1]
    inside = frame[top : bottom + 1, left : right + 1].reshape(-1, 3)
    colours, counts = np.unique(inside // 16, axis=0, return_counts=True)
    assert len(colours) > 50  # shaded parts of a scene, not a blank or uniform window
    assert counts.max() < 0.5 * len(inside)  # no single colour fills it
    belt = np.all(inside < 30, axis=1).mean()  # the black belt seen from above
    floor = (np.ptp(inside, axis=1) < 12) & (inside.mean(axis=1) > 100)  # the grey floor
    assert 0.05 < belt < 0.6 and floor.mean() > 0.1


@pytest.mark.slow
def test_camera_perception_needs_an_off_screen_back_end_beside_the_viewer(display):
    proc = _view("--items", 3, env=_env(display, MUJOCO_GL="glfw"))
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 2 and out == ""
    assert "MUJOCO_GL" in err and "egl" in err and len(err.strip().splitlines()) == 1
