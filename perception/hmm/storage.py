"""Saving and loading trained stripe HMMs as `.npz` files with a format version.

A file holds `format` (the string "sortsim-stripe-hmms"), `version` (an int), `pi` (S, N),
`A` (S, C, N, N) and `B` (S, N, M), and optionally `cells_per_item` (N,), the expected grid
cells per item of each class that the item extraction needs. Loading refuses, with one
`PerceptionInputError` line naming the file, anything that is not such a file: unreadable or not
a zip, another format or version, missing arrays, pickled objects, shapes other than the
expected ones, numbers that are not finite, or rows that do not sum to 1. Saving writes a
temporary beside the target (`.<name>.<pid>.<token>.tmp.npz`, the project's scheme for
temporaries) and renames it over the target.
"""

from __future__ import annotations

import os
import secrets
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from perception.codes import N_CODES, N_STATES
from perception.errors import PerceptionInputError
from perception.hmm.stripes import N_STRIPES, StripeHmms

FORMAT = "sortsim-stripe-hmms"
VERSION = 1


def save_models(path: Path | str, models: StripeHmms, cells_per_item=None) -> Path:
    """Write `models` (and optionally the expected cells per item of each class) to `path`.

    The `.npz` suffix is added if missing; the file is replaced atomically. Returns the path.
    """
    path = Path(path)
    if path.suffix != ".npz":
        path = path.with_name(path.name + ".npz")
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.{secrets.token_hex(4)}.tmp.npz")
    states = models.pi.shape[1]
    extra: dict[str, Any] = (
        {} if cells_per_item is None else {"cells_per_item": _cells(cells_per_item, path, states)}
    )
    try:
        np.savez(
            tmp,
            format=np.array(FORMAT),
            version=np.array(VERSION),
            pi=models.pi,
            A=models.A,
            B=models.B,
            **extra,
        )
        tmp.replace(path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


def load_models(
    path: Path | str,
    stripes: int = N_STRIPES,
    states: int = N_STATES,
    codes: int = N_CODES,
    coupled: bool | None = None,
) -> StripeHmms:
    """Read stripe HMMs written by `save_models`, checking format, version, shapes and sums.

    Args:
        path: The `.npz` file.
        stripes, states, codes: The S, N and M the caller expects.
        coupled: Expect coupled (True) or independent (False) transitions; None accepts either.

    Raises:
        PerceptionInputError: one line naming the file and what is wrong with it.
    """
    field = f"hmm file {path}"
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {key: data[key] for key in data.files}
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as exc:
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise PerceptionInputError(
            field, "a readable .npz written by save_models", reason
        ) from None
    missing = sorted({"format", "version", "pi", "A", "B"} - set(arrays))
    if missing:
        raise PerceptionInputError(field, "arrays format, version, pi, A, B", f"missing {missing}")
    if arrays["format"].shape != () or str(arrays["format"]) != FORMAT:
        raise PerceptionInputError(field, f"format {FORMAT!r}", str(arrays["format"])[:40])
    version = arrays["version"]
    if version.shape != () or version.dtype.kind not in "iu" or int(version) != VERSION:
        raise PerceptionInputError(field, f"format version {VERSION}", str(version)[:40])
    for name in ("pi", "A", "B"):
        if arrays[name].dtype.kind != "f":
            raise PerceptionInputError(field, f"{name} of floats", str(arrays[name].dtype))
    contexts = {None: (1, states), True: (states,), False: (1,)}[coupled]
    pi, a, b = arrays["pi"], arrays["A"], arrays["B"]
    expected = {"pi": (stripes, states), "B": (stripes, states, codes)}
    for name, arr in (("pi", pi), ("B", b)):
        if arr.shape != expected[name]:
            raise PerceptionInputError(field, f"{name} of shape {expected[name]}", arr.shape)
    if (
        a.ndim != 4
        or a.shape[0] != stripes
        or a.shape[1] not in contexts
        or a.shape[2:]
        != (
            states,
            states,
        )
    ):
        allowed = f"A of shape ({stripes}, {' or '.join(map(str, contexts))}, {states}, {states})"
        raise PerceptionInputError(field, allowed, a.shape)
    try:
        return StripeHmms(pi, a, b)
    except PerceptionInputError as exc:
        raise PerceptionInputError(field, f"{exc.field}: {exc.allowed}", exc.got) from None


def _cells(values, path, states: int = N_STATES) -> np.ndarray:
    allowed = f"cells_per_item of {states} counts, finite and > 0 for the item classes"
    arr = np.asarray(values)
    if arr.dtype.kind not in "fiu":
        raise PerceptionInputError(f"hmm file {path}", allowed, str(arr.dtype))
    arr = arr.astype(np.float64)
    ok = arr.shape == (states,) and not np.any(np.isnan(arr))
    if not ok or not np.all(np.isfinite(arr[1:])) or np.any(arr[1:] <= 0):
        got = arr.tolist() if arr.size <= states else f"shape {arr.shape}"
        raise PerceptionInputError(f"hmm file {path}", allowed, got)
    return arr


def load_cells_per_item(path: Path | str, states: int = N_STATES) -> np.ndarray | None:
    """The expected cells per item (N,) stored beside the models, None if the file has none."""
    load_models(path, states=states)
    with np.load(path, allow_pickle=False) as data:
        if "cells_per_item" not in data.files:
            return None
        return _cells(data["cells_per_item"], path, states)
