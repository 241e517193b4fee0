"""The README's picture of the cell: one off-screen frame from the `overview_camera`.

Run `MUJOCO_GL=egl python -m sim.render.picture docs/cell.png` to regenerate it.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import mujoco
import numpy as np

from sim.cell.robot import set_configuration
from sim.model.mjcf import load_model
from sim.paths import REPO_ROOT, SCENE_XML

DEFAULT_PATH = REPO_ROOT / "docs" / "cell.png"
POSE = (0.35, 0.55, 0.75)
"""Motor angles of the pictured pose [rad]: the platform off-centre, so the legs read apart."""


def render_cell(
    width: int = 800, height: int = 450, camera: str = "overview_camera", scene=SCENE_XML
) -> np.ndarray:
    """Render the cell of the MJCF `scene` from its camera `camera`, `width` x `height` [px].

    Returns:
        RGB image, shape (height, width, 3), uint8.
    """
    model = load_model(scene)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    set_configuration(model, data, POSE)
    with mujoco.Renderer(model, height=height, width=width) as renderer:
        renderer.update_scene(data, camera=camera)
        return renderer.render()


def save_picture(path: Path | str = DEFAULT_PATH, width: int = 800, height: int = 450) -> Path:
    """Render the overview picture and write it as PNG; returns the path."""
    import imageio.v3 as iio

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    iio.imwrite(path, render_cell(width, height), extension=".png", optimize=True)
    return path


def main(argv: list[str] | None = None) -> int:
    """Command line: `python -m sim.render.picture [PATH] [--width W] [--height H]`."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("path", nargs="?", default=str(DEFAULT_PATH), help="output PNG")
    parser.add_argument("--width", type=int, default=800, help="image width [px]")
    parser.add_argument("--height", type=int, default=450, help="image height [px]")
    args = parser.parse_args(argv)
    out = save_picture(args.path, args.width, args.height)
    print(f"wrote {out} ({out.stat().st_size // 1024} KB)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
