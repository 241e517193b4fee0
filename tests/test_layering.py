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

# Each room and the rooms it may import besides its own modules.
ALLOWED = {
    "perception.errors": set(),
    "perception.codes": set(),
    "perception.camera": {"perception.errors", "perception.codes"},
    "perception.hmm": {"perception.errors", "perception.codes"},
    "perception.items": {"perception.errors", "perception.codes"},
    "planner.errors": {"perception.errors"},
    "planner.motion": {"planner.errors", "perception.errors"},
    "planner.decision": {"planner.motion", "planner.errors", "perception.codes"},
    "sim.paths": set(),
    "sim.errors": {"perception.errors"},
    "sim.checks": {"sim.errors", "perception.errors"},
    "sim.user_cache": {"sim.paths", "sim.errors", "perception.errors"},
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
    ],
)
def test_the_checker_flags_a_wrong_import(importer, target):
    graph = import_graph()
    graph[importer] = set(graph.get(importer, ())) | {target}
    assert any(v.startswith(f"{importer} -> {target}") for v in violations(graph))


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
