"""Camera calibration from rendered checkerboard views (`sortsim calibrate`)."""

from __future__ import annotations

import json

import cv2
import mujoco
import numpy as np
import pytest

from perception.camera.calibration import CameraCalibration, calibrate
from perception.camera.lens import ZED_HD_LEFT
from perception.errors import PerceptionError, PerceptionInputError
from sim.cell.camera import true_camera_matrix
from sim.cli.calibrate import DEFAULT_CALIBRATION
from sim.cli.main import main as cli_main
from sim.paths import REPO_ROOT, SCENE_XML

FIXTURE = REPO_ROOT / "tests" / "models" / "belt_camera.xml"


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    """`sortsim calibrate` on the fixture at the default 1280x720, 20 poses."""
    out = tmp_path_factory.mktemp("cal") / "camera.json"
    code = cli_main(["calibrate", "--scene", str(FIXTURE), "--out", str(out), "--seed", "1"])
    assert code == 0
    model = mujoco.MjModel.from_xml_path(str(FIXTURE))
    return CameraCalibration.load(out), true_camera_matrix(model, 1280, 720)


def test_calibration_recovers_the_true_focal_length(calibrated):
    result, truth = calibrated
    assert result.n_views >= 15
    assert result.camera_matrix[0, 0] == pytest.approx(truth[0, 0], rel=0.01)
    assert result.camera_matrix[1, 1] == pytest.approx(truth[1, 1], rel=0.01)
    assert np.abs(result.camera_matrix[:2, 2] - truth[:2, 2]).max() < 2.0
    assert result.rms_px < 0.5


def test_calibration_recovers_the_lens(calibrated):
    result, truth = calibrated
    # Compare what matters, the distortion field over the frame, not coefficients one by one.
    u, v = np.meshgrid(np.linspace(0, 1279, 17), np.linspace(0, 719, 11))
    rays = np.stack(
        [(u.ravel() - truth[0, 2]) / truth[0, 0], (v.ravel() - truth[1, 2]) / truth[1, 1]], 1
    )
    pts = np.c_[rays, np.ones(len(rays))]
    want, _ = cv2.projectPoints(pts, np.zeros(3), np.zeros(3), truth, ZED_HD_LEFT.dist_coeffs())
    got, _ = cv2.projectPoints(
        pts, np.zeros(3), np.zeros(3), result.camera_matrix, result.dist_coeffs
    )
    inside = (
        (want[:, 0, 0] > 0) & (want[:, 0, 0] < 1279) & (want[:, 0, 1] > 0) & (want[:, 0, 1] < 719)
    )
    error = np.linalg.norm((got - want)[inside, 0], axis=1)
    assert error.max() < 2.0


def test_committed_calibration_fits_the_cell_camera():
    result = CameraCalibration.load(DEFAULT_CALIBRATION)
    model = mujoco.MjModel.from_xml_path(str(SCENE_XML))
    truth = true_camera_matrix(model, *result.image_size)
    assert result.camera_matrix[0, 0] == pytest.approx(truth[0, 0], rel=0.01)
    assert result.rms_px < 0.5 and result.n_views >= 15


def test_round_trip_and_scaling(tmp_path):
    matrix = np.array([[624.0, 0, 639.5], [0, 624.0, 359.5], [0, 0, 1]])
    cal = CameraCalibration(matrix, ZED_HD_LEFT.dist_coeffs(), (1280, 720), 0.2, 20)
    cal.save(tmp_path / "c.json")
    back = CameraCalibration.load(tmp_path / "c.json")
    assert np.allclose(back.camera_matrix, matrix) and np.allclose(
        back.dist_coeffs, cal.dist_coeffs
    )
    half = cal.scaled((640, 360))
    assert half.camera_matrix[0, 0] == 312.0 and half.camera_matrix[0, 2] == 319.5
    with pytest.raises(PerceptionInputError, match="image_size"):
        cal.scaled((640, 640))


def test_bad_files_and_too_few_views_are_refused(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"camera_matrix": [[1, 0], [0, 1]]}))
    with pytest.raises(PerceptionInputError, match="calibration file"):
        CameraCalibration.load(bad)
    blank = [np.full((120, 160, 3), 40, np.uint8)] * 12
    with pytest.raises(PerceptionError, match="found in 0 of 12"):
        calibrate(blank, (9, 6), 0.03)
    assert cli_main(["calibrate", "--poses", "5", "--out", str(tmp_path / "x.json")]) == 2
