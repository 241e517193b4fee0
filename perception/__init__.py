"""Perception: camera model, calibration, belt grid, observation codes, HMMs, items.

Pure: takes images and arrays, never MuJoCo data, so it would run on a real camera's frames.
The public API is re-exported here lazily (PEP 562): importing `perception.codes` does not
import OpenCV or scikit-learn.
"""

from __future__ import annotations

import importlib

_EXPORTS = {
    "LensModel": "lens",
    "CameraCalibration": "calibration",
    "calibrate": "calibration",
    "BeltGrid": "grid",
    "CameraPipeline": "pipeline",
    "observation_code": "codes",
    "code_of_cell": "codes",
    "EMPTY_CODE": "codes",
    "HmmParams": "hmm",
    "StripeHmms": "hmm_stripes",
    "OnlineStripeHmms": "hmm_online",
    "save_models": "hmm_io",
    "load_models": "hmm_io",
    "items_kmeans": "items_from_grid",
    "items_components": "items_from_grid",
    "item_blobs": "item_blobs",
    "PerceptionError": "errors",
    "PerceptionInputError": "errors",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    if name not in _EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{_EXPORTS[name]}"), name)
