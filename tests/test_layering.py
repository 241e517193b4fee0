"""The dependency rule of docs/architecture.md, enforced on every import in the packages.

Every `import` and `from ... import` of `sim`, `planner` and `perception` is read with `ast`
(function-level imports included, since a lazy import is still a dependency), resolved to the
module it names, and checked against the layers below; the module graph must also be free of
import circles.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("perception", "planner", "sim")

# The shared base: modules every room may import, which import nothing of the project.
BASE = ("perception.project_errors",)
# Each room and the rooms it may import besides its own modules and the base.
ALLOWED = {
    "perception.errors": set(),
    "perception.codes": {"perception.errors"},
    "perception.camera": {"perception.errors", "perception.codes"},
    "perception.hmm": {"perception.errors", "perception.codes"},
    "perception.items": {"perception.errors", "perception.codes"},
    "planner.errors": set(),
    "planner.motion": {"planner.errors"},
    "planner.decision": {"planner.motion", "planner.errors", "perception.codes"},
    "sim.paths": set(),
    "sim.errors": set(),
    "sim.checks": {"sim.errors"},
    "sim.user_cache": {"sim.paths", "sim.errors"},
}
# sim's rooms, lowest first: each may import the ones below it and the pure packages whole.
SIM_ROOMS = (
    "sim.flow",
    "sim.config",
    "sim.model",
    "sim.cell",
    "sim.monitors",
    "sim.render",
    "sim.sensing",
    "sim.results",
    "sim.episode",
    "sim.envs",
    "sim.evaluation",
    "sim.experiments",
    "sim.cli",
)
PURE = ("perception", "planner")
for i, room in enumerate(SIM_ROOMS):
    ALLOWED[room] = {"sim.paths", "sim.errors", "sim.checks", "sim.user_cache"}
    ALLOWED[room] |= {*SIM_ROOMS[:i], *PURE}
for room in ALLOWED:
    ALLOWED[room] |= set(BASE)
for base in BASE:
    ALLOWED[base] = set()


def room_of(module: str) -> str | None:
    """The room a module belongs to (the longest ALLOWED key that prefixes it)."""
    best = None
    for room in ALLOWED:
        if (module == room or module.startswith(room + ".")) and (
            best is None or len(room) > len(best)
        ):
            best = room
    return best


def module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def project_modules() -> dict[str, Path]:
    """Every module of the three packages, by dotted name."""
    return {
        module_name(p): p
        for pkg in PACKAGES
        for p in sorted((ROOT / pkg).rglob("*.py"))
        if ".venv" not in p.parts
    }


def _type_only_imports(tree: ast.AST) -> set[int]:
    """ids of the import nodes inside `if TYPE_CHECKING:` blocks (never executed)."""
    found = set()
    for node in ast.walk(tree):
        test = getattr(node, "test", None)
        if isinstance(node, ast.If) and (
            (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING")
            or (isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")
        ):
            found |= {id(n) for b in node.body for n in ast.walk(b)}
    return found


def imports_of(path: Path, name: str, known: set[str], typing: bool = True) -> set[str]:
    """The project modules `path` imports (relative imports resolved); with `typing` False,
    not those imported for type checking only (they never run, so they close no circle)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: set[str] = set()
    skip = set() if typing else _type_only_imports(tree)
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join(anchor + ([base] if base else []))
            targets = [f"{base}.{a.name}" for a in node.names] + [base]
        else:
            continue
        for target in targets:
            # The deepest project module the name resolves to (`from a import b` may name the
            # module a.b or an attribute of a).
            while target and target not in known:
                target = target.rpartition(".")[0]
            if target and target.split(".")[0] in PACKAGES:
                found.add(target)
    found.discard(name)
    return found


def import_graph(typing: bool = True) -> dict[str, set[str]]:
    modules = project_modules()
    known = set(modules)
    return {name: imports_of(path, name, known, typing) for name, path in modules.items()}


