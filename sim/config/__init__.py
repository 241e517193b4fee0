"""Configuration of one episode: a frozen, eagerly validated dataclass read from TOML; the
one schema of every key (`sim.config.fields`: each key's range, choices, help and option
declared once on its field), from which the command line's options (`sim.config.options`), a
sweep's grid checks and docs/settings.md are made. Nothing here imports OpenCV or MuJoCo.

Every key a TOML file may hold is a field below; unknown keys, wrong types, values out of
range and malformed TOML are refused with one line naming the key and the file
(`InvalidInput`, exit code 2) before anything runs. Command-line options override the file.

Files are read at the edge, never in the dataclass's validation (`sim.config.loading`): `load`,
`from_dict` (and `read_config_file`, `EpisodeConfig.build`, `EpisodeConfig.replace` with a new
`catalogue`)
read the item catalogue the `catalogue` key names and hand it to the config as a
`CatalogueFile` (`catalogue_file`: the key it was read for, its content digest, the
`Catalogue`). The config keeps the key (`catalogue`, what a manifest records) and the
catalogue it was validated against, so `EpisodeConfig()` (the built-in catalogue, read once
per process) and `config.replace(...)` need no file, a config pickles whole to a sweep's worker
process (which then reads no file either) and two configs compare equal by what they run with
(every other setting, the catalogue's key and its content digest; the `Catalogue` object and
`where` are left out). A `catalogue_file` that was not read for the `catalogue` key (say
`dataclasses.replace(config, catalogue=...)`, which reads nothing) is refused in one line
naming `catalogue`. Frozen dataclasses and no validation library: the checks are a few lines
each (`sim.config.fields.validate`), and the refusals keep the project's one-line form.

TOML layout (every key optional; defaults are the headline episode)::

    seed = 0
    items = 100
    speed_factor = 1.0          # belt speed = 0.185 m/s x factor, inside 0.135..0.277 m/s;
                                # or [belt] speed_mps (below), not both
    planner = "qlearning"       # qlearning | rollout | lookahead | proximity | fifo | greedy
                                # | random | seen_best | module:Class
    perception = "camera"       # camera | truth
    duration_s = 90.0           # items arrive over this time [s]
    horizon_s = 90.0            # the run ends at this time [s], the items still on the belt
                                # and those not yet arrived counted (left_on_belt,
                                # not_arrived); unset: once every item has arrived and left
                                # the belt
    observation_period_s = 0.5  # one grid row per period [s]
    item_riding = "path"        # path | settled | contact (see sim/cell/riding.py)
    energy_price_eur_per_kwh = 0.0  # > 0: every planner nets each pick's motor energy cost
    min_class_confidence = 0.9  # 0..1: an item whose most probable class is less probable is
                                # left on the belt (sim/sensing/confidence.py); 0: none is;
                                # unset: the classifier's own (0.9 fused and features, 0 hmm
                                # and truth)
    classifier = "fused"        # camera items' class: fused | features | hmm (the thesis's)
    depth_noise = true          # the stereo camera's depth error (sim/cell/depth_noise.py)
    world = "varied"            # varied | uniform: how items vary (sim/flow/world.py,
                                # docs/world.md); the numbers below override the preset's
    size_jitter = 0.15          # size factors in [1 - j, 1 + j] per dimension
    crushed_share = 0.25        # cans and bottles crushed
    crumpled_share = 0.2        # paper sheets crumpled
    folded_share = 0.15         # A4 sheets folded
    hue_jitter_deg = 8.0        # colour: hue +- [deg]
    colour_jitter = 0.12        # colour: saturation and value +- (relative)
    label_share = 0.6           # round containers with a printed label in a second colour
    min_gap_m = 0.0             # least gap between items [m] (uniform: 0.005)
    overlap_share = 0.1         # flat-sided items allowed to lie partly over a flat neighbour
    overlap_depth_m = 0.02      # how far over it [m]
    robots = 1                  # IRB 360s in series over the belt, 1..4 (a sorting line) at
                                # the default spacing, or a [[robots]] table per robot (below,
                                # after the tables)
    coordination = "coordinated"  # a line's: independent | coordinated
                                # (planner/decision/line_coordination.py)
    catalogue = ""              # item catalogue TOML (its [[material]] entries name the
                                # materials, one bin each); "": sim/data/items.toml (the
                                # thesis's paper, plastic, aluminium). Relative paths are
                                # taken from the directory the command runs in.
    [values]                    # EUR per item of a material, or of one item type (which then
    paper = 0.22                # overrides its material's in the profit); unset: the
    plastic = 0.25              # catalogue's value_eur (thesis table 3.3 by default)
    aluminium = 0.27
    per_kg = { aluminium = 1.2 }   # EUR/kg instead (a name has one or the other): an item
                                # is worth its own mass x the price
    [flow]                      # the class mix of the flow (default: the thesis's for its
    class_priors = [0.29, 0.36, 0.35]   # three materials, equal shares otherwise); one entry
    transitions = [[0.46, 0.30, 0.24],  # per material in the catalogue's order
                   [0.22, 0.50, 0.28],
                   [0.20, 0.28, 0.52]]
    stripe_priors = [0.16, 0.22, 0.24, 0.22, 0.16]
    mix = { paper = 0.40, plastic = 0.35, aluminium = 0.25 }  # or the mix as shares: by
                                # material (every one named), or by base item type of the
                                # catalogue (mix_types = { paper_sheet_a4 = 0.1, ... }, types
                                # not named not drawn), not both, nor with class_priors: the
                                # transitions are matched to the shares (sim/flow/mix.py)
    [qlearning]                 # the thesis's Q-learning (also read by rollout); seeded by seed
    gamma = 0.9
    iterations = 50
    batch_rows = 20
    objective = "value_over_distance"   # | value_only (d = 1) | distance_only (v = 1)
    [video]
    fps = 10.0                  # frames per simulated second
    width = 640
    height = 360
    [camera]                    # the belt camera's frames [px], 16:9 like its calibration
    width = 640                 # 384..1920, a multiple of 16 (the calibration is scaled to it)
    height = 360                # width x 9/16
    per_robot = false           # a line: each robot its own belt camera upstream of its reach,
                                # their tracks fused (docs/line.md); false: the one camera
    [cup]                       # the vacuum cup
    diameter_m = 0.06           # lip diameter 0.02..0.12 m (recompiles the cell's model);
                                # unset: 0.06 for one robot, 0.05 for a line (docs/line.md)
    vacuum_pa = 80000.0         # vacuum below atmosphere, 1000..101325 Pa; holds area x vacuum
    [belt]
    speed_mps = 0.2             # belt speed [m/s], 0.135..0.277, instead of speed_factor
    length_m = 4.5              # 4..20 m from the infeed; the discharge end moves (recompiles)
    width_m = 0.8               # 0.4..1.2 m; the stripes, bins, camera rig follow (recompiles)
    infeed_hold = true          # an item that would drop into one already on the belt is held
                                # back (sim/episode/infeed.py); false: every result to the bit
                                # as before it
    [hmm]                       # camera perception's stripe HMMs
    coupled = false             # true: each stripe's transitions use its neighbour stripes'
                                # states at t-1 (thesis 1.3); false: five independent HMMs
    [economics]                 # what a robot costs: the money columns only (an assumption
    robot_capital_eur = 75000.0  # for one delta robot cell; set the plant's own figures)
    robot_life_years = 10.0
    hours_per_year = 4000.0
    robot_maintenance_eur_per_year = 3000.0
    energy_price_eur_per_kwh = 0.2   # the top-level key, given here instead (either place)
    [infeed]                    # the feed in plant units instead of items (one key of three;
    items_per_m = 18.0          # sim/flow/feed_rate.py): items per metre of belt, or
    # items_per_s = 3.6         # items per second, or kilograms per hour at the catalogue's
    # kg_per_h = 250.0          # mean item mass under the mix; items = the rate over
                                # duration_s (18 x belt speed x duration_s), rounded
    profile = [[600, 1.5], [900, 0.0]]  # the rate x factor from each start [s] on (1
                                # before the first): a surge from 600 s, a gap from 900 s
    surges = { mean_gap_s = 900, mean_length_s = 60, factor = 2.0 }  # drawn by seed
    [timeline]                  # timeline.csv beside episodes.csv
    period_s = 10.0             # a row every period [s], 0.5..3600
    [[faults]]                  # a fault each (sim/config/faults.py): kind, start_s,
    kind = "robot_stop"         # duration_s and the kind's key (robot, camera, vacuum_pa,
    robot = 1                   # speed_factor); no overlap on one part, no robot or camera
    start_s = 120.0             # the cell lacks, no start at or after the episode's end
    duration_s = 30.0           # (horizon_s, else duration_s): refused at load
    [faults_random.belt_stop]   # faults drawn by seed, per kind: mean time between faults
    mtbf_s = 1800.0             # and mean time to repair [s] (and vacuum_pa, speed_factor
    mttr_s = 120.0              # for those kinds)

The robots one by one, instead of `robots = N` (sim/config/robots.py, docs/line.md;
`--robots N` and a sweep's `robots = N` give N robots at the default spacing, robot k keeping
robot k's pauses)::

    [[robots]]                  # the first robot, upstream
    x_m = 0.0                   # its base along the belt [m]; for every robot or none (then
                                # 0, 1.8, 3.6, ...): first >= 0, >= 1.8 m apart, last <= 15.5
    materials = ["aluminium"]   # what it picks (items by their most probable material);
                                # omitted: every material. Each material by some robot
    pick_pause_s = 0.5          # extra dwell after each pick / place, 0..2 s (thesis: ~0.5 s
    place_pause_s = 0.0         # each)
    idle_sleep = true           # an idle robot sleeps in MuJoCo until its next pick
                                # (sim/cell/idle_sleep.py); false: the physics to the bit
                                # as before it
    [[robots]]
    x_m = 2.2

Whatever the form, the config holds one tuple of robots (`EpisodeConfig.robots`, one
`RobotSpec` each) and writes one array of tables (`to_dict`, a run's manifest.json); an old
file's `[robot]` section of every robot's pauses is read by `sim.config.migration`::

    robots = [{x_m = 0.0, materials = ["aluminium"], pick_pause_s = 0.5, place_pause_s = 0.0,
               idle_sleep = true}, {x_m = 2.2, pick_pause_s = 0.0, ...}]
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "sim.config.episode": ("EpisodeConfig", "SCALARS", "SECTIONS"),
    "sim.config.loading": ("KEYS", "from_dict", "load", "read_config_file", "read_toml"),
    "sim.config.catalogue_file": ("CatalogueFile", "builtin_catalogue", "episode_catalogue"),
    "sim.config.fields": ("Range", "Setting", "settings_of", "validate"),
    "sim.config.flow_table": ("MIX_KEYS", "FlowMix"),
    "sim.config.plant": ("MAX_ROBOTS",),
    "sim.config.ranges": ("RANGES",),
    "sim.config.robots": ("RobotSpec",),
    "sim.config.sections": (
        "OBJECTIVES",
        "Belt",
        "Camera",
        "Cup",
        "Economics",
        "Hmm",
        "InfeedRate",
        "QLearning",
        "Video",
    ),
    "sim.config.settings": (
        "CLASSIFIERS",
        "ITEM_RIDINGS",
        "PERCEPTIONS",
        "WORLD_NUMBERS",
        "WORLDS",
        "EpisodeSettings",
        "belt_speed_mps",
    ),
    "sim.config.values": ("Values", "mean_masses"),
}
"""Where each public name lives; imported when first asked for (PEP 562), so importing one
light module of the package (the command line's `sim.config.options`) reads no catalogue and
imports no numerics."""
_HOME = {name: module for module, names in _EXPORTS.items() for name in names}
__all__ = sorted(_HOME)


def __getattr__(name: str) -> Any:
    module = _HOME.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(module), name)
