"""Where the project's files are: one place, so no module spells a path twice."""

from __future__ import annotations

from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]
MODELS_DIR = REPO_ROOT / "models"
ROBOT_XML = MODELS_DIR / "abb_irb360" / "irb360.xml"
SCENE_XML = MODELS_DIR / "cell" / "scene.xml"
DATA_DIR = REPO_ROOT / "sim" / "data"
EXPERIMENTS_DIR = REPO_ROOT / "experiments"
CAMERA_CALIBRATION_JSON = MODELS_DIR / "cell" / "belt_camera_calibration.json"
