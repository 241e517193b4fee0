"""The camera perception reads out only its row's band: the same detections as whole frames."""

from __future__ import annotations

import numpy as np
import pytest

import sim.sensing.perception as perception_module
from perception.errors import PerceptionError
from sim import config
from sim.episode.loop import Episode

EPISODE = dict(items=12, duration_s=8.0, perception="camera", planner="qlearning", seed=11)


class _CountingCamera:
    """The episode's belt camera, counting its whole frames and its windows' frames."""

    def __init__(self, camera):
        self.camera, self.size, self.name = camera, camera.size, camera.name
        self.whole = self.windowed = 0

    def render_rgbd(self, data):
        self.whole += 1
        return self.camera.render_rgbd(data)

    def window(self, rows, cols):
        outer, window = self, self.camera.window(rows, cols)

        class _Counted:
            def render_rgbd(self, data):
                outer.windowed += 1
                return window.render_rgbd(data)

        return _Counted()


def _detections(cell, monkeypatch, whole_every: int):
    """Every detection of the episode and the camera's counts, a whole frame every
    `whole_every`-th period."""
    monkeypatch.setattr(perception_module, "WHOLE_FRAME_EVERY", whole_every)
    seen = []
    with Episode(config.load(None, **EPISODE), cell) as episode:
        episode.reset()
        camera = _CountingCamera(episode.perception.camera)
        episode.perception.camera = camera
        observe = episode.perception.observe

        def recorded(t):
            out = observe(t)
            seen.extend((d.t, d.x, d.y, *d.probs) for d in out)
            return out

        episode.perception.observe = recorded
        episode.run()
        rows = episode.perception.rows
    return np.array(seen), camera, rows


def test_the_band_window_reports_what_whole_frames_report(cell, monkeypatch):
    """Read out as its band's window, the camera renders a whole frame every
    `WHOLE_FRAME_EVERY`-th period (the first locates the belt) and windows between, and
    reports the same items at the same places with the same classes as from whole frames."""
    windowed, camera, rows = _detections(cell, monkeypatch, perception_module.WHOLE_FRAME_EVERY)
    every = perception_module.WHOLE_FRAME_EVERY
    assert camera.whole == -(-rows // every) and camera.whole + camera.windowed == rows
    assert camera.windowed > camera.whole
    whole, camera, _ = _detections(cell, monkeypatch, 1)
    assert camera.windowed == 0
    assert len(windowed) >= 8  # most of the 12 items reported
    assert windowed.shape == whole.shape
    np.testing.assert_allclose(windowed, whole, atol=1e-9)


def test_observing_before_the_belt_is_located_needs_a_whole_frame(cell):
    """The first observation always reads a whole frame: the band's window is only known once
    the belt is located from the markers."""
    with Episode(config.load(None, **EPISODE), cell) as episode:
        episode.reset()
        perception = episode.perception
        assert perception.pipeline.view is None
        with pytest.raises(PerceptionError, match="not located"):
            perception.pipeline.band_mapper(perception.speed)
        camera = _CountingCamera(perception.camera)
        perception.camera = camera
        perception.observe(float(episode.data.time))
        assert (camera.whole, camera.windowed) == (1, 0)
        assert perception.pipeline.view is not None
