"""What the camera sees of the belt once per observation period: detections for the tracker.

The camera's source of detections, with the interface of `sim.sensing.truth.TruthPerception`
(`observe(t) -> list[Detection]`):

- `CameraPerception`: the belt camera's frame and its registered depth map (a stereo camera's
  output) are rendered (`sim.cell.camera.BeltCamera`, real lens distortion; only the window the
  row's band is seen in, `CameraWindow`, but every `WHOLE_FRAME_EVERY`-th frame), turned into a
  row of 5 observation codes from the items' footprints (`perception.camera.pipeline`), filtered
  by the online stripe HMMs (`perception.hmm.online`), and items are extracted from the decoded
  class grid (`perception.items.from_grid`). The thesis runs k-means on batches of 20 rows;
  online that would report an item 10 s after it passed the camera, 1.85 m downstream at x1 and
  so already past the robot 1.48 m away. Here items are the blobs of item pixels of a sliding
  window of rows (`perception.items.blobs`; touching items are cut apart by their footprints'
  shape and the steps in height between them, `perception.items.split`), reported the period
  after their last row, at the centroid of their pixels (the 5-stripe grid alone would place an
  item up to 8 cm off, more than the cup's lip tolerates), with the filtered HMM posteriors of
  the cells they cover as class probabilities. (Connected regions of one decoded class, the
  components alternative of `items_from_grid`, split an item whose cells decode to two materials
  into two phantom items.) A frame the pipeline cannot use is counted and its row read as empty.

The rows are belt travel, not time, as a line-scan camera's triggered by the belt's encoder
(`sim.cell.conveyor.BeltEncoder`): a frame is taken each time the belt has run one row (the
set speed x the observation period; the episode's `BeltRowEvent`), and every belt coordinate
is the encoder's travel. A belt that a fault stops gives no rows, one that runs slow fewer a
second, and the stripe HMMs, the item window and the reported positions are as at the set
speed.
"""

from __future__ import annotations

import hashlib
import logging
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from perception.codes import EMPTY_CODE, VOID
from perception.errors import PerceptionError
from perception.hmm.online import OnlineStripeHmms
from perception.items.blobs import item_blobs
from perception.items.classifier import CLASSIFIER_MODES, combine
from perception.items.features import item_features
from perception.items.split import SplitSettings
from sim.cell.conveyor import BeltEncoder
from sim.cell.depth_noise import ZED_CLASS, StereoDepthNoise
from sim.config.plant import FRAME_SIZE
from sim.errors import InvalidInput
from sim.flow.config import BELT_WIDTH_M, X_CAMERA
from sim.paths import REPO_ROOT
from sim.sensing.item_classifier import trained_item_classifier
from sim.sensing.tracking import Detection
from sim.user_cache import cache_dir

log = logging.getLogger(__name__)