def violations(graph: dict[str, set[str]]) -> list[str]:
    """Imports that break the rule: `importer -> imported (room -> room)`."""
    bad = []
    for importer, targets in sorted(graph.items()):
        src = room_of(importer)
        for target in sorted(targets):
            dst = room_of(target)
            if importer.count(".") == 0 or target.count(".") == 0:
                # A package's own __init__ (lazy re-exports) and bare package imports.
                if importer.split(".")[0] == target.split(".")[0]:
                    continue
            if src is None or dst is None:
                bad.append(f"{importer} -> {target} (no room)")
                continue
            if dst == src or any(dst == a or dst.startswith(a + ".") for a in ALLOWED[src]):
                continue
            if any(dst.startswith(p) for p in ALLOWED[src] if p in PURE):
                continue
            bad.append(f"{importer} -> {target} ({src} may not import {dst})")
    return bad


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    counter = [0]

    def visit(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_every_module_has_a_room():
    homeless = [m for m in project_modules() if "." in m and room_of(m) is None]
    assert homeless == []


def test_no_import_breaks_the_dependency_rule():
    assert violations(import_graph()) == []


def test_no_import_circles():
    assert cycles(import_graph(typing=False)) == []


def test_no_package_module_reads_the_tests_folder():
    offenders = [
        name
        for name, path in project_modules().items()
        if '"tests"' in path.read_text(encoding="utf-8")
    ]
    assert offenders == []


@pytest.mark.parametrize(
    "importer, target",
    [
        ("planner.motion.kinematics", "sim.cell.robot"),  # pure package imports the sim
        ("perception.hmm.model", "planner.motion.limits"),
        ("sim.monitors.bins", "sim.results.metrics"),  # a lower room imports a higher one
        ("sim.episode.loop", "sim.cli.run"),  # a library module imports a CLI module
        ("planner.motion.intercept", "planner.decision.managers.fifo"),
        ("planner.motion.intercept", "perception.errors"),  # perception's own errors
        ("perception.project_errors", "perception.codes"),  # the base imports nothing
    ],
)
def test_the_checker_flags_a_wrong_import(importer, target):
    graph = import_graph()
    graph[importer] = set(graph.get(importer, ())) | {target}
    assert any(v.startswith(f"{importer} -> {target}") for v in violations(graph))


def test_the_base_imports_nothing_of_the_project():
    graph = import_graph()
    assert {base: graph[base] for base in BASE} == {base: set() for base in BASE}


def test_one_exception_root():
    """Every error class of the three packages derives from the base's `SortsimError`, and
    every refusal from its `RefusedInput`."""
    import importlib
    import inspect

    from perception.project_errors import RefusedInput, SortsimError

    found = []
    for name in ("perception.errors", "planner.errors", "sim.errors"):
        module = importlib.import_module(name)
        found += [c for _, c in inspect.getmembers(module, inspect.isclass) if c.__module__ == name]
    assert found and all(issubclass(c, SortsimError) for c in found)
    refusals = [
        c for c in found if c.__name__.endswith("InputError") or c.__name__ == "InvalidInput"
    ]
    assert len(refusals) == 3 and all(issubclass(c, RefusedInput) for c in refusals)


def test_the_checker_flags_a_circle():
    graph = import_graph()
    graph["sim.flow.catalogue"] = set(graph["sim.flow.catalogue"]) | {"sim.flow.generator"}
    assert any("sim.flow.catalogue" in c for c in cycles(graph))


MAX_ROOM_MODULES = 15
"""Modules a room may hold (its `__init__` aside) before it is split by concern."""
MAX_EPISODE_LINES = 450
"""Lines of the module holding `class Episode`: the loop stays thin."""


def test_every_room_holds_at_most_fifteen_modules():
    rooms: dict[str, int] = {}
    for name, path in project_modules().items():
        if path.name != "__init__.py":
            room = name.rpartition(".")[0]
            rooms[room] = rooms.get(room, 0) + 1
    assert {r: n for r, n in rooms.items() if n > MAX_ROOM_MODULES} == {}


def test_the_episode_module_stays_thin():
    path = ROOT / "sim" / "episode" / "loop.py"
    assert "class Episode" in path.read_text(encoding="utf-8")
    assert len(path.read_text(encoding="utf-8").splitlines()) <= MAX_EPISODE_LINES


def _sources(exclude: str | None = None) -> dict[str, str]:
    return {
        name: path.read_text(encoding="utf-8")
        for name, path in project_modules().items()
        if exclude is None or not (name == exclude or name.startswith(exclude + "."))
    }


def test_one_kind_of_cell_no_duck_typing_of_its_robots():
    import re

    duck = re.compile(r"getattr\([^)]*[\"'](robot_cells|prefix|held_slot)[\"']")
    assert [n for n, text in _sources().items() if duck.search(text)] == []
    assert [n for n, text in _sources().items() if "LineCell" in text] == []


def test_item_poses_are_read_through_the_cells_accessors():
    """No `data.xpos[...]`/`xmat[...]` of an item body, and no rider sync, outside sim.cell."""
    import re

    by_body = re.compile(r"\b(xpos|xmat|geom_xpos|geom_xmat)\[[^\]]*(body_ids|geom_id)")
    outside = _sources(exclude="sim.cell")
    assert [n for n, text in outside.items() if by_body.search(text)] == []
    assert [n for n, text in outside.items() if re.search(r"riding\.sync\(", text)] == []


CIRCLE_FREE_ROOMS = ("sim.episode", "sim.experiments")
"""Rooms whose modules import no circle among themselves, type-checking imports counted."""


def room_cycles(room: str) -> list[list[str]]:
    """The import circles among the modules of `room`, type-checking imports included."""
    graph = import_graph(typing=True)
    inside = {m for m in graph if m.startswith(room + ".")}
    return cycles({m: graph[m] & inside for m in inside})


@pytest.mark.parametrize("room", CIRCLE_FREE_ROOMS)
def test_no_import_circle_inside_a_room_type_checking_imports_counted(room):
    assert room_cycles(room) == []


def test_the_room_circle_check_flags_a_type_checking_circle():
    graph = import_graph(typing=True)
    assert "sim.episode.loop" not in graph["sim.episode.stations"]
    inside = {m for m in graph if m.startswith("sim.episode.")}
    graph = {m: graph[m] & inside for m in inside}
    graph["sim.episode.stations"] = graph["sim.episode.stations"] | {"sim.episode.loop"}
    assert any("sim.episode.loop" in c for c in cycles(graph))


MAX_FUNCTION_LINES = 80
"""Lines a function or method may span (its docstring included) before it is split in stages."""


def test_no_function_is_longer_than_eighty_lines_and_none_waives_the_complexity_limits():
    import re

    long_ones, waivers = [], []
    for name, path in project_modules().items():
        text = path.read_text(encoding="utf-8")
        if re.search(r"noqa:[^\n]*\b(C901|PLR0912|PLR0915)\b", text):
            waivers.append(name)
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                lines = node.end_lineno - node.lineno + 1
                if lines > MAX_FUNCTION_LINES:
                    long_ones.append(f"{name}.{node.name}: {lines}")
    assert long_ones == []
    assert waivers == []
