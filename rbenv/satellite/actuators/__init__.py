"""The actuators of the plant: one module each, registered here by their scene table.

:data:`ACTUATORS` maps a scene table name to its entry: the parser of the table (it returns
the actuator's parameters, kept in ``Scene.actuators``) and the maker that builds the actuator
from a scene and the env's actuation options (``action_mode``, ``allocator``). The plant builds
one actuator for every registered table its scene has, in this order, and concatenates their
action slices in the same order. A new actuator is its module (the class, see
:class:`rbenv.satellite.actuators.base.Actuator`, its table parser and maker) plus one entry
here, or, outside rbenv, one :func:`register` call.
"""

from __future__ import annotations

from typing import NamedTuple

from rbenv.satellite.actuators import magnetorquers, thrusters, wheels
from rbenv.satellite.actuators.base import Actuator, ActuatorDefaults, Contribution
from rbenv.satellite.actuators.magnetorquers import Magnetorquers
from rbenv.satellite.actuators.thrusters import Thrusters
from rbenv.satellite.actuators.wheels import Wheels

__all__ = [
    "ACTION_MODES",
    "ACTUATORS",
    "ALLOCATORS",
    "DEFAULT_ACTION_MODE",
    "Actuator",
    "ActuatorDefaults",
    "Contribution",
    "Entry",
    "Magnetorquers",
    "Thrusters",
    "Wheels",
    "make_actuators",
    "register",
]


class Entry(NamedTuple):
    """A registered actuator: its table parser (``parse(table, com_B) -> params``) and maker
    (``make(scene, action_mode=, allocator=) -> Actuator``)."""

    parse: object
    make: object


ACTUATORS = {"wheels": Entry(wheels.parse_wheels, wheels.make_wheels),
             "thrusters": Entry(thrusters.parse_thrusters, thrusters.make_thrusters),
             "magnetorquers": Entry(magnetorquers.parse_magnetorquers,
                                    magnetorquers.make_magnetorquers)}
# The env's actuation options. action_mode: every mode some actuator reads (an actuator
# without a use for a mode keeps its own, one entry per element: magnetorquers always);
# allocator: how the thrusters turn a torque into throttles.
ACTION_MODES = ("throttle", "on_off", "torque", "acceleration", "acceleration_lifted")
DEFAULT_ACTION_MODE = "throttle"
ALLOCATORS = thrusters.ALLOCATORS


def register(table: str, parse, make) -> None:
    """Register an actuator by its scene table: ``parse(table, com_B) -> params`` and
    ``make(scene, action_mode=, allocator=) -> Actuator``. A scene with the table is then
    parsed with it and builds the actuator, after those registered before."""
    if not (isinstance(table, str) and table.isidentifier()) or not callable(parse) \
            or not callable(make):
        raise TypeError(f"register(table, parse, make) takes a table name and two "
                        f"callables, got {table!r}, {parse!r}, {make!r}")
    ACTUATORS[table] = Entry(parse, make)


def make_actuators(scene, **options) -> tuple:
    """The scene's actuators, in :data:`ACTUATORS` order (at least one)."""
    out = tuple(entry.make(scene, **options) for table, entry in ACTUATORS.items()
                if table in scene.actuators)
    for actuator in out:
        if not isinstance(actuator, Actuator):
            raise TypeError(f"{type(actuator).__name__} does not satisfy "
                            "rbenv.satellite.actuators.Actuator")
    return out
