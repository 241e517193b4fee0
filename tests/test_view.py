"""`sortsim view`: the episode in MuJoCo's viewer on a virtual X display (Xvfb), its refusals.

The slow test starts its own Xvfb, runs a short truth episode in the viewer, grabs the X
display's pixels while the window shows the cell, and checks the picture and the exit code.
It is skipped where Xvfb is not installed (Debian: apt-get install xvfb).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
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


@pytest.fixture(scope="module")
def display():
    """A virtual X display of its own (Xvfb picks a free number), stopped afterwards."""
    if shutil.which("Xvfb") is None:
        pytest.skip("Xvfb is not installed (Debian: apt-get install xvfb)")
    read, write = os.pipe()
    screen = f"{SCREEN[0]}x{SCREEN[1]}x24"
    server = subprocess.Popen(
        ["Xvfb", "-displayfd", str(write), "-screen", "0", screen, "-nolisten", "tcp"],
        pass_fds=(write,),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    os.close(write)
    with os.fdopen(read) as pipe:
        number = pipe.readline().strip()
    if not number:
        server.kill()
        pytest.fail("Xvfb did not start")
    yield f":{number}"
    server.terminate()
    server.wait(timeout=10)


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
