"""sortsim: physics digital twin of a robotic recycling sorting cell (MuJoCo side)."""

from importlib import metadata as _metadata

try:
    __version__ = _metadata.version("sortsim")
except _metadata.PackageNotFoundError:  # a source tree that was never installed
    __version__ = "unknown"
