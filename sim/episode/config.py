"""The episode config lives in `sim.config`; this name follows it until the imports do."""

from sim.config import *  # noqa: F403
from sim.config import SCALARS, SECTIONS
from sim.config import __doc__ as __doc__  # noqa: PLC0414
from sim.errors import InvalidInput  # noqa: F401

_SECTIONS = SECTIONS
_SCALARS = set(SCALARS)
