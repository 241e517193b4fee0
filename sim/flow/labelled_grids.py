"""Labelled grids for the stripe HMMs: generated flows, their true classes and codes, true items.

One recording per seed. The seed also picks the belt speed (x1, x1.2, x1.5) and the density
(50, 100, 120, 150 items per 90 s, thesis table 4.2), so a set of seeds mixes the conditions the
thesis recorded. Codes come from the flow's ground truth (`sim.flow.ground_truth`) or, in camera
mode, from
the camera pipeline in MuJoCo (`sim.evaluation.camera_recordings`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from planner.motion.belt_speeds import SPEED_FACTORS

DENSITIES = (50, 100, 120, 150)
DURATION_S = 90.0


@dataclass(frozen=True, eq=False)
class Recording:
    """One generated recording.

    Attributes:
        seed: Seed of the flow.
        speed_factor: Belt speed over x1.
        row_pitch_m: Belt travel per row [m].
        classes: (rows, 5) true classes 1.. (1 void, 2.. materials).
        codes: (rows, 5) observation codes 1..19.
        item_b: (n,) belt coordinate of each item's centre, v x (time it crosses the camera) [m].
        item_y: (n,) lateral position of each item's centre [m].
        item_class: (n,) material class ids 2, 3, ...
        item_cell: (n, 2) (row, stripe) of each item's centre.
        refused_rows: Rows whose camera frame the pipeline refused (camera mode).
    """

    seed: int
    speed_factor: float
    row_pitch_m: float
    classes: np.ndarray
    codes: np.ndarray
    item_b: np.ndarray
    item_y: np.ndarray
    item_class: np.ndarray
    item_cell: np.ndarray
    refused_rows: int = 0


def conditions(seed: int) -> tuple[float, int]:
    """(speed factor, items per 90 s) of a seed."""
    return SPEED_FACTORS[seed % 3], DENSITIES[(seed // 3) % 4]


def record(seed: int, catalogue, mix: dict | None = None) -> Recording:
    """Generate the flow of `seed` and its labelled grid (true codes; the camera's recordings
    of the same flows are `sim.evaluation.camera_recordings.camera_recording`).

    `mix`: the flow's class mix (`FlowConfig`'s stripe_priors, transitions, class_priors) when
    not the default of the catalogue's materials."""
    from sim.flow.config import stripe_of
    from sim.flow.generator import FlowConfig, generate_flow
    from sim.flow.ground_truth import flow_truth

    speed, n_items = conditions(seed)
    config = FlowConfig(
        n_items=n_items,
        duration_s=DURATION_S,
        speed_factor=speed,
        seed=seed,
        n_materials=catalogue.materials.count,
        **(mix or {}),
    )
    flow = generate_flow(config, catalogue)
    v = config.belt_speed_mps
    classes, codes = flow_truth(flow, catalogue)
    return Recording(
        seed=seed,
        speed_factor=speed,
        row_pitch_m=config.row_pitch_m,
        classes=np.asarray(classes),
        codes=np.asarray(codes),
        item_b=v * np.asarray(flow.tau),
        item_y=np.asarray(flow.y),
        item_class=np.asarray(flow.class_id),
        item_cell=np.stack([flow.row, stripe_of(flow.y, config.belt_width_m)], axis=1),
    )


def parse_seeds(text: str, field: str) -> list[int]:
    """Seeds from '0-9', '3,5,8' or '0-4,10'."""
    from sim.errors import InvalidInput

    seeds: list[int] = []
    try:
        for part in text.split(","):
            lo, _, hi = part.strip().partition("-")
            seeds.extend(range(int(lo), int(hi or lo) + 1))
    except ValueError:
        raise InvalidInput(field, "seeds like 0-9 or 1,4,7 (integers >= 0)", text) from None
    if not seeds or min(seeds) < 0:
        raise InvalidInput(field, "seeds like 0-9 or 1,4,7 (integers >= 0)", text)
    return seeds
