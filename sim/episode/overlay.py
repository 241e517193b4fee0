"""The video's annotations of an episode's frame, read from the episode's parts.

`overlay_of` is what the loop hands a frame sink (`sim.render.sink.FrameSink`) with each frame:
the tracked items with their predicted classes, the picks under way, every bin with its
material and the items that landed in it (those of another material counted apart), and the
counters (time, entered, picked, missed, wrong bins, profit, each bin's purity so far) and,
while any is active, the faults.
"""

from __future__ import annotations

import re

import mujoco
import numpy as np

from sim.render.labels import BinLabel, Overlay, class_labels, purity_text

_RIMS: dict[tuple[int, tuple[str, ...]], list[tuple[str, int, tuple[float, float, float]]]] = {}
"""Per (model, materials): each bin's (material, class id, rim centre [m]); bins are static."""


def bin_rims(
    model: mujoco.MjModel, data: mujoco.MjData, materials
) -> list[tuple[str, int, tuple[float, float, float]]]:
    """Each bin of the cell or line and the centre of its rim.

    Args:
        model: The compiled cell (bins `bin_<material>`, a line's robots' `<prefix>bin_<...>`:
            `sim.model.bin_layout`).
        data: Its data (static bodies' poses are read).
        materials: The catalogue's materials (`names`, `ids`).

    Returns:
        [(material name, class id, (x, y, z) of the rim's centre [m])], bodies in model order.
    """
    key = (id(model), tuple(materials.names))
    if key in _RIMS:
        return _RIMS[key]
    ids = dict(zip(materials.names, materials.ids, strict=True))
    pattern = re.compile(r"^(?:.*_)?bin_(" + "|".join(map(re.escape, ids)) + r")$")
    out = []
    for b in range(model.nbody):
        match = pattern.match(model.body(b).name or "")
        if match is None:
            continue
        walls = [g for g in range(model.ngeom) if model.geom_bodyid[g] == b]
        top = max(
            (data.geom_xpos[g][2] + abs(data.geom_xmat[g].reshape(3, 3)) @ model.geom_size[g])[2]
            for g in walls
        )
        x, y, _ = data.xpos[b]
        out.append((match.group(1), ids[match.group(1)], (float(x), float(y), float(top))))
    if len(_RIMS) > 8:
        _RIMS.clear()
    _RIMS[key] = out
    return out


def bin_labels(parts) -> list[BinLabel]:
    """Each bin's label: its material, the items that landed in it, those of another material.

    A landing (`sim.monitors.bins.Landing`) counts in the nearest bin of its material (a
    line's robots each have one per material).
    """
    rims = bin_rims(parts.model, parts.data, parts.metrics.materials)
    counts = np.zeros(len(rims), dtype=int)
    wrong = np.zeros(len(rims), dtype=int)
    for landing in parts.bins.landed:
        near = [
            (np.hypot(r[2][0] - landing.position[0], r[2][1] - landing.position[1]), k)
            for k, r in enumerate(rims)
            if r[0] == landing.bin
        ]
        if near:
            k = min(near)[1]
            counts[k] += 1
            wrong[k] += not landing.correct
    return [
        BinLabel(cls, *rim, int(counts[k]), int(wrong[k])) for k, (_, cls, rim) in enumerate(rims)
    ]


def fault_lines(parts, t: float) -> list[str]:
    """The counters' line of the faults active at `t` [s] (`sim.config.faults.Fault.label`),
    none while nothing has failed (`parts.faults`)."""
    active = parts.faults.active(t)
    return ["fault: " + "; ".join(f.label() for f in active)] if active else []


def overlay_of(parts, t: float, planner: str | None = None) -> Overlay:
    """The annotations of an episode's frame.

    Args:
        parts: The running episode's parts (`sim.episode.parts.EpisodeParts`).
        t: Its sim time [s].
        planner: The name the counters give the decision maker (None: the config's planner;
            an environment's agent says "agent").

    Returns:
        The overlay.
    """
    items = []
    tracks = parts.tracker.tracks()
    under_way = [s.current_pick for s in parts.stations if s.current_pick is not None]
    tracks.extend(under_way)
    for tr in tracks:
        cls = tr.predicted_class
        items.append((tr.track_id, tr.x_at(t, parts.speed), tr.y, 0.03, cls, tr.probs[cls - 1]))
    m = parts.metrics
    short, colours = class_labels(m.materials)
    wrong = sum(true != bin_ for true, bin_ in m.binned.values())
    counters = [
        f"t {t:5.1f} s  x{parts.config.speed_factor:g}  {planner or parts.config.planner}  "
        f"{parts.config.perception}",
        f"entered {m.n_entered}  picked {m.n_picked}  missed {len(m.missed)}",
        f"wrong bin {wrong}  profit {m.profit:.2f} EUR",
        "purity " + purity_text(m.binned, short),
        *fault_lines(parts, t),
    ]
    pick = None if parts.current_pick is None else parts.current_pick.track_id
    picks = tuple(track.track_id for track in under_way)
    return Overlay(
        items=items,
        next_pick=pick,
        counters=counters,
        short=short,
        colours=colours,
        next_picks=picks,
        bins=bin_labels(parts),
        wrong_line=2 if wrong else None,
    )
