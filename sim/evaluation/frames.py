"""The belt camera's frames of an episode as a labelled data set (COCO), `sortsim frames`.

An episode runs as `sortsim run` would run it (the same config, seed and options; the robots
pick as usual), and at every camera observation (`Episode.every(observation_period_s, ...)`)
the scene's belt camera's frame is kept, as the perception receives it: the lens's distorted
RGB frame (`sim.cell.camera.BeltCamera` at the config's `[camera]` size, one sample per pixel)
and its registered depth map (the ZED-class stereo error unless `depth_noise = false`, from a
random stream of the data set's own), with one mask per item in view from MuJoCo's segmentation
render of the same camera (`sim.render.segmentation`), distorted by the same lens onto the same
pixels. The folder:

    images/000000.png     the RGB frame (8-bit PNG)
    depth/000000.png      depth along the optical axis, 16-bit PNG in mm (0: no depth)
    annotations.json      COCO: info, licenses, images, annotations, categories

Each annotation is one item in one frame: `segmentation` (COCO's compressed RLE, column-major,
as `pycocotools.mask.encode` writes it), `bbox` [x, y, width, height] [px] of the mask, `area`
(its pixels), `category_id` (the item's material's class id, `categories` the catalogue's
materials), `iscrowd` 0, and the item: `item_id` (its id in the episode's flow), `item_type`
(its catalogue type), `visible_fraction` (of its top area, `sim.monitors.visibility`, on the
camera's full canvas), `position_m` (its centre in the world then [m]). `info` holds the camera
(intrinsics of the distorted frames, the lens's distortion coefficients) and the episode's
config, so the data set says how it was made.

The data set is written into a hidden folder beside `out` and renamed into place when complete
(an earlier data set in `out` is replaced whole), so a killed run leaves no half-written data
set; a killed run's folder is removed at the next start (`remove_stale`).
"""

from __future__ import annotations

import json
import os
import re
import secrets
import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np

from sim.cell.camera import CAMERA_NAME
from sim.cell.depth_noise import ZED_CLASS
from sim.config import EpisodeConfig
from sim.episode.runner import Cell, Episode, config_cell
from sim.errors import InvalidInput
from sim.monitors.visibility import VisibilityWatch
from sim.paths import process_alive
from sim.render.segmentation import BeltSegmentation
from sim.results.outputs import check_output_dir

if TYPE_CHECKING:
    from sim.episode.parts import EpisodeParts

ANNOTATIONS = "annotations.json"
IMAGES, DEPTH = "images", "depth"
DESCRIPTION = "sortsim frames: the belt camera's labelled frames of one episode"
"""`info.description` of a data set written here (an `--out` holding one may be replaced)."""
DEPTH_UNIT_M = 0.001
"""Depth PNGs are in this unit [m]: millimetres."""
_STAGING = re.compile(r"^\..+\.frames\.(?P<pid>\d+)\.[0-9a-f]{8}\.tmp$")


def rle_counts(mask: np.ndarray) -> list[int]:
    """Run lengths of a (height, width) bool mask in column-major order, starting with a run
    of zeros (COCO's uncompressed RLE)."""
    flat = np.asarray(mask, dtype=bool).ravel(order="F")
    edges = np.flatnonzero(flat[1:] != flat[:-1]) + 1
    bounds = np.concatenate([[0], edges, [flat.size]])
    counts = np.diff(bounds).tolist()
    return [0, *counts] if flat.size and flat[0] else counts


def encode_rle(mask: np.ndarray) -> dict:
    """COCO's compressed RLE of a (height, width) bool mask: {"size": [h, w], "counts": str},
    the string as `pycocotools.mask.encode` writes it (each count less the one two before
    from the third on, 5 bits a character, continuation bit 0x20, offset 48)."""
    counts = rle_counts(mask)
    chars = []
    for i, count in enumerate(counts):
        x = count - counts[i - 2] if i > 2 else count
        while True:
            c = x & 0x1F
            x >>= 5
            more = x != -1 if c & 0x10 else x != 0
            chars.append(chr((c | 0x20 if more else c) + 48))
            if not more:
                break
    return {"size": [int(mask.shape[0]), int(mask.shape[1])], "counts": "".join(chars)}


