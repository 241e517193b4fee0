"""MuJoCo's off-screen rendering back-end: checked once, at the first render, refused in one line.

MuJoCo picks its OpenGL back-end from the environment variable `MUJOCO_GL` when it is first
imported: `egl` (a GPU's driver or Mesa's software EGL) and `osmesa` (Mesa's software renderer)
render without a display; unset, it tries GLFW, which needs one. A value MuJoCo does not know
makes `import mujoco` itself fail, which would break runs that never render (truth perception,
`sortsim cycle`). So the command line calls `prepare_environment` before anything imports
MuJoCo: an unknown value is put aside (MuJoCo is imported with rendering disabled) and remembered
for the refusal. `check_backend` then renders one tiny frame the first time something renders
(the belt camera, the video, the calibration views) and refuses in one line saying what to set
when that fails. Nothing here imports MuJoCo at module level (`sortsim --help` stays fast).

The OpenGL context `check_backend` renders its frame in is kept: `gl_context` hands it to the
belt cameras (`sim.cell.camera.SceneRenderer`), so a process makes one context for all of them
(one per thread that renders).
On Mesa's software renderer a context's first MuJoCo render context and first frames cost
about 0.2 s and 0.1 s of CPU time (its shaders are compiled per context), a later one's 0.04 s.
"""

from __future__ import annotations

import contextlib
import gc
import os
import threading
import warnings
from collections.abc import Iterator

from sim.errors import InvalidInput

VARIABLE = "MUJOCO_GL"
KNOWN = ("", "egl", "osmesa", "glx", "glfw", "enable", "enabled", "on", "true", "1")
"""Values of MUJOCO_GL that MuJoCo accepts on Linux (and which try to render)."""
DISABLED = ("disable", "disabled", "off", "false", "0")
"""Values that turn MuJoCo's rendering off."""
_PUT_ASIDE = "SORTSIM_REFUSED_MUJOCO_GL"
"""Where `prepare_environment` keeps an unknown MUJOCO_GL (inherited by worker processes)."""
ALLOWED = (
    "egl or osmesa, an off-screen OpenGL back-end that works on this machine: set "
    "MUJOCO_GL=egl PYOPENGL_PLATFORM=egl (a GPU driver or Mesa's EGL), or MUJOCO_GL=osmesa "
    "PYOPENGL_PLATFORM=osmesa (Mesa's software renderer)"
)
WHERE = "the environment"
_checked: list[bool] = []
_contexts: dict[int, object] = {}
"""The OpenGL context of each thread that renders (`gl_context`), by thread id: the first is
the one `check_backend` rendered its frame in."""


_LIBRARIES = {"egl": "EGL", "osmesa": "OSMesa"}
"""The library each off-screen back-end loads when MuJoCo is imported."""


def _library_loads(name: str) -> bool:
    """Whether lib<name> can be loaded, tried as PyOpenGL tries it (.so, then .so.9 .. .so.0)."""
    import ctypes

    for suffix in ["", *(f".{i}" for i in range(9, -1, -1))]:
        try:
            ctypes.CDLL(f"lib{name}.so{suffix}", mode=ctypes.RTLD_GLOBAL)
        except OSError:
            continue
        return True
    return False


def prepare_environment() -> None:
    """Keep MUJOCO_GL from breaking `import mujoco` (call before anything imports it).

    A value MuJoCo does not know, or an off-screen back-end whose library is missing (MuJoCo's
    import fails on both), is moved to a variable of ours and MuJoCo's rendering disabled: runs
    that never render work, and the first render is refused naming the value that was given.
    """
    value = os.environ.get(VARIABLE)
    if value is None:
        return
    key = value.strip().lower()
    missing = key in _LIBRARIES and not _library_loads(_LIBRARIES[key])
    if key not in KNOWN + DISABLED or missing:
        os.environ[_PUT_ASIDE] = value
        os.environ[VARIABLE] = "disable"


def given_backend() -> str:
    """The MUJOCO_GL the user gave ('unset' when none), even one put aside, as text."""
    return _given()


