"""The actuators of the plant: one module each, registered here by their scene table.

:data:`ACTUATORS` maps a scene table name to the function that builds the actuator from a scene
and the env's actuation options (``action_mode``, ``allocator``). The plant builds one actuator
for every registered table that its scene has, in this order; their action slices are
concatenated in the same order. A new actuator is its module (the class, see
:class:`rbenv.actuators.base.Actuator`, and its table parser) plus one entry here.
"""

from __future__ import annotations

from rbenv.actuators.base import Actuator, Contribution
from rbenv.actuators.thrusters import Thrusters, make_thrusters

__all__ = ["ACTUATORS", "Actuator", "Contribution", "Thrusters", "make_actuators"]

ACTUATORS = {"thrusters": make_thrusters}


def make_actuators(scene, **options) -> tuple:
    """The scene's actuators, in :data:`ACTUATORS` order (at least one)."""
    out = tuple(make(scene, **options) for table, make in ACTUATORS.items()
                if getattr(scene, table, None) is not None)
    for actuator in out:
        if not isinstance(actuator, Actuator):
            raise TypeError(f"{type(actuator).__name__} does not satisfy rbenv.actuators.Actuator")
    return out
