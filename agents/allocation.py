"""Re-export of :mod:`rbenv.allocation` (moved there: rbenv's torque action mode needs it)."""

from rbenv.allocation import *  # noqa: F403
from rbenv.allocation import __all__  # noqa: F401