def _given() -> str:
    """The MUJOCO_GL the user gave, as text for the refusal."""
    put_aside = os.environ.get(_PUT_ASIDE)
    if put_aside is not None:
        return put_aside
    value = os.environ.get(VARIABLE)
    return "unset" if value is None else value


@contextlib.contextmanager
def quiet_stderr() -> Iterator[None]:
    """Silence the C libraries' and GLFW's messages on stderr (and Python's warnings) while
    a back-end is probed or a window opened."""
    try:
        saved = os.dup(2)
    except OSError:
        saved = None
    try:
        if saved is not None:
            with open(os.devnull, "wb") as null:
                os.dup2(null.fileno(), 2)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            yield
    finally:
        if saved is not None:
            os.dup2(saved, 2)
            os.close(saved)


def _refusal(reason: str) -> InvalidInput:
    reason = " ".join(reason.split())[:100]
    return InvalidInput(VARIABLE, ALLOWED, f"{_given()}: {reason}", WHERE)


def check_backend() -> None:
    """Render one tiny frame off-screen, once per process; refuse in one line if it fails. The
    OpenGL context it renders in is kept for `gl_context`.

    Raises:
        InvalidInput: MUJOCO_GL is unknown, disables rendering, or names a back-end that cannot
            create an OpenGL context here; the message says what to set.
    """
    if _checked:
        return
    if _PUT_ASIDE in os.environ:
        key = os.environ[_PUT_ASIDE].strip().lower()
        if key in _LIBRARIES:
            raise _refusal(f"lib{_LIBRARIES[key]} is not installed")
        raise _refusal("not a back-end MuJoCo knows")
    if os.environ.get(VARIABLE, "").strip().lower() in DISABLED:
        raise _refusal("rendering is disabled")
    failure, context = None, None
    with quiet_stderr():
        try:
            context = _probe()
        except Exception as exc:  # any failure of the GL stack is the same refusal
            failure = f"{type(exc).__name__}: {exc}"
        gc.collect()  # a half-made context's finaliser may complain: while stderr is quiet
    if failure is not None:
        raise _refusal(failure)
    _contexts[threading.get_ident()] = context
    _checked.append(True)


def _probe():
    """An OpenGL context in which a tiny scene was rendered and read back (MuJoCo's
    `mjr_render`, `mjr_readPixels`), current on this thread."""
    import mujoco
    import numpy as np
    from mujoco.rendering.classic import gl_context as backends

    # The frame's own buffers only (no multisampling, no shadow map): a third of the cost.
    model = mujoco.MjModel.from_xml_string(
        "<mujoco><visual><global offwidth='8' offheight='8'/>"
        "<quality offsamples='0' shadowsize='0'/></visual>"
        "<worldbody><light pos='0 0 1'/><geom size='0.1'/></worldbody></mujoco>"
    )
    context = backends.GLContext(8, 8)
    context.make_current()
    mjr = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_150.value)
    try:
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN.value, mjr)
        scene = mujoco.MjvScene(model, maxgeom=10)
        camera = mujoco.MjvCamera()
        mujoco.mjv_defaultFreeCamera(model, camera)
        everything = mujoco.mjtCatBit.mjCAT_ALL.value
        data = mujoco.MjData(model)
        mujoco.mjv_updateScene(model, data, mujoco.MjvOption(), None, camera, everything, scene)
        rect = mujoco.MjrRect(0, 0, 8, 8)
        mujoco.mjr_render(rect, scene, mjr)
        mujoco.mjr_readPixels(np.empty((8, 8, 3), np.uint8), None, rect, mjr)
    finally:
        mjr.free()
    return context


def gl_context():
    """This thread's OpenGL context, made current: the one `check_backend` rendered its frame
    in (checked first) on the thread that checked, one made now on another (a context is
    current on one thread at a time).

    Raises:
        InvalidInput: As `check_backend`.
    """
    check_backend()
    context = _contexts.get(threading.get_ident())
    if context is None:
        from mujoco.rendering.classic import gl_context as backends

        context = _contexts[threading.get_ident()] = backends.GLContext(8, 8)
    context.make_current()
    return context