def decode_rle(rle: dict) -> np.ndarray:
    """The (height, width) bool mask of a COCO RLE (compressed string or list of counts)."""
    height, width = rle["size"]
    counts = rle["counts"]
    if isinstance(counts, str):
        counts = _string_counts(counts)
    flat = np.zeros(height * width, dtype=bool)
    position, value = 0, False
    for count in counts:
        if value:
            flat[position : position + count] = True
        position += count
        value = not value
    return flat.reshape((height, width), order="F")


def _string_counts(text: str) -> list[int]:
    """The run lengths of COCO's compressed RLE string."""
    counts: list[int] = []
    p = 0
    while p < len(text):
        x, k, more = 0, 0, True
        while more:
            c = ord(text[p]) - 48
            x |= (c & 0x1F) << (5 * k)
            more = bool(c & 0x20)
            p, k = p + 1, k + 1
            if not more and c & 0x10:
                x |= -1 << (5 * k)
        if len(counts) > 2:
            x += counts[-2]
        counts.append(x)
    return counts


def bbox_of(mask: np.ndarray) -> list[int]:
    """[x, y, width, height] [px] of the pixels of a non-empty mask (COCO's, as
    `pycocotools.mask.toBbox` gives it)."""
    rows = np.flatnonzero(mask.any(axis=1))
    cols = np.flatnonzero(mask.any(axis=0))
    x, y = int(cols[0]), int(rows[0])
    return [x, y, int(cols[-1]) - x + 1, int(rows[-1]) - y + 1]