_HMM_INPUTS = (
    "sim/data/items.toml",
    "sim/flow/generator.py",
    "sim/flow/config.py",
    "sim/flow/ground_truth.py",
    "sim/flow/labelled_grids.py",
    "sim/sensing/stripe_hmms.py",
    "perception/hmm/training.py",
    "perception/hmm/stripes.py",
)
CAMERA_SIZE = FRAME_SIZE
"""The belt camera's default frame size [px] (the episode config's `[camera]`)."""
WHOLE_FRAME_EVERY = 10
"""The camera perception renders every this-many-th frame whole (the first locates the belt;
each checks the markers, which lie outside the window the footprints use, are where they
were): every 5 s at the thesis's 0.5 s period. The frames between are read out as the window
alone (`sim.cell.camera.CameraWindow`)."""
WINDOW_ROWS = 12
COMPLETE_ROW = WINDOW_ROWS - 2
"""Window row whose item regions are reported: complete, the newest row did not add to them."""
ITEM_SPLIT = SplitSettings(step_m=0.05, concave_ratio=1.2, concave_depth_m=0.012, rejoin=True)
"""How touching items are cut apart. Tuned first on 30 training flows of the uniform world with
exact depth (seeds 100-109 at x1, x1.2, x1.5, 100 items in 90 s;
`sim.evaluation.segmentation_eval`), one setting moved at a time: every item was found once
for a neck ratio of 0.4-0.7, a wall step of 5-30 mm, a smallest core of 6-20 mm and a raster of
3 or 4 mm. In the varied world with the stereo depth's noise (training seeds 100-102 at x1,
100-101 at x1.5, 500 items), walls at 10 mm split 14 % of the items (lying bottles and cans: a
round item's flank falls to the belt in a noisy step), at 30 mm 3.6 %, at 50 mm 1.8 % with 0.8 %
merged; without walls 1.8 % split and 1.2 % merged. Walls at 50 mm still part a can or a
bottle (6-12 cm tall) from a sheet it touches. Busy belts (training seeds 20-22, 60 s flows of
6-24 items per metre at x1 and x1.5, `sim.evaluation.segmentation_density`): items touch over
most of a side, where neither walls nor necks part them (x1, 18 items/m: 22.5 % merged); cuts
at concave notches at least 12 mm deep, along a chord at most 1.2 times their summed depths,
leave 3.2 % merged and 2.0 % split there, 0 % merged at 6 and 12 items/m (ratios 1.0-1.5 and
depths 6-12 mm within a point of each other); rejoining touching pieces whose union is convex
and of one height takes the split items at 18 and 24 items/m from 2.0-2.1 % to 1.3 % (x1) and
from 2.6-3.4 % to 1.6-2.5 % (x1.5), nothing merged more. Cuts allowed twice as long when the
two sides differ in height by 10-20 mm traded merges for splits one for one and split 1.5-2.5 %
of the sparse belt's items: not taken."""


@dataclass(frozen=True, eq=False)
class ReportedItem:
    """An item the camera perception reported, with what its class was decided from.

    Attributes:
        detection: What the tracker got.
        features: Its feature vector (`perception.items.features`).
        hmm_probs: (3,) the stripe HMMs' posterior over (paper, plastic, aluminium): their
            filtered and smoothed class of the cells the item covers (the thesis's path).
        hmm_prior: (3,) the stripe HMMs' prediction of the item's class from the codes of its
            stripe before it (`CameraPerception._hmm_prior`), the prior the fusion uses.
        classifier_probs: (3,) the item classifier's, None in `hmm` mode.
    """

    detection: Detection
    features: np.ndarray
    hmm_probs: np.ndarray
    hmm_prior: np.ndarray
    classifier_probs: np.ndarray | None


def hmm_cache_path(
    catalogue=None,
    mix: dict | None = None,
    coupled: bool = False,
    belt_width_m: float = BELT_WIDTH_M,
) -> Path:
    """Cache file of the trained stripe HMMs, named after what the training depends on (the
    catalogue's content, the flow's class mix, the flow generator, the recordings and the
    training code, the stripes' coupling, the belt's width), so a change to any of them trains
    afresh instead of reusing stale models. The default catalogue and mix, uncoupled, on the
    0.8 m belt, keep the name they always had. The file is in the user's cache folder
    (`sim.user_cache.cache_dir`, created if need be)."""
    digest = hashlib.sha1()
    for rel in _HMM_INPUTS:
        digest.update((REPO_ROOT / rel).read_bytes())
    if catalogue is not None and not (catalogue.materials.is_thesis and _is_default(catalogue)):
        digest.update(catalogue.digest.encode())
    if mix:
        digest.update(repr(sorted(mix.items())).encode())
    if coupled:
        digest.update(b"coupled")
    if belt_width_m != BELT_WIDTH_M:
        digest.update(f"belt width {float(belt_width_m)!r} m".encode())
    return cache_dir() / f"stripe_hmms-{digest.hexdigest()[:12]}.npz"


def _is_default(catalogue) -> bool:
    from sim.flow.catalogue import load_catalogue

    return catalogue.digest == load_catalogue().digest


