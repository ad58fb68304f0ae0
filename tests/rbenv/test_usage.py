"""User-facing messages: the did-you-mean of a near miss and the extra a missing module needs."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest

from rbenv.satellite import usage

ROOT = Path(__file__).resolve().parents[2]
# A module whose distribution is named otherwise, or that comes with another one.
DISTRIBUTION = {"pygame": "pygame-ce", "tensordict": "torchrl", "sbx": "sbx-rl"}


def _extras() -> dict[str, set[str]]:
    """pyproject.toml's extras: name -> the distributions it installs (nested extras expanded)."""
    import tomllib

    declared = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"][
        "optional-dependencies"]

    def names(extra: str) -> set[str]:
        found = set()
        for requirement in declared[extra]:
            nested = re.fullmatch(r"rbenv\[(\w+)\]", requirement)
            if nested:
                found |= names(nested.group(1))
            else:
                found.add(re.split(r"[\[<>=!~; ]", requirement)[0].lower().replace("_", "-"))
        return found

    return {extra: names(extra) for extra in declared}


@pytest.mark.skipif(sys.version_info < (3, 11), reason="tomllib")
def test_each_optional_module_is_installed_by_the_extra_it_names():
    extras = _extras()
    for module, extra in usage.EXTRAS.items():
        distribution = DISTRIBUTION.get(module, module).replace("_", "-")
        assert distribution in extras[extra], (module, extra)


def test_a_near_miss_gets_a_did_you_mean_and_a_far_one_does_not():
    assert usage.suggestion("PD", ["pd", "bangbang"]) == "pd"
    assert usage.suggestion("cubesat12u", ["cubesat-12u", "boom-sat"]) == "cubesat-12u"
    assert usage.suggestion("xyzzy", ["cubesat-12u", "boom-sat"]) is None
    error = usage.invalid_choice("scene", "boomsat", ["cubesat-12u", "boom-sat"])
    assert str(error) == ("scene: 'boomsat' is not one of cubesat-12u, boom-sat (did you mean "
                          "'boom-sat'?)")
    assert isinstance(error, ValueError) and error.field == "scene"


def test_a_missing_module_of_an_extra_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "torchrl", None)
    with pytest.raises(usage.MissingExtraError, match=r"needs torchrl.*the ecosystem extra"):
        usage.require("torchrl", "rbenv train --engine torchrl")
    assert usage.missing_extra(ModuleNotFoundError("x", name="not_an_extra"), "it") is None
