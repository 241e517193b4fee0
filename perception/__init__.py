"""Perception: camera model, calibration, belt grid, observation codes, HMMs, items.

Pure: takes images and arrays, never MuJoCo data, so it would run on a real camera's frames.
The public API is re-exported here lazily (PEP 562): importing `perception.codes` does not
import OpenCV or scikit-learn.
"""

from __future__ import annotations

import importlib

_EXPORTS = {
    "LensModel": "camera.lens",
    "CameraCalibration": "camera.calibration",
    "calibrate": "camera.calibration",
    "BeltGrid": "camera.grid",
    "CameraPipeline": "camera.pipeline",
    "observation_code": "codes",
    "code_of_cell": "codes",
    "EMPTY_CODE": "codes",
    "HmmParams": "hmm.model",
    "StripeHmms": "hmm.stripes",
    "OnlineStripeHmms": "hmm.online",
    "save_models": "hmm.storage",
    "load_models": "hmm.storage",
    "items_kmeans": "items.from_grid",
    "items_components": "items.from_grid",
    "item_blobs": "items.blobs",
    "split_region": "items.split",
    "SplitSettings": "items.split",
    "PerceptionError": "errors",
    "PerceptionInputError": "errors",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    if name not in _EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{_EXPORTS[name]}"), name)