def stripe_models(
    catalogue, mix: dict | None = None, coupled: bool = False, belt_width_m: float = BELT_WIDTH_M
):
    """(stripe HMMs, cells per item): trained once per catalogue, class mix, coupling (the
    config's `[hmm] coupled`: each stripe's transitions per neighbour class at t-1) and belt
    width (flows on a belt of that width: its stripes' share of it), cached in the user's cache
    folder (`hmm_cache_path`; written atomically)."""
    from perception.hmm.storage import save_models
    from perception.hmm.training import TrainConfig
    from sim.sensing.stripe_hmms import trained_models

    path = hmm_cache_path(catalogue, mix, coupled, belt_width_m)
    train = TrainConfig(coupled=bool(coupled))
    if path.exists():
        return trained_models(catalogue, train, cache=path)
    other_belt = belt_width_m != BELT_WIDTH_M
    if not (catalogue.materials.is_thesis and _is_default(catalogue)) or mix or other_belt:
        log.info("training the stripe HMMs for this catalogue, class mix and belt (once; cached)")
    flows = {**(mix or {}), "belt_width_m": float(belt_width_m)} if other_belt else mix
    models, sizes = trained_models(catalogue, train, cache=None, mix=flows)
    save_models(path, models, sizes)  # through a temporary renamed over it
    return models, sizes


