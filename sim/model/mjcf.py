"""Loading MJCF files into MuJoCo models, refused in one line when they cannot be used.

A model file is refused (`ModelFileError`, exit code 2, one line naming the file) when it is
missing or not a file, is not UTF-8 (it or a file it includes), does not compile, holds NaN or
infinite numbers (MuJoCo only warns about those), or lacks an element the code looks up by name
(`ROBOT_ELEMENTS` for the robot, `CELL_ELEMENTS` as well for the cell): the refusal names the
missing element and the file, not every name the model has.
"""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import mujoco
import numpy as np

from sim.errors import ModelFileError
from sim.paths import ROBOT_XML, SCENE_XML

_LEGS = (1, 2, 3)
_RODS = ("a", "b")
_BINS = ("paper", "plastic", "aluminium")

Element = tuple[tuple[str, ...], str]
"""(the kinds it may be, e.g. ("geom", "site"), its name)."""


def _of(kind: str, *names: str) -> tuple[Element, ...]:
    return tuple(((kind,), name) for name in names)


def robot_elements(prefix: str = "") -> tuple[Element, ...]:
    """Elements of the IRB 360 the code reads by name (`sim.cell.robot`, the executor, the
    cup), for the robot whose names start with `prefix` (a robot of a sorting line,
    `sim.model.line_model`; "" for the robot's own names)."""
    p = prefix
    return (
        *_of("body", *(p + n for n in ("base_link", "platform_link", "cup_link"))),
        *_of("body", *(f"{p}rod_1{r}_link" for r in _RODS)),
        *_of("body", *(f"{p}upper_arm_{i}_link" for i in _LEGS)),
        *_of("joint", *(f"{p}motor_{i}_joint" for i in _LEGS)),
        *_of("joint", f"{p}axis4_joint", f"{p}platform_joint"),
        *_of("site", f"{p}cup_site"),
        *_of("site", *(f"{p}rod_{i}{r}_tip" for i in _LEGS for r in _RODS)),
        *_of("site", *(f"{p}platform_{i}{r}" for i in _LEGS for r in _RODS)),
        *_of("actuator", *(f"{p}motor_{i}" for i in _LEGS), f"{p}axis4"),
        *_of("geom", f"{p}cup_collision"),
        *_of("key", f"{p}home"),
    )


ROBOT_ELEMENTS: tuple[Element, ...] = robot_elements()
"""Elements of the IRB 360 the code reads by name (`sim.cell.robot`, the executor, the cup)."""

CELL_ELEMENTS: tuple[Element, ...] = (
    *ROBOT_ELEMENTS,
    *_of("geom", "belt", "rail_left", "rail_right"),
    *_of("geom", *(f"bin_{b}_floor_plate" for b in _BINS)),
    *_of("site", *(f"bin_{b}_drop" for b in _BINS)),
    *_of("camera", "belt_camera"),
    *((("geom", "site"), f"marker_{i}") for i in range(4)),
    *_of("body", "item_0"),
)
"""Elements of the cell the code reads by name (belt, rails, bins, camera, markers, pool)."""

_OBJECTS = {
    "body": mujoco.mjtObj.mjOBJ_BODY,
    "joint": mujoco.mjtObj.mjOBJ_JOINT,
    "site": mujoco.mjtObj.mjOBJ_SITE,
    "actuator": mujoco.mjtObj.mjOBJ_ACTUATOR,
    "geom": mujoco.mjtObj.mjOBJ_GEOM,
    "camera": mujoco.mjtObj.mjOBJ_CAMERA,
    "key": mujoco.mjtObj.mjOBJ_KEY,
    "equality": mujoco.mjtObj.mjOBJ_EQUALITY,
}
_INCLUDE = re.compile(rb"<include\s[^>]*file\s*=\s*[\"']([^\"']+)[\"']")
_FLOAT_FIELDS: dict[type, tuple[str, ...]] = {}
_GIVEN = ("option.", "body_", "geom_", "jnt_", "site_", "cam_", "light_", "mesh_", "key_", "eq_")
"""Prefixes of compiled fields that the file sets directly (reported first)."""


def _one_line(text: object, limit: int = 200) -> str:
    return " ".join(str(text).split())[:limit]


def _check_text(path: Path, top: Path, seen: set[Path]) -> None:
    """Every file of the model (the top file and what it includes) must be UTF-8."""
    if path in seen:
        return
    seen.add(path)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        where = "" if path == top else f" (included: {path})"
        raise ModelFileError(top, f"unreadable{where}: {_one_line(exc.strerror or exc)}") from None
    try:
        raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        where = "" if path == top else f" (included: {path})"
        raise ModelFileError(top, f"not UTF-8 text{where} at byte {exc.start}") from None
    for name in _INCLUDE.findall(raw):
        included = path.parent / name.decode("utf-8")
        if included.is_file():  # a missing include is MuJoCo's to report
            _check_text(included, top, seen)


def _float_fields(obj: object) -> tuple[str, ...]:
    kind = type(obj)
    if kind not in _FLOAT_FIELDS:
        names = []
        for name in dir(obj):
            if name.startswith("_"):
                continue
            try:
                value = getattr(obj, name)
            except Exception:  # noqa: BLE001 - some attributes raise on access
                continue
            if isinstance(value, np.ndarray | float) and np.asarray(value).dtype.kind == "f":
                names.append(name)
        _FLOAT_FIELDS[kind] = tuple(names)
    return _FLOAT_FIELDS[kind]


