"""The video's annotations of an episode's frame, read from the episode's own state.

`overlay_of` is what the loop hands a frame sink (`sim.render.sink.FrameSink`) with each frame:
the tracked items with their predicted classes, the picks under way, and the counters (time,
entered, picked, missed, profit, each bin's purity so far).
"""

from __future__ import annotations

from sim.render.labels import Overlay, class_labels, purity_text


def overlay_of(episode, t: float) -> Overlay:
    """The annotations of an episode's frame at sim time `t` [s]."""
    items = []
    tracks = episode.tracker.tracks()
    under_way = [s.current_pick for s in episode.stations if s.current_pick is not None]
    tracks.extend(under_way)
    for tr in tracks:
        cls = tr.predicted_class
        items.append((tr.track_id, tr.x_at(t, episode.speed), tr.y, 0.03, cls, tr.probs[cls - 1]))
    m = episode.metrics
    short, colours = class_labels(m.materials)
    counters = [
        f"t {t:5.1f} s  x{episode.config.speed_factor:g}  {episode.config.planner}  "
        f"{episode.config.perception}",
        f"entered {m.n_entered}  picked {m.n_picked}  missed {len(m.missed)}",
        f"profit {m.profit:.2f} EUR",
        "purity " + purity_text(m.binned, short),
    ]
    pick = None if episode.current_pick is None else episode.current_pick.track_id
    picks = tuple(track.track_id for track in under_way)
    return Overlay(
        items=items,
        next_pick=pick,
        counters=counters,
        short=short,
        colours=colours,
        next_picks=picks,
    )