class CameraPerception:
    """Rendered frames -> codes -> online stripe HMMs -> items (see the module docstring)."""

    name = "camera"

    def __init__(
        self,
        model,
        data,
        catalogue,
        belt_speed: float,
        period_s: float,
        camera=None,
        classifier: str = "fused",
        depth_noise: StereoDepthNoise | None = ZED_CLASS,
        seed: int = 0,
        mix: dict | None = None,
        size: tuple[int, int] = CAMERA_SIZE,
        prefix: str = "",
        coupled: bool = False,
        encoder: BeltEncoder | None = None,
    ):
        from sim.cell.camera import (
            PERCEPTION_SAMPLES,
            BeltCamera,
            belt_grid,
            camera_line,
            camera_name,
            camera_pipeline,
            marker_names,
        )

        if classifier not in CLASSIFIER_MODES:
            raise InvalidInput("classifier", " | ".join(CLASSIFIER_MODES), classifier)
        self.data, self.speed, self.period = data, float(belt_speed), float(period_s)
        # The belt's encoder (`belt_speed` its set speed): the rows' belt coordinates.
        self.encoder = BeltEncoder(belt_speed) if encoder is None else encoder
        self.mode = classifier
        self.item_classifier = (
            None if classifier == "hmm" else trained_item_classifier(catalogue, mix)
        )
        self.depth_noise = depth_noise
        # The camera's own random stream (depth noise), apart from the flow's and the planner's.
        self.rng = np.random.default_rng([int(seed), 0x5E4])
        self.reported: list[ReportedItem] = []
        # The camera of the robot of name prefix `prefix` (a line's camera per robot); "" the
        # scene's, on the flow's camera line.
        name = camera_name(prefix)
        self.x_line = X_CAMERA if prefix == "" else camera_line(model, name)
        grid = belt_grid(model, self.x_line, period_s)  # the stripes share the model's belt
        size = (int(size[0]), int(size[1]))
        if camera is not None and tuple(camera.size) != size:
            raise InvalidInput("camera", f"a camera of {size[0]} x {size[1]} px", camera.size)
        if camera is not None and getattr(camera, "name", name) != name:
            raise InvalidInput("camera", f"the renderer of camera {name!r}", camera.name)
        self.pipeline = camera_pipeline(model, data, size, grid, markers=marker_names(prefix))
        self._own_camera = camera is None
        if camera is None:
            camera = BeltCamera(model, *size, name=name, samples=PERCEPTION_SAMPLES)
        self.camera = camera
        # `coupled` (the config's `[hmm] coupled`): the online filter mixes each stripe's
        # transitions by its neighbours' posteriors at t-1 (`perception.hmm.stripes`).
        width = grid.y_max - grid.y_min
        models, self.cells_per_item = stripe_models(catalogue, mix, coupled, width)
        self.hmm = OnlineStripeHmms(models)
        stripes, n_states = models.pi.shape
        self.classes = np.full((WINDOW_ROWS, stripes), VOID, dtype=np.int64)
        self.posteriors = np.zeros((WINDOW_ROWS, stripes, n_states))
        self.predicted = np.zeros((WINDOW_ROWS, stripes, n_states))
        self.pixels = [[np.zeros(0)] * stripes for _ in range(WINDOW_ROWS)]
        self.pixel_y = [[np.zeros(0)] * stripes for _ in range(WINDOW_ROWS)]
        self.pixel_height = [[np.zeros(0)] * stripes for _ in range(WINDOW_ROWS)]
        self.pixel_rgb = [[np.zeros((0, 3), np.uint8)] * stripes for _ in range(WINDOW_ROWS)]
        # Per pixel of the window: already reported (a piece of a region still growing).
        self.pixel_done = [[np.zeros(0, bool)] * stripes for _ in range(WINDOW_ROWS)]
        self.rows = self.unobserved = 0
        self.render_s = self.pipeline_s = self.hmm_s = 0.0

    def observe(self, t: float, blind: frozenset[int] = frozenset()) -> list[Detection]:
        """Take the frame of time `t` [s] (the belt one row on since the last); return the
        items whose last row was the previous. With the camera (0) in `blind` (an outage)
        there is no frame: its row reads empty."""
        t0 = time.perf_counter()
        stripes = self.classes.shape[1]
        travel = self.encoder.travel(t)
        try:
            if 0 in blind:
                raise PerceptionError("no frame: the camera is out")
            crop, depth = self._window_frame()
            if self.depth_noise is not None:
                depth = self.depth_noise.apply(depth, self.rng)
            t1 = time.perf_counter()
            row = self.pipeline.observe_window(crop, depth, self.speed, self.encoder.clock(t))
            codes = row.codes
            pixels = [np.asarray(c.pixels, dtype=float).reshape(-1, 2) for c in row.cells]
            heights = [np.asarray(c.heights, dtype=float) for c in row.cells]
            rgb = [np.asarray(c.rgb, dtype=np.uint8).reshape(-1, 3) for c in row.cells]
        except PerceptionError as exc:
            t1 = time.perf_counter()
            self.unobserved += 1
            log.debug("t %.2f s: camera frame unusable, its row read as empty (%s)", t, exc)
            codes = np.full(stripes, EMPTY_CODE)
            pixels = [np.zeros((0, 2))] * stripes
            heights = [np.zeros(0)] * stripes
            rgb = [np.zeros((0, 3), np.uint8)] * stripes
        # Belt coordinate b of each item pixel: the belt travel until it crosses the camera line.
        self.pixels = self.pixels[1:] + [[travel + self.x_line - p[:, 0] for p in pixels]]
        self.pixel_y = self.pixel_y[1:] + [[p[:, 1] for p in pixels]]
        self.pixel_height = self.pixel_height[1:] + [heights]
        self.pixel_rgb = self.pixel_rgb[1:] + [rgb]
        self.pixel_done = self.pixel_done[1:] + [[np.zeros(len(p), bool) for p in pixels]]
        t2 = time.perf_counter()
        est = self.hmm.step(codes)
        self.classes = np.roll(self.classes, -1, axis=0)
        self.posteriors = np.roll(self.posteriors, -1, axis=0)
        self.predicted = np.roll(self.predicted, -1, axis=0)
        self.classes[-1], self.posteriors[-1] = est.classes, est.filtered
        self.predicted[-1] = est.predicted
        self.rows += 1
        out = self._completed_items(t, travel)
        self.render_s += t1 - t0
        self.pipeline_s += t2 - t1
        self.hmm_s += time.perf_counter() - t2
        return out

    def _window_frame(self) -> tuple[np.ndarray, np.ndarray]:
        """The window of the frame that the footprints of the row's band use
        (`FootprintMapper.roi` of `CameraPipeline.band_mapper`) and of its exact depth map:
        read out alone (`sim.cell.camera.CameraWindow`) but every `WHOLE_FRAME_EVERY`-th
        frame, which is rendered whole to locate the belt (the first) and to check the markers
        are where they were (`CameraPipeline.check`).

        Raises:
            PerceptionError: A whole frame's markers are not seen where they were.
        """
        pipeline = self.pipeline
        if pipeline.view is None or self.rows % WHOLE_FRAME_EVERY == 0:
            frame, depth = self.camera.render_rgbd(self.data)
            pipeline.check(frame)
            roi = pipeline.band_mapper(self.speed).roi
            return frame[roi], depth[roi]
        return self.camera.window(*pipeline.band_mapper(self.speed).roi).render_rgbd(self.data)

    def _completed_items(self, t: float, travel: float) -> list[Detection]:
        """The items complete at time `t` [s], the belt's travel then `travel` [m]."""
        out: list[Detection] = []
        # Regions that still touch the newest row are still growing; older ones were reported.
        blobs = item_blobs(
            self.pixels,
            self.pixel_y,
            self._smoothed_posteriors,
            pixel_height=self.pixel_height,
            split=ITEM_SPLIT,
            complete_row=COMPLETE_ROW,
            reported=self.pixel_done,
        )
        self.reported = []
        if not blobs:
            return out
        members = [blob.members for blob in blobs]
        hmm_probs = np.array([blob.probs[1:] for blob in blobs])
        b, y, height, rgb, row, stripe = self._window_pixels()
        features = np.array([item_features(b[m], y[m], height[m], rgb[m]) for m in members])
        priors = np.array([self._hmm_prior(row[m], stripe[m]) for m in members])
        clf = self.item_classifier
        clf_probs = None if clf is None else clf.probabilities(features)
        if self.mode == "hmm":
            probs = hmm_probs
        else:
            assert clf is not None  # every mode but "hmm" has a classifier
            probs = combine(self.mode, priors, clf_probs, clf.train_prior)
        for k, blob in enumerate(blobs):
            x = self.x_line + travel - blob.b
            det = Detection(t, x, blob.y, (0.0, *(float(p) for p in probs[k])))
            out.append(det)
            self.reported.append(
                ReportedItem(
                    det,
                    features[k],
                    hmm_probs[k],
                    priors[k],
                    None if clf_probs is None else clf_probs[k],
                )
            )
        return out

    def _smoothed_posteriors(self) -> np.ndarray:
        """(WINDOW_ROWS, stripes, N) the window's class posteriors, smoothed where the HMMs'
        window reaches: fixed-lag smoothing, an item is reported once all its rows are in, so
        the rows after it inform its class as well as those before (forward-backward over the
        HMM window). Asked for only when an item is found."""
        smoothed = self.hmm.smoothed_window(last=WINDOW_ROWS)
        posteriors = self.posteriors.copy()
        posteriors[WINDOW_ROWS - len(smoothed) :] = smoothed
        return posteriors

    def _window_pixels(self) -> tuple[np.ndarray, ...]:
        """The window's item pixels in `item_blobs`' order (row by row, stripe by stripe):
        belt coordinates, lateral positions, heights [m], colours, window rows and stripes."""
        cells = [(r, j) for r, row in enumerate(self.pixels) for j, b in enumerate(row) if len(b)]
        sizes = [len(self.pixels[r][j]) for r, j in cells]
        return (
            np.concatenate([self.pixels[r][j] for r, j in cells]),
            np.concatenate([self.pixel_y[r][j] for r, j in cells]),
            np.concatenate([self.pixel_height[r][j] for r, j in cells]),
            np.concatenate([self.pixel_rgb[r][j] for r, j in cells]),
            np.repeat([r for r, _ in cells], sizes),
            np.repeat([j for _, j in cells], sizes),
        )

    def _hmm_prior(self, rows: np.ndarray, stripes: np.ndarray) -> np.ndarray:
        """(3,) the stripe HMMs' prediction of an item's class before any of its own codes
        were seen: the predicted distribution of its first row, over the stripes its pixels
        there fall in (weighted by pixels), void left out."""
        first = rows == rows.min()
        weights = np.bincount(stripes[first], minlength=self.predicted.shape[1])
        prior = weights @ self.predicted[int(rows.min()), :, 1:]
        total = prior.sum()
        n = self.predicted.shape[2] - 1
        return prior / total if total > 0 else np.full(n, 1.0 / n)

    def close(self) -> None:
        """Free the camera's renderer (unless it was lent by the caller)."""
        if self._own_camera:
            self.camera.close()