def check_finite(model: mujoco.MjModel, path: object) -> None:
    """Refuse a compiled model holding NaN or infinite numbers, or a time step <= 0.

    Raises:
        ModelFileError: naming the first such field of the compiled model and the file.
    """
    bad = []
    for owner, prefix in ((model.opt, "option."), (model, "")):
        for name in _float_fields(owner):
            if not np.all(np.isfinite(np.asarray(getattr(owner, name)))):
                bad.append(prefix + name)
    if bad:
        # the fields the file sets (body_pos, geom_size ...) before those computed from them
        derived = ("0", "subtreemass")  # invweight0, acc0, length0 ...: computed by MuJoCo
        bad.sort(key=lambda n: (not n.startswith(_GIVEN) or n.endswith(derived), n))
        shown = ", ".join(bad[:3]) + (f" and {len(bad) - 3} more" if len(bad) > 3 else "")
        raise ModelFileError(path, f"NaN or infinite numbers in {shown}")
    if not model.opt.timestep > 0:
        raise ModelFileError(path, f"option.timestep must be > 0 s (got {model.opt.timestep})")


def require_elements(model: mujoco.MjModel, elements: tuple[Element, ...], path: object) -> None:
    """Refuse a model lacking an element the code looks up by name.

    Raises:
        ModelFileError: one line naming the missing element (its kind and name) and the file.
    """
    for kinds, name in elements:
        if not any(mujoco.mj_name2id(model, _OBJECTS[k], name) >= 0 for k in kinds):
            what = f"no {' or '.join(kinds)} named {name!r} (the code needs it)"
            raise ModelFileError(path, what)


def load_model(path: str | Path, elements: tuple[Element, ...] = ()) -> mujoco.MjModel:
    """Compile an MJCF file, checked as the module docstring says.

    Args:
        path: MJCF file path.
        elements: Named elements the caller needs (`ROBOT_ELEMENTS`, `CELL_ELEMENTS`).

    Raises:
        ModelFileError: the file does not exist, is not a file, is not UTF-8, does not compile,
            holds non-finite numbers or lacks one of `elements`; one line naming the file.
    """
    path = Path(path)
    if not path.is_file():
        raise ModelFileError(path, "no such file" if not path.exists() else "not a file")
    _check_text(path, path, set())
    said: list[str] = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(said.append)  # MuJoCo's own printing would add stderr lines
    try:
        model = mujoco.MjModel.from_xml_path(str(path))
    except (ValueError, OSError) as exc:
        raise ModelFileError(path, f"does not compile: {_one_line(exc)}") from exc
    finally:
        mujoco.set_mju_user_warning(previous)
    check_finite(model, path)
    nan = [w for w in said if "nan" in w.lower()]
    if nan:
        raise ModelFileError(path, _one_line(nan[0]))
    for text in said:
        warnings.warn(f"MuJoCo, loading {path}: {_one_line(text)}", RuntimeWarning, stacklevel=2)
    require_elements(model, elements, path)
    return model


def load_spec(path: str | Path, elements: tuple[Element, ...] = ()) -> mujoco.MjSpec:
    """An MJCF file as an `MjSpec` to edit, once `load_model(path, elements)` accepted it.

    Raises:
        ModelFileError: as `load_model`.
    """
    load_model(path, elements)
    try:
        return mujoco.MjSpec.from_file(str(path))
    except (ValueError, OSError) as exc:  # pragma: no cover - load_model compiled it
        raise ModelFileError(path, f"does not compile: {_one_line(exc)}") from exc


def compile_spec(
    spec: mujoco.MjSpec, path: object, elements: tuple[Element, ...] = ()
) -> mujoco.MjModel:
    """Compile an edited `MjSpec` of file `path`, checked as `load_model` checks a file."""
    try:
        model = spec.compile()
    except (ValueError, OSError) as exc:
        raise ModelFileError(path, f"does not compile: {_one_line(exc)}") from exc
    check_finite(model, path)
    require_elements(model, elements, path)
    return model


def cell_elements(materials=None) -> tuple[Element, ...]:
    """`CELL_ELEMENTS` with the bins of `materials` (the thesis's when None)."""
    from sim.model.bin_layout import bin_elements

    if materials is None or tuple(materials.names) == _BINS:
        return CELL_ELEMENTS
    thesis_bins = {f"bin_{b}_floor_plate" for b in _BINS} | {f"bin_{b}_drop" for b in _BINS}
    kept = tuple(e for e in CELL_ELEMENTS if e[1] not in thesis_bins)
    return kept + bin_elements(materials)


def load_scene(path: str | Path = SCENE_XML, materials=None) -> mujoco.MjModel:
    """The sorting cell (`models/cell/scene.xml`): robot, belt, bins, cameras, items; with one
    bin per material of `materials` (`perception.codes.Materials`; the file's thesis bins when
    None or the thesis's materials, `sim.model.bin_layout`)."""
    if materials is None or tuple(materials.names) == _BINS:
        return load_model(path, CELL_ELEMENTS)
    from sim.model.bin_layout import lay_out_bins

    spec = load_spec(path, CELL_ELEMENTS)
    lay_out_bins(spec, materials)
    return compile_spec(spec, path, cell_elements(materials))


def load_robot(path: str | Path = ROBOT_XML) -> mujoco.MjModel:
    """The robot alone (`models/abb_irb360/irb360.xml`)."""
    return load_model(path, ROBOT_ELEMENTS)
