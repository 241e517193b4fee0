"""The one interface the loop hands frames to: the MP4 recorder and the live viewer both take it."""

from __future__ import annotations

from sim.render.live_view import LiveView
from sim.render.sink import FrameSink
from sim.render.video import VideoRecorder
from tests.utils import scene_at_home


def test_the_video_recorder_is_a_frame_sink(tmp_path):
    model, _ = scene_at_home()
    recorder = VideoRecorder(model, tmp_path / "clip.mp4", 10.0, 320, 184)
    try:
        assert isinstance(recorder, FrameSink)
        assert recorder.next_frame_time == 0.0 and recorder.due(0.0)
    finally:
        recorder.abort()
    assert list(tmp_path.iterdir()) == []


def test_the_live_view_is_a_frame_sink():
    """Checked on an instance that opened no window (the viewer needs a display)."""
    view = LiveView.__new__(LiveView)
    view._next_t = 0.5
    assert isinstance(view, FrameSink)
    assert not view.due(0.4) and view.due(0.5)


def test_an_object_without_abort_is_not_a_frame_sink():
    class Partial:
        next_frame_time = 0.0

        def due(self, t):
            return True

        def capture(self, data, overlay):
            pass

        def close(self):
            pass

    assert not isinstance(Partial(), FrameSink)
