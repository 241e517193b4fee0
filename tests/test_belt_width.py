"""`[belt] width_m`: the belt's width, which the flow's stripes, the model (belt, rails, camera
rig, bins), the robot's window, the camera's grid and the planners' grid follow; items the robot
cannot reach are missed, and the default width changes nothing."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from perception.camera.depth_footprint import BELT_EDGE_M
from perception.codes import Materials
from sim import config as episode_config
from sim.cell.camera import BeltCamera, belt_edge_margin, belt_grid, camera_pipeline
from sim.cell.cell import PICK_Z_NOMINAL, Cell
from sim.episode.runner import run_episode
from sim.errors import InvalidInput
from sim.experiments import sweep_config
from sim.flow.config import BELT_WIDTH_M, X_CAMERA, FlowConfig, stripe_of
from sim.flow.generator import EDGE_MARGIN_M, generate_flow
from sim.model.belt_width import reaches
from sim.model.scene_edits import CellSettings, compile_scene
from sim.sensing.perception import hmm_cache_path

BINS = ("paper", "plastic", "aluminium")


def _flow(width: float, n_items: int = 300, seed: int = 3):
    config = episode_config.EpisodeConfig(
        items=n_items, duration_s=180.0, seed=seed, belt=episode_config.Belt(width_m=width)
    )
    flow = generate_flow(config.flow_config(), config.item_catalogue)
    types = flow.item_types(config.item_catalogue)
    half_y = np.array([t.half_extents(a)[1] for t, a in zip(types, flow.yaw, strict=True)])
    return flow, half_y


def test_items_spread_over_the_whole_width_of_a_wide_belt_and_stay_on_it():
    wide, half_y = _flow(1.2)
    thesis, _ = _flow(0.8)
    assert wide.config.belt_width_m == 1.2 and wide.config.stripe_width_m == pytest.approx(0.24)
    # Centres to within 8 cm of both edges (a small item's centre lies up to 5.5 cm from it).
    assert wide.y.min() < -0.52 and wide.y.max() > 0.52
    assert np.all(np.abs(wide.y) + half_y <= 0.6 - EDGE_MARGIN_M + 1e-9)
    assert np.array_equal(stripe_of(wide.y, 1.2), wide.stripe)
    assert set(np.bincount(wide.stripe, minlength=5) > 0) == {True}
    # The same seed on the thesis's belt: the same items, within +-0.4 m.
    assert np.abs(thesis.y).max() < 0.4
    assert np.array_equal(np.sort(thesis.class_id), np.sort(wide.class_id))


def test_a_narrow_belt_keeps_every_footprint_on_it():
    narrow, half_y = _flow(0.4)
    assert np.all(np.abs(narrow.y) + half_y <= 0.2 - EDGE_MARGIN_M + 1e-9)
    assert narrow.y.min() < -0.12 and narrow.y.max() > 0.12
    # An item wider than its outer stripe (0.08 m) lies as near it as the belt allows.
    outside = stripe_of(narrow.y, 0.4) != narrow.stripe
    assert outside.any() and np.all(np.isin(narrow.stripe[outside], (0, 4)))


def test_the_default_width_is_the_thesis_belt_to_the_bit():
    from sim.model.mjcf import load_scene

    assert belt_edge_margin(load_scene()) == BELT_EDGE_M
    a = generate_flow(FlowConfig(seed=5), _catalogue())
    b = generate_flow(FlowConfig(seed=5, belt_width_m=BELT_WIDTH_M), _catalogue())
    for name in ("t_spawn", "y", "yaw", "type_index", "stripe", "scale"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    assert hmm_cache_path() == hmm_cache_path(belt_width_m=0.8) != hmm_cache_path(belt_width_m=1.2)
    base = episode_config.EpisodeConfig()
    assert base.cell_settings == CellSettings() and base.cell_settings.is_default
    wide = base.replace(belt=episode_config.Belt(width_m=1.2))
    assert wide.cell_settings == CellSettings(belt_width_m=1.2)
    assert wide.to_dict()["belt"]["width_m"] == 1.2


def _catalogue():
    return episode_config.EpisodeConfig().item_catalogue


def test_a_sweeps_identity_changes_only_with_a_width_away_from_the_thesis():
    grid = {"sweep": {"name": "w", "items": [10], "seeds": 1}, "base": {"perception": "truth"}}
    same = {**grid, "base": {"perception": "truth", "belt": {"width_m": 0.8}}}
    wide = {**grid, "base": {"perception": "truth", "belt": {"width_m": 1.2}}}
    identity = sweep_config.from_dict(grid, "s.toml").identity
    assert sweep_config.from_dict(same, "s.toml").identity == identity
    assert sweep_config.from_dict(wide, "s.toml").identity != identity


@pytest.mark.parametrize("width", [1.5, 0.3, "wide"])
def test_a_width_out_of_range_is_refused_naming_the_key(tmp_path, width):
    path = tmp_path / "c.toml"
    path.write_text(f"[belt]\nwidth_m = {width!r}\n".replace("'", '"'))
    with pytest.raises(InvalidInput) as refused:
        episode_config.load(path)
    assert refused.value.field == "belt.width_m" and "0.4..1.2 m" in str(refused.value)


@pytest.fixture(scope="module", params=[0.4, 1.2])
def cell_of(request):
    model = compile_scene(CellSettings(belt_width_m=request.param))
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    return request.param, model, data


def test_the_model_follows_the_width(cell_of):
    width, model, data = cell_of
    half, dw = 0.5 * width, 0.5 * width - 0.4
    assert model.geom("belt").size[1] == pytest.approx(half, abs=1e-12)
    for rail in ("rail_left", "rail_right"):
        assert abs(model.geom(rail).pos[1]) == pytest.approx(0.42 + dw, abs=1e-12)
    for k in range(4):
        assert abs(data.geom(f"marker_{k}").xpos[1]) == pytest.approx(0.52 + dw, abs=1e-12)
    from sim.cell.robot import geometry_from_model

    geometry = geometry_from_model(model)
    rail_outside = 0.43 + dw  # the rails' outer faces
    for name in BINS:
        plate = model.geom(f"bin_{name}_floor_plate").id
        inner = abs(data.geom_xpos[plate][1]) - model.geom_size[plate][1]
        assert inner >= rail_outside + 0.01, f"bin {name} reaches under the belt or its rails"
        drop = data.site(f"bin_{name}_drop").xpos
        side = np.sign(drop[1])
        assert reaches(geometry, drop, side), f"bin {name}'s release point out of reach"
        assert inner < abs(drop[1]) < inner + 2 * model.geom_size[plate][1]  # over the bin


def test_the_camera_sees_the_whole_width_and_codes_it_in_five_stripes(cell_of):
    width, model, data = cell_of
    half = 0.5 * width
    grid = belt_grid(model, X_CAMERA, 0.5)
    assert (grid.y_min, grid.y_max) == pytest.approx((-half, half), abs=1e-12)
    assert grid.stripe_width == pytest.approx(width / 5, abs=1e-12)
    size = (640, 360)
    with BeltCamera(model, *size) as camera:
        frame = camera.render(data)
    pipeline = camera_pipeline(model, data, size, grid)
    view = pipeline.locate(frame)  # the markers found on both sides
    # The belt's edges over the longest row's band, on the belt and 15 cm above it.
    corners = np.array(
        [(X_CAMERA + dx, s * half, z) for dx in (-0.15, 0.15) for s in (-1, 1) for z in (0, 0.15)]
    )
    px = view.project(corners)
    assert np.all(px >= 20) and np.all(px <= np.array(size) - 20)
    # The rails, seen more obliquely on the wider belt, are kept farther from the items.
    margin = belt_edge_margin(model)
    assert margin == (BELT_EDGE_M if width <= 0.8 else pytest.approx(0.0137, abs=5e-4))
    assert pipeline.band_mapper(0.185).edge_margin_m == margin


def test_the_robot_reaches_nearly_the_whole_wide_belt_but_its_window_narrows_at_the_edges():
    cell = Cell(settings=CellSettings(belt_width_m=1.2))
    window = cell.robots[0].window
    assert window.pick_z == PICK_Z_NOMINAL
    reach = max(abs(y) for y in np.linspace(-0.6, 0.6, 241) if window.bounds(y) is not None)
    assert 0.55 < reach < 0.6  # the cup's reach at the belt: the IRB 360's ~1.2 m circle
    centre = np.subtract(*window.bounds(0.0)[::-1])
    edge = np.subtract(*window.bounds(0.55)[::-1])
    assert edge < 0.5 * centre


def test_a_wide_belt_runs_with_items_across_it_and_every_item_accounted_for():
    config = episode_config.load(
        None, items=24, duration_s=20.0, perception="truth", planner="fifo", seed=2
    ).replace(belt=episode_config.Belt(width_m=1.2))
    flow = generate_flow(config.flow_config(), config.item_catalogue)
    assert flow.y.min() < -0.4 and flow.y.max() > 0.4  # beyond the thesis belt on both sides
    result = run_episode(config)
    row = result.episode_row
    assert row["entered"] == 24
    assert row["picked"] + row["missed"] + row["dropped"] == 24
    assert row["picked"] >= 12
    picked = [int(p["item_id"]) for p in result.pick_rows if p["success"]]
    assert np.abs(flow.y[picked]).max() > 0.4  # picked off the belt's outer parts too


@pytest.mark.parametrize("count", range(1, 9))
def test_a_catalogues_bins_on_the_widest_belt_are_reached_or_refused(count):
    names = tuple(f"m{k}" for k in range(count))
    materials = Materials(names, (0.1,) * count)
    settings = CellSettings(belt_width_m=1.2)
    if count > 4:  # four on a side: the corner bins lie beyond the robot's reach
        with pytest.raises(InvalidInput) as refused:
            compile_scene(settings, materials=materials)
        assert refused.value.field == "belt.width_m"
        return
    model = compile_scene(settings, materials=materials)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    from sim.cell.robot import geometry_from_model

    geometry = geometry_from_model(model)
    for name in names:
        drop = data.site(f"bin_{name}_drop").xpos
        assert reaches(geometry, drop, np.sign(drop[1]))
        assert _over_bin(model, data, name, drop)


def _over_bin(model, data, name, point) -> bool:
    """Whether `point` lies over bin `name`'s floor plate (x, y)."""
    plate = model.geom(f"bin_{name}_floor_plate").id
    centre, half = data.geom_xpos[plate][:2], model.geom_size[plate][:2]
    return bool(np.all(np.abs(np.asarray(point)[:2] - centre) <= half))


def test_a_report_of_two_widths_groups_by_the_belts_width(tmp_path, capsys):
    from sim.cli import main as cli
    from sim.cli.run import write_run

    folders = []
    for width in (0.8, 1.2):
        config = episode_config.load(
            None, items=6, duration_s=4.0, perception="truth", seed=3
        ).replace(belt=episode_config.Belt(width_m=width), cup=episode_config.Cup(0.06))
        folder = tmp_path / f"w{width}"
        write_run(folder, config, run_episode(config))
        folders.append(str(folder))
    assert cli.main(["report", *folders, "--out", str(tmp_path / "report")]) == 0
    assert "Grouped by belt width" in capsys.readouterr().out
