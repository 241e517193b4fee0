"""Loading MJCF files into MuJoCo models, with one-line errors for missing or broken files."""

from __future__ import annotations

from pathlib import Path

import mujoco

from sim.errors import ModelFileError
from sim.paths import ROBOT_XML, SCENE_XML


def load_model(path: str | Path) -> mujoco.MjModel:
    """Compile an MJCF file.

    Args:
        path: MJCF file path.

    Returns:
        The compiled model.

    Raises:
        ModelFileError: the file does not exist, is not a file, or does not compile; the
            message is one line naming the file.
    """
    path = Path(path)
    if not path.is_file():
        raise ModelFileError(path, "no such file")
    try:
        return mujoco.MjModel.from_xml_path(str(path))
    except (ValueError, OSError) as exc:
        reason = " ".join(str(exc).split())  # MuJoCo's messages span several lines
        raise ModelFileError(path, f"does not compile: {reason}") from exc


def load_scene() -> mujoco.MjModel:
    """The sorting cell (`models/cell/scene.xml`): robot, belt, bins, cameras, items."""
    return load_model(SCENE_XML)


def load_robot() -> mujoco.MjModel:
    """The robot alone (`models/abb_irb360/irb360.xml`)."""
    return load_model(ROBOT_XML)