class LineCameraPerception:
    """A line's camera per robot (`[camera] per_robot`): one `CameraPerception` per belt camera,
    upstream first, each with its own renderer, pipeline, stripe HMMs, item window and depth
    noise stream, all observed every period. Their detections go to the one tracker, each
    marked with its camera (`Detection.camera`), which fuses a downstream camera's detections
    with the tracks of the cameras upstream (`sim.sensing.tracking`).

    Args:
        cameras: The cameras' perceptions, upstream first (the first on the scene's camera).
    """

    name = "camera"

    def __init__(self, cameras: list[CameraPerception]):
        if not cameras:
            raise InvalidInput("cameras", "at least one camera's perception", cameras)
        self.cameras = tuple(cameras)

    def observe(self, t: float, blind: frozenset[int] = frozenset()) -> list[Detection]:
        """Every camera's frame of time `t` [s]; their detections, each marked with its camera.

        Args:
            t: Simulated time [s].
            blind: The cameras out (no frame: their rows read empty), 0 upstream.

        Returns:
            The detections of every camera, upstream camera first.
        """
        out = []
        for index, camera in enumerate(self.cameras):
            seen = camera.observe(t, frozenset({0}) if index in blind else frozenset())
            out += [replace(det, camera=index) for det in seen]
        return out

    @property
    def reported(self) -> list[ReportedItem]:
        """The items every camera reported at the last observation, upstream camera first."""
        return [item for camera in self.cameras for item in camera.reported]

    @property
    def rows(self) -> int:
        """Rows observed, summed over the cameras."""
        return sum(camera.rows for camera in self.cameras)

    @property
    def unobserved(self) -> int:
        """Rows read as empty (an unusable frame), summed over the cameras."""
        return sum(camera.unobserved for camera in self.cameras)

    @property
    def render_s(self) -> float:
        """Wall time spent rendering frames, summed over the cameras [s]."""
        return sum(camera.render_s for camera in self.cameras)

    @property
    def pipeline_s(self) -> float:
        """Wall time spent in the pipeline, summed over the cameras [s]."""
        return sum(camera.pipeline_s for camera in self.cameras)

    @property
    def hmm_s(self) -> float:
        """Wall time spent in the HMMs, blobs and classes, summed over the cameras [s]."""
        return sum(camera.hmm_s for camera in self.cameras)

    def close(self) -> None:
        """Free every camera's renderer that is its own (not lent by the cell)."""
        for camera in self.cameras:
            camera.close()


def line_camera_perception(
    model, data, catalogue, prefixes: tuple[str, ...], cameras: list, **options
) -> LineCameraPerception:
    """A camera perception per belt camera of a line (`LineCameraPerception`).

    Args:
        model: The compiled line, with a camera per robot (`sim.model.line_model`).
        data: Its data.
        catalogue: The item catalogue.
        prefixes: Each camera's robot's name prefix, upstream first ("" for the scene's camera,
            the first robot's).
        cameras: Each camera's renderer (`Cell.belt_camera`), in the same order; None entries
            make their own.
        **options: `CameraPerception`'s other arguments (belt_speed, period_s, classifier,
            depth_noise, seed, mix, size, coupled, encoder), the same for every camera.

    Returns:
        The composite perception. The first camera's depth noise is drawn from the stream a
        single camera's would be; camera k's from its own (the episode's seed and k).
    """
    out = []
    for index, (prefix, camera) in enumerate(zip(prefixes, cameras, strict=True)):
        perception = CameraPerception(
            model, data, catalogue, camera=camera, prefix=prefix, **options
        )
        if index:
            perception.rng = np.random.default_rng([int(options.get("seed", 0)), 0x5E4, index])
        out.append(perception)
    return LineCameraPerception(out)