class FrameRecorder:
    """Keeps the belt camera's frame, depth and item masks at each observation of an episode.

    Call it with the episode's parts every observation period (`Episode.every`).

    Args:
        folder: Where the images go (`images/`, `depth/` are made in it).
        cell: The episode's cell.
        config: The episode's config (the camera's size, the depth noise, the seed).
        every: Keep the frame of every `every`-th observation.
        keep_empty: Keep frames with no item in view too.
    """

    def __init__(
        self, folder: Path, cell: Cell, config: EpisodeConfig, every: int = 1,
        keep_empty: bool = False,
    ):  # fmt: skip
        self.folder, self.cell, self.config = Path(folder), cell, config
        self.every, self.keep_empty = int(every), bool(keep_empty)
        size = config.camera.size
        self.camera = cell.belt_camera(size)
        self.segmentation = BeltSegmentation(cell.model, cell.pool, size, name=CAMERA_NAME)
        self.watch = VisibilityWatch([self.segmentation], cell.items)
        self.noise = ZED_CLASS if config.depth_noise else None
        # The data set's own random stream for the depth error (not the perception's).
        self.rng = np.random.default_rng([int(config.seed), 0xF4A3E5])
        self.images: list[dict] = []
        self.annotations: list[dict] = []
        self.observations = 0
        for sub in (IMAGES, DEPTH):
            (self.folder / sub).mkdir(parents=True, exist_ok=True)

    def __call__(self, parts: EpisodeParts) -> None:
        """Keep this observation's frame (unless skipped)."""
        self.observations += 1
        if (self.observations - 1) % self.every:
            return
        items = self.cell.items
        items.kinematics()
        data = items.current()
        canvas = self.segmentation.render(data)
        slots = self.segmentation.distort(canvas)
        present = np.flatnonzero(np.bincount(slots.ravel() + 1, minlength=1)[1:])
        if not len(present) and not self.keep_empty:
            return
        rgb, depth = self.camera.render_rgbd(data)
        if self.noise is not None:
            depth = self.noise.apply(depth, self.rng)
        fractions, _ = self.watch.fractions(self.segmentation, self.segmentation.counts(canvas))
        image_id = len(self.images)
        name = f"{image_id:06d}.png"
        _write_png(self.folder / IMAGES / name, cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
        _write_png(self.folder / DEPTH / name, depth_png(depth))
        height, width = slots.shape
        self.images.append(
            {
                "id": image_id,
                "file_name": f"{IMAGES}/{name}",
                "depth_file": f"{DEPTH}/{name}",
                "width": width,
                "height": height,
                "time_s": round(float(data.time), 4),
            }
        )
        for slot in present.tolist():
            self.annotations.append(self._annotation(image_id, slot, slots == slot, fractions))

    def _annotation(self, image_id: int, slot: int, mask: np.ndarray, fractions: dict) -> dict:
        """The COCO annotation of the item in `slot` in image `image_id`."""
        pool, items = self.cell.pool, self.cell.items
        item_id = int(pool.item_ids[slot])
        item_type = pool.catalogue.types[int(pool.type_index[slot])]
        fraction = fractions.get(item_id)
        return {
            "id": len(self.annotations) + 1,
            "image_id": image_id,
            "category_id": self.cell.materials.id_of(item_type.material),
            "segmentation": encode_rle(mask),
            "area": int(mask.sum()),
            "bbox": bbox_of(mask),
            "iscrowd": 0,
            "item_id": item_id,
            "item_type": item_type.name,
            "visible_fraction": None if fraction is None else round(float(fraction), 4),
            "position_m": [round(float(v), 5) for v in items.position(slot)],
        }

    def dataset(self) -> dict:
        """The COCO data set of the frames kept so far."""
        materials = self.cell.materials
        segmentation = self.segmentation
        lens = segmentation.lens
        return {
            "info": {
                "description": DESCRIPTION,
                "version": "1",
                "segmentation": "COCO compressed RLE (column-major), pycocotools-compatible",
                "camera": {
                    "name": CAMERA_NAME,
                    "frames": "distorted by the lens, as the perception receives them",
                    "width": segmentation.frame_size[0],
                    "height": segmentation.frame_size[1],
                    "camera_matrix": segmentation.frame_matrix.round(6).tolist(),
                    "dist_coeffs": [] if lens is None else lens.dist_coeffs().tolist(),
                    "depth_unit_m": DEPTH_UNIT_M,
                    "depth_noise": self.noise is not None,
                },
                "seed": self.config.seed,
                "config": self.config.to_dict(),
            },
            "licenses": [],
            "images": self.images,
            "annotations": self.annotations,
            "categories": [
                {"id": materials.id_of(name), "name": name, "supercategory": "material"}
                for name in materials.names
            ],
        }

    def close(self) -> None:
        """Frees the segmentation renderer."""
        self.segmentation.close()


def depth_png(depth: np.ndarray) -> np.ndarray:
    """A depth map [m] (NaN: none) as the uint16 millimetres of a depth PNG (0: none)."""
    z = np.asarray(depth, dtype=np.float64) / DEPTH_UNIT_M
    z = np.where(np.isfinite(z) & (z > 0.0), np.rint(z), 0.0)
    return np.clip(z, 0, np.iinfo(np.uint16).max).astype(np.uint16)


def _write_png(path: Path, image: np.ndarray) -> None:
    ok, png = cv2.imencode(".png", image)
    if not ok:
        raise OSError(f"could not encode {path.name}")
    path.write_bytes(png.tobytes())


@dataclass(frozen=True)
class FramesResult:
    """What `record_frames` wrote.

    Attributes:
        out: The data set's folder.
        images: Frames kept.
        annotations: Item masks in them.
        observations: Camera observations of the episode.
        episode_row: The episode's episodes.csv counters (`EpisodeMetrics.row`).
    """

    out: Path
    images: int
    annotations: int
    observations: int
    episode_row: dict


def check_out(out: Path | str) -> Path:
    """Refuse, before any work, a data-set folder that could not be written: as
    `check_output_dir`, and an existing folder must be empty or hold an earlier data set of
    `sortsim frames` (it is replaced whole), in a folder where its replacement can be made.

    Raises:
        InvalidInput: one line naming `--out`.
    """
    out = check_output_dir(out, "--out")
    if not out.exists():
        return out
    entries = sorted(p.name for p in out.iterdir())
    if entries and not _is_dataset(out, entries):
        allowed = "an empty or new folder, or one holding a sortsim frames data set (replaced)"
        raise InvalidInput("--out", allowed, str(out))
    parent = Path(os.path.abspath(out)).parent
    if not os.access(parent, os.W_OK | os.X_OK):
        allowed = f"a folder in a writable folder ({parent} is not: the data set is made there)"
        raise InvalidInput("--out", allowed, str(out))
    return out


def _is_dataset(out: Path, entries: list[str]) -> bool:
    """Whether folder `out` (holding `entries`) holds a data set written here and nothing else."""
    if ANNOTATIONS not in entries or not set(entries) <= {ANNOTATIONS, IMAGES, DEPTH}:
        return False
    try:
        info = json.loads((out / ANNOTATIONS).read_text(encoding="utf-8")).get("info", {})
    except (OSError, UnicodeDecodeError, ValueError, AttributeError):
        return False
    return isinstance(info, dict) and info.get("description") == DESCRIPTION


def check_every(every: object) -> int:
    """Refuse a `--every` that is not a whole number of observations of at least one."""
    if isinstance(every, bool) or not isinstance(every, int) or every < 1:
        raise InvalidInput("--every", "an integer >= 1 (observations)", every)
    return every


def remove_stale(out: Path | str) -> list[Path]:
    """Remove the staging folders beside `out` that killed runs left; returns them."""
    parent = Path(os.path.abspath(out)).parent
    removed: list[Path] = []
    try:
        names = os.listdir(parent)
    except OSError:
        return removed
    for name in names:
        match = _STAGING.match(name)
        path = parent / name
        if match and not process_alive(int(match["pid"])) and path.is_dir():
            shutil.rmtree(path, ignore_errors=True)
            removed.append(path)
    return removed


def _staging(out: Path, what: str = "frames") -> Path:
    """A fresh hidden folder beside `out`, named with this process's id."""
    parent = Path(os.path.abspath(out)).parent
    return parent / f".{out.name}.{what}.{os.getpid()}.{secrets.token_hex(4)}.tmp"


def _publish(staging: Path, out: Path) -> None:
    """Rename the finished data set `staging` to `out`, replacing what `out` held."""
    out = Path(os.path.abspath(out))
    if out.exists() and any(out.iterdir()):
        old = _staging(out)
        os.rename(out, old)
        os.rename(staging, out)
        shutil.rmtree(old, ignore_errors=True)
    else:
        if out.exists():
            out.rmdir()
        os.rename(staging, out)


def record_frames(
    config: EpisodeConfig, out: Path | str, every: int = 1, keep_empty: bool = False,
    progress=None,
) -> FramesResult:  # fmt: skip
    """Run the episode of `config` and write its camera frames as a data set in `out`.

    Args:
        config: The episode's config.
        out: The data set's folder (checked by `check_out`).
        every: Keep the frame of every `every`-th camera observation.
        keep_empty: Keep frames with no item in view too.
        progress: Called with (fraction, status line) while the episode runs.
    """
    out = Path(out)
    cell = config_cell(config)
    staging = _staging(out)
    staging.mkdir(parents=True)
    try:
        recorder = FrameRecorder(staging, cell, config, every, keep_empty)
        try:
            with Episode(config, cell, progress=progress) as episode:
                episode.every(config.observation_period_s, recorder)
                episode.reset()
                episode.run()
            dataset = recorder.dataset()
        finally:
            recorder.close()
        text = json.dumps(dataset, indent=1)
        (staging / ANNOTATIONS).write_text(text + "\n", encoding="utf-8")
        _publish(staging, out)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    return FramesResult(
        out,
        len(dataset["images"]),
        len(dataset["annotations"]),
        recorder.observations,
        episode.metrics.row(),
    )
