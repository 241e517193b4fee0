"""The one registry of decision managers: built-in names, and a user's own class.

`make_planner('qlearning', gamma=0.9)` builds a built-in manager (qlearning: the thesis's algorithm;
rollout: our timed rollout over its reward; lookahead: our budgeted branch and bound; proximity,
fifo, greedy; random: a uniform draw among the items the cup can meet, the thesis's "random picker";
seen_best: the best order over the items in view, replanned at each decision: no bound;
best_order: the order a search finds with the episode's whole flow known, followed: no bound).
`make_planner('mymod:MyPlanner')` (or `path/to/file.py:MyPlanner`) imports the user's class and
builds it with no arguments. A user's class implements
`planner.decision.interface.DecisionManager`: a `choose(items, robot, context)` returning a
`Choice` or None, and a `reset()` called at the start of every episode; its `name` attribute,
if any, is what episodes.csv records (else the spec). Unknown names, specs that do not import and
options a manager does not take are refused with one line.

An episode asks its manager through `ask_manager`: a `choose()` that returns
anything but a `Choice` or None (the item itself, say) ends the episode with one line naming the
manager's class, `choose()`, what it returned and what is expected (`ChoiceTypeError`, exit code
1), not an AttributeError deep in the pick.
"""

from __future__ import annotations

import dataclasses
import importlib
import importlib.util
import os
import sys
from pathlib import Path

from planner.errors import PlannerError, PlannerInputError

COORDINATIONS = ("independent", "coordinated")
"""How a line's robots share the belt (`planner.decision.line_coordination`); here, where no
numerics are imported, so a config's schema and the command line read them."""

# Imported only when built, so that the command line's --help stays light.
_BUILT_IN = {
    "qlearning": "planner.decision.managers.qlearning:QLearningPlanner",
    "rollout": "planner.decision.managers.rollout:RolloutPlanner",
    "lookahead": "planner.decision.managers.lookahead:LookaheadPlanner",
    "learned": "planner.decision.managers.learned:LearnedPlanner",
    "proximity": "planner.decision.managers.proximity:ProximityPlanner",
    "fifo": "planner.decision.managers.fifo:FifoPlanner",
    "greedy": "planner.decision.managers.greedy:GreedyPlanner",
    "random": "planner.decision.managers.random_pick:RandomPlanner",
    "seen_best": "planner.decision.managers.seen_best:SeenBestPlanner",
    "best_order": "planner.decision.managers.best_order:BestOrderPlanner",
}
FLOW_PLANNERS = ("best_order",)
"""The built-in decision managers given the episode's whole flow by the episode runner
(`sim.episode.builder.known_flow`): they cannot be built without it."""
PLANNERS = tuple(name for name in _BUILT_IN if name not in FLOW_PLANNERS)
"""The built-in decision managers built from their options alone (on any belt)."""
ALLOWED = (
    " | ".join((*PLANNERS, *FLOW_PLANNERS)) + " | module:Class (a class with choose() and reset())"
)
"""What a planner spec may be, in words (for refusals and --help)."""


def is_user_spec(spec: str) -> bool:
    """True for `module:Class` / `file.py:Class`, a user's own decision manager."""
    return isinstance(spec, str) and ":" in spec


def user_class(spec: str) -> type:
    """The class a `module:Class` or `path/file.py:Class` spec names, imported.

    A dotted module is imported as usual, with the working directory searched last; a path
    ending in `.py` is loaded from that file.

    Raises:
        PlannerInputError: The module or class cannot be found or imported, or the class has no
            `choose` and `reset`.
    """
    module_name, _, class_name = spec.rpartition(":")
    if not module_name or not class_name.isidentifier():
        raise PlannerInputError("planner", ALLOWED, spec)
    try:
        if module_name.endswith(".py"):
            path = Path(module_name)
            if not path.is_file():
                raise PlannerInputError("planner", f"{ALLOWED}; no file {path}", spec)
            unique = f"_sortsim_user_{path.stem}_{abs(hash(str(path.resolve())))}"
            module = sys.modules.get(unique)
            if module is None:
                loader_spec = importlib.util.spec_from_file_location(unique, path)
                assert loader_spec is not None and loader_spec.loader is not None  # a .py file
                module = importlib.util.module_from_spec(loader_spec)
                sys.modules[unique] = module
                loader_spec.loader.exec_module(module)
        else:
            if os.getcwd() not in sys.path:
                sys.path.append(os.getcwd())
            module = importlib.import_module(module_name)
    except PlannerInputError:
        raise
    except Exception as exc:  # the user's module failed to import: say why in one line
        reason = f"{type(exc).__name__}: {exc}".splitlines()[0]
        raise PlannerInputError(
            "planner", f"{ALLOWED}; importing it failed: {reason}", spec
        ) from None
    cls = getattr(module, class_name, None)
    if not isinstance(cls, type):
        raise PlannerInputError(
            "planner", f"{ALLOWED}; {module_name} has no class {class_name}", spec
        )
    if not (callable(getattr(cls, "choose", None)) and callable(getattr(cls, "reset", None))):
        raise PlannerInputError(
            "planner", f"{ALLOWED}; {class_name} lacks choose() or reset()", spec
        )
    return cls


