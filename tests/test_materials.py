"""Materials are data: a catalogue's [[material]] entries set the classes, the bins, the HMM
states, the values and the columns; the default catalogue keeps the thesis's three."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import mujoco
import numpy as np
import pytest

from perception.codes import THESIS_MATERIALS, Materials
from perception.hmm.training import count_models
from perception.items.from_grid import cells_per_item, items_components
from planner.decision.interface import DecisionContext, TrackedItem
from planner.errors import PlannerInputError
from planner.motion.kinematics import reachable_mask
from sim import config as episode_config
from sim.cell.robot import geometry_from_model
from sim.errors import InvalidInput
from sim.flow.catalogue import load_catalogue
from sim.flow.config import FlowConfig
from sim.flow.generator import generate_flow
from sim.flow.ground_truth import flow_truth
from sim.model.bin_layout import bin_centres
from sim.model.mjcf import cell_elements, load_scene, require_elements
from sim.paths import REPO_ROOT
from sim.results import outputs

FOUR = REPO_ROOT / "experiments" / "catalogues" / "pet_hdpe.toml"
EXAMPLE = REPO_ROOT / "experiments" / "four_materials.toml"


def _catalogue_text(materials: list[tuple[str, float]], rename: dict[str, str]) -> str:
    """The default catalogue with `[[material]]` entries and materials renamed."""
    text = (REPO_ROOT / "sim" / "data" / "items.toml").read_text()
    for old, new in rename.items():
        text = text.replace(f'material = "{old}"', f'material = "{new}"')
    head = "".join(f'[[material]]\nname = "{n}"\nvalue_eur = {v}\n\n' for n, v in materials)
    return head + text


def test_the_default_catalogue_is_the_thesiss_three_materials():
    cat = load_catalogue()
    assert cat.materials == THESIS_MATERIALS
    assert cat.materials.ids == (2, 3, 4) and cat.materials.n_states == 4
    assert {t.material: t.class_id for t in cat.types} == {"paper": 2, "plastic": 3, "aluminium": 4}


def test_a_four_material_catalogue_numbers_its_classes_in_file_order():
    cat = load_catalogue(FOUR)
    assert cat.materials.names == ("paper", "pet", "hdpe", "aluminium")
    assert cat.materials.values_eur == (0.22, 0.30, 0.20, 0.27)
    ids = {t.name: t.class_id for t in cat.types}
    assert ids["pet_bottle_0l5"] == ids["pet_bottle_1l5_crushed"] == 3
    assert ids["hdpe_bottle_1l"] == ids["hdpe_tub_0l5"] == 4
    assert ids["can_330_lying_crushed"] == 5
    assert cat.digest != load_catalogue().digest


@pytest.mark.parametrize(
    ("materials", "rename", "field"),
    [
        ([("paper", 0.2), ("plastic", 0.2)], {}, "material"),  # aluminium items, no material
        ([("paper", 0.2), ("plastic", 0.2), ("aluminium", 0.2), ("glass", 1)], {}, "item.material"),
        ([("paper", 0.2), ("Plastic", 0.2), ("aluminium", 0.2)], {}, "material.name"),
        ([("paper", 0.2), ("paper", 0.2), ("aluminium", 0.2)], {}, "material.name"),
        ([("paper", -1), ("plastic", 0.2), ("aluminium", 0.2)], {}, "material.value_eur"),
    ],
)
def test_a_bad_material_table_is_refused_naming_the_field(tmp_path, materials, rename, field):
    path = tmp_path / "items.toml"
    path.write_text(_catalogue_text(materials, rename))
    with pytest.raises(InvalidInput) as err:
        load_catalogue(path)
    assert err.value.field == field
    assert str(path) in str(err.value)


def test_materials_refuse_bad_names_and_counts():
    for names in [(), ("void", "a"), ("a",) * 2, tuple("abcdefghi"), ("has space",)]:
        with pytest.raises(ValueError):
            Materials(names, (0.1,) * len(names))
    with pytest.raises(ValueError):
        Materials(("a", "b"), (0.1,))


@pytest.mark.parametrize("count", range(1, 9))
def test_every_bin_layout_compiles_reachable_and_clear_of_the_belt(count):
    names = tuple(f"m{k}" for k in range(count))
    materials = Materials(names, (0.1,) * count)
    model = load_scene(materials=materials)
    require_elements(model, cell_elements(materials), "test")
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    geometry = geometry_from_model(model)
    drops = np.array([data.site(f"bin_{n}_drop").xpos for n in names])
    assert reachable_mask(geometry, drops).all()
    boxes = []
    for n in names:
        plate = model.geom(f"bin_{n}_floor_plate").id
        centre, half = data.geom_xpos[plate], model.geom_size[plate]
        lo, hi = centre[:2] - half[:2], centre[:2] + half[:2]
        assert abs(centre[1]) - half[1] >= 0.44, "a bin reaches under the belt (half width 0.4 m)"
        assert np.all(lo > -0.86) and np.all(hi < 0.86), "a bin outside the cage's posts"
        boxes.append((lo, hi))
    for i in range(count):
        for j in range(i):
            (a0, a1), (b0, b1) = boxes[i], boxes[j]
            assert np.any(a1 <= b0) or np.any(b1 <= a0), f"bins {i} and {j} overlap"
    sides = [np.sign(y) for _, y in bin_centres(count)]
    assert sides == [(-1.0) ** (k + 1) for k in range(count)]  # alternating, first on -y


def test_the_thesis_materials_keep_the_scene_files_bins():
    a, b = load_scene(), load_scene(materials=THESIS_MATERIALS)
    assert a.ngeom == b.ngeom and a.nbody == b.nbody
    np.testing.assert_array_equal(a.geom_size, b.geom_size)


def test_a_flow_follows_the_class_mix_of_four_materials():
    cat = load_catalogue(FOUR)
    priors = (0.4, 0.3, 0.2, 0.1)
    # independent draws (every row of the transitions the priors): the class shares follow them
    config = FlowConfig(
        n_items=2000,
        duration_s=1200.0,
        seed=3,
        n_materials=4,
        class_priors=priors,
        transitions=(priors,) * 4,
    )
    flow = generate_flow(config, cat)
    shares = np.bincount(flow.class_id, minlength=6)[2:] / len(flow)
    np.testing.assert_allclose(shares, priors, atol=0.035)  # 3 sigma of 2000 draws: <= 0.033
    for i, k in enumerate(flow.type_index):
        assert cat.types[int(k)].class_id == flow.class_id[i]
    classes, codes = flow_truth(flow, cat)
    assert set(np.unique(classes)) <= {1, 2, 3, 4, 5} and {3, 4}.issubset(set(np.unique(classes)))


def test_a_class_mix_of_the_wrong_size_is_refused_naming_the_key(tmp_path):
    path = tmp_path / "episode.toml"
    path.write_text(
        f'catalogue = "{FOUR}"\n[flow]\nclass_priors = [0.3, 0.3, 0.4]\n', encoding="utf-8"
    )
    with pytest.raises(InvalidInput) as err:
        episode_config.load(path)
    assert err.value.field == "flow.class_priors" and "4" in err.value.allowed
    path.write_text(f'catalogue = "{FOUR}"\n[values]\nglass = 0.1\n', encoding="utf-8")
    with pytest.raises(InvalidInput) as err:
        episode_config.load(path)
    assert err.value.field == "values.glass" and "pet" in err.value.allowed
    with pytest.raises(InvalidInput) as err:
        episode_config.load(None, catalogue=str(tmp_path / "missing.toml"))
    assert err.value.field == "catalogue"


def test_values_resolve_per_material_and_per_item_type():
    config = episode_config.load(EXAMPLE)
    cat = config.item_catalogue
    assert config.values.of_materials(cat.materials) == (0.22, 0.30, 0.20, 0.27)
    by_type = config.values.of_types(cat)
    k, crushed = cat.index("pet_bottle_1l5"), cat.index("pet_bottle_1l5_crushed")
    assert by_type == {k: 0.40, crushed: 0.40}
    table = config.to_dict()["values"]
    assert table == {"paper": 0.22, "pet": 0.30, "hdpe": 0.20, "aluminium": 0.27,
                     "pet_bottle_1l5": 0.40}  # fmt: skip
    assert episode_config.from_dict(config.to_dict()) == config  # what a manifest gives back


def test_hmms_and_grid_items_take_any_number_of_states():
    rng = np.random.default_rng(0)
    classes = rng.integers(1, 6, size=(40, 5))
    codes = rng.integers(1, 20, size=(40, 5))
    models = count_models([classes], [codes], n_states=5)
    assert models.pi.shape == (5, 5) and models.B.shape == (5, 5, 19)
    np.testing.assert_allclose(models.A.sum(axis=-1), 1.0)
    sizes = cells_per_item([classes], [0, 10, 10, 10, 10])
    assert sizes.shape == (5,) and math.isinf(sizes[0])
    found = items_components(classes, _geometry())
    assert set(found.class_id.tolist()) == {2, 3, 4, 5}


def _geometry():
    from perception.items.from_grid import GridGeometry

    return GridGeometry(row_pitch_m=0.0925)


def test_decisions_take_any_number_of_materials():

    item = TrackedItem.certain(1, -0.2, 0.1, 5, n_materials=4)
    assert item.class_probs == (0.0, 0.0, 0.0, 0.0, 1.0) and item.bin_class == 5
    with pytest.raises(PlannerInputError):
        TrackedItem.certain(1, 0.0, 0.0, 6, n_materials=4)
    bins = ((0.0, -0.5, 0.06), (0.1, 0.5, 0.06), (0.2, -0.5, 0.06), (0.3, 0.5, 0.06))
    context = DecisionContext(
        0.185, _Cycle(), _window(), bins=bins, values=(0.22, 0.30, 0.20, 0.27)
    )
    assert context.value_of(5) == 0.27 and context.bin_of(4) == (0.2, -0.5, 0.06)
    assert context.expected_value(item) == pytest.approx(0.27)


class _Cycle:
    def time_to_pick(self, start_xyz, item_xy, belt_speed):
        return 0.3

    def time_to_place(self, pick_xyz, bin_xyz):
        return 0.3


def _window():
    from planner.motion.reach_window import ReachWindow
    from sim.cell.cell import PICK_Z_NOMINAL

    model = load_scene()
    geometry = geometry_from_model(model)
    return ReachWindow.from_reachable(lambda p: reachable_mask(geometry, p), PICK_Z_NOMINAL)


def test_columns_follow_the_materials():
    assert outputs.episode_columns() == outputs.EPISODE_COLUMNS
    cols = outputs.episode_columns(load_catalogue(FOUR).materials)
    for group in ("picked", "entered", "purity", "recovery"):
        assert [c for c in cols if c.startswith(group + "_")] == [
            f"{group}_{m}" for m in ("paper", "pet", "hdpe", "aluminium")
        ]
    assert outputs.format_value("purity_hdpe", 0.5) == "0.5000"


def test_a_four_material_truth_episode_sorts_into_four_bins(tmp_path):
    """A short episode of the example config: every material has its bin; the profit is the
    per-material values plus the per-type one, recomputed from picks.csv and the flow."""
    from sim.cli.main import main

    out = tmp_path / "run"
    code = main(
        ["run", "--config", str(EXAMPLE), "--perception", "truth", "--items", "24",
         "--duration", "20", "--seed", "4", "--out", str(out), "--quiet"]
    )  # fmt: skip
    assert code == 0
    row = next(csv.DictReader(open(out / "episodes.csv")))
    picks = list(csv.DictReader(open(out / "picks.csv")))
    assert int(row["picked"]) >= 20 and int(row["wrong_bin"]) == 0
    names = ("paper", "pet", "hdpe", "aluminium")
    assert sum(int(row[f"picked_{m}"]) for m in names) == int(row["picked"])
    assert {p["bin"] for p in picks if p["success"] == "1"} == set(names)
    config = episode_config.load(EXAMPLE).replace(items=24, duration_s=20.0, seed=4)
    flow = generate_flow(config.flow_config(), config.item_catalogue)
    cat = config.item_catalogue
    worth = {"paper": 0.22, "pet": 0.30, "hdpe": 0.20, "aluminium": 0.27}
    expected = 0.0
    for p in picks:
        if p["success"] == "1" and p["bin"] == p["true_class"]:
            base = cat.types[int(flow.type_index[int(p["item_id"])])]
            name = base.variant_of or base.name
            expected += 0.40 if name == "pet_bottle_1l5" else worth[p["true_class"]]
    assert float(row["profit_eur"]) == pytest.approx(expected, abs=1e-4)
    assert Path(out / "manifest.json").exists()
