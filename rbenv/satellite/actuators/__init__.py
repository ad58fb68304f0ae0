"""The actuators of the plant: one module each, registered here by their scene table.

:data:`ACTUATORS` maps a scene table name to its entry: the parser of the table (it returns
the actuator's parameters, kept in ``Scene.actuators``) and the maker that builds the actuator
from a scene and the env's actuation options (``action_mode``, ``allocator``). The plant builds
one actuator for every registered table its scene has, in this order, and concatenates their
action slices in the same order. A new actuator is its module (the class, see
:class:`rbenv.satellite.actuators.base.Actuator`, its table parser and maker) plus one entry here.

``[thrusters]`` predates the registry: ``rbenv.satellite.scene`` parses it into ``Scene.thrusters``
(its parser here is None).
"""

from __future__ import annotations

from typing import NamedTuple

from rbenv.satellite.actuators.base import Actuator, Contribution
from rbenv.satellite.actuators.magnetorquers import (
    Magnetorquers,
    make_magnetorquers,
    parse_magnetorquers,
)
from rbenv.satellite.actuators.thrusters import Thrusters, make_thrusters
from rbenv.satellite.actuators.wheels import Wheels, make_wheels, parse_wheels

__all__ = ["ACTUATORS", "Actuator", "Contribution", "Magnetorquers", "Thrusters", "Wheels",
           "make_actuators"]


class Entry(NamedTuple):
    """A registered actuator: its table parser (``parse(table, com_B) -> params``) and maker
    (``make(scene, action_mode=, allocator=) -> Actuator``)."""

    parse: object
    make: object


ACTUATORS = {"wheels": Entry(parse_wheels, make_wheels),
             "thrusters": Entry(None, make_thrusters),
             "magnetorquers": Entry(parse_magnetorquers, make_magnetorquers)}


def _present(scene, table: str) -> bool:
    if table == "thrusters":
        return scene.thrusters is not None
    return table in scene.actuators


def make_actuators(scene, **options) -> tuple:
    """The scene's actuators, in :data:`ACTUATORS` order (at least one)."""
    out = tuple(entry.make(scene, **options) for table, entry in ACTUATORS.items()
                if _present(scene, table))
    for actuator in out:
        if not isinstance(actuator, Actuator):
            raise TypeError(f"{type(actuator).__name__} does not satisfy "
                            "rbenv.satellite.actuators.Actuator")
    return out