def check_planner(spec: str) -> None:
    """Refuse a spec that names no built-in manager and no importable user class."""
    if is_user_spec(spec):
        user_class(spec)
    elif spec not in _BUILT_IN:
        raise PlannerInputError("planner", ALLOWED, spec)


# The managers built from a config dataclass: name -> "module:ConfigClass".
_CONFIGS = {
    "qlearning": "planner.decision.managers.qlearning:QLearningConfig",
    "rollout": "planner.decision.managers.rollout:RolloutConfig",
    "lookahead": "planner.decision.managers.lookahead:LookaheadConfig",
}


def _load(spec: str):
    module_name, _, attr = spec.partition(":")
    return getattr(importlib.import_module(module_name), attr)


def _built_in(name: str) -> tuple[type, tuple[str, ...]]:
    """A built-in manager's class and the options it takes."""
    cls = _load(_BUILT_IN[name])
    if name in _CONFIGS:
        return cls, tuple(f.name for f in dataclasses.fields(_load(_CONFIGS[name])))
    extra = {
        "seen_best": ("max_items",),
        "learned": ("policy_file",),
        "random": ("seed", "stream"),
        "best_order": ("x0", "y", "classes"),
    }
    return cls, extra.get(name, ())


def make_planner(spec: str, **params):
    """A new decision manager.

    Args:
        spec: One of PLANNERS or FLOW_PLANNERS, or `module:Class` of the user's own class.
        **params: Options of that planner (qlearning, rollout, lookahead: the fields of
            QLearningConfig, RolloutConfig, LookaheadConfig; seen_best: max_items; learned:
            policy_file (a JSON written by `sortsim train`); random: seed and stream;
            best_order: the flow, x0, y and classes (required); the others, and users'
            classes, take none).

    Raises:
        PlannerInputError: Unknown name or option, or an option out of range.

    Returns:
        A `planner.decision.interface.DecisionManager`.
    """
    options: tuple[str, ...]
    if is_user_spec(spec):
        cls, options = user_class(spec), ()
    elif spec in _BUILT_IN:
        cls, options = _built_in(spec)
    else:
        raise PlannerInputError("planner", ALLOWED, spec)
    unknown = sorted(set(params) - set(options))
    if unknown:
        allowed = ", ".join(options) or "no options"
        raise PlannerInputError(f"{spec} option {unknown[0]}", allowed, params[unknown[0]])
    if spec in _CONFIGS:
        return cls(_load(_CONFIGS[spec])(**params))
    planner = cls(**params)
    if is_user_spec(spec) and not getattr(planner, "name", None):
        try:
            planner.name = spec
        except AttributeError:
            pass  # a read-only name property: the CSV falls back to the class name
    return planner


CHOICE_TYPE = "planner.decision.interface.Choice"
"""What `choose()` returns (or None), as the error names it."""


class ChoiceTypeError(PlannerError, TypeError):
    """A decision manager's `choose()` returned something else than a `Choice` or None.

    Args:
        manager: Its class name.
        got: The returned value's type, qualified by its module.
    """

    def __init__(self, manager: str, got: str):
        self.manager = manager
        self.got = got
        super().__init__(
            f"{manager}.choose() returned a {got}; it must return a {CHOICE_TYPE} or None"
        )

    def __reduce__(self):
        return (type(self), (self.manager, self.got))


def ask_manager(planner, items, robot, context):
    """`planner.choose(items, robot, context)`: its `Choice` or None, checked.

    Raises:
        ChoiceTypeError: It returned anything else (one line naming its class).
    """
    choice = planner.choose(items, robot, context)
    from planner.decision.interface import Choice  # numpy: not at the CLI's start-up

    if choice is None or isinstance(choice, Choice):
        return choice
    got = type(choice)
    module = "" if got.__module__ == "builtins" else f"{got.__module__}."
    raise ChoiceTypeError(type(planner).__name__, f"{module}{got.__qualname__}")
