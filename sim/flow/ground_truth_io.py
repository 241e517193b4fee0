"""Ground-truth grid sequences on disk: .npz files with deterministic bytes.

`numpy.savez` stamps each member with the current time, so two saves of one flow differ; here
every member carries a fixed timestamp and is stored uncompressed, so the same flow gives the
same file byte for byte. `numpy.load` reads the files.
"""

from __future__ import annotations

import io
import zipfile
from pathlib import Path

import numpy as np

from sim.flow.catalogue import Catalogue
from sim.flow.generator import Flow
from sim.flow.ground_truth import flow_truth

_EPOCH = (1980, 1, 1, 0, 0, 0)


def save_npz(path: Path | str, **arrays: np.ndarray) -> None:
    """Writes `arrays` to an .npz file whose bytes depend only on the arrays (sorted by name)."""
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_STORED) as archive:
        for name in sorted(arrays):
            buffer = io.BytesIO()
            np.lib.format.write_array(
                buffer, np.ascontiguousarray(arrays[name]), allow_pickle=False
            )
            info = zipfile.ZipInfo(name + ".npy", date_time=_EPOCH)
            info.external_attr = 0o644 << 16
            archive.writestr(info, buffer.getvalue())


def save_flow_truth(path: Path | str, flow: Flow, catalogue: Catalogue) -> None:
    """Writes a flow and its ground-truth grid sequences.

    Members: classes and codes (rows, 5); the flow's per-item arrays (t_spawn, y, yaw,
    type_index, class_id, colour, stripe); belt_speed_mps and observation_period_s; type_names.
    """
    classes, codes = flow_truth(flow, catalogue)
    save_npz(
        path,
        classes=classes.astype(np.int8),
        codes=codes.astype(np.int8),
        t_spawn=flow.t_spawn,
        y=flow.y,
        yaw=flow.yaw,
        type_index=flow.type_index,
        class_id=flow.class_id,
        colour=flow.colour,
        stripe=flow.stripe,
        belt_speed_mps=np.array(flow.config.belt_speed_mps),
        observation_period_s=np.array(float(flow.config.observation_period_s)),
        type_names=np.array([t.name for t in catalogue.types]),
    )


def load_truth(path: Path | str) -> tuple[np.ndarray, np.ndarray]:
    """(classes, codes) int arrays (rows, 5) from a file written by `save_flow_truth`."""
    with np.load(path, allow_pickle=False) as data:
        return data["classes"].astype(np.int64), data["codes"].astype(np.int64)
