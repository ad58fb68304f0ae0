"""What a user is told when an input is wrong: a value outside its choices (with a did-you-mean
for a near miss) and a missing optional dependency (naming the extra that installs it).

Both are :class:`rbenv.core.errors.RbenvValueError` subclasses, so ``rbenv`` prints them as one
line (``rbenv: error: ...``, exit status 2) and Python callers can catch them as ``ValueError``.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable

from rbenv.core.errors import InvalidParameterError, RbenvValueError

# The top-level module of each optional dependency -> the extra of pyproject.toml that
# installs it (tests/rbenv/test_usage.py checks each against pyproject's lists).
EXTRAS = {
    "torch": "train",
    "stable_baselines3": "train",
    "sb3_contrib": "train",
    "tqdm": "train",
    "rich": "train",
    "matplotlib": "train",
    "tensorboard": "train",
    "pygame": "render",
    "imageio": "render",
    "imageio_ffmpeg": "render",
    "moviepy": "render",
    "torchrl": "ecosystem",
    "tensordict": "ecosystem",
    "rl_zoo3": "ecosystem",
    "numba": "fast",
    "sbx": "sbx",
    "jax": "sbx",
    "flax": "sbx",
    "ray": "ray",
    "mujoco": "bench",
    "highspy": "mpc",
}


def suggestion(value, valid: Iterable) -> str | None:
    """The valid choice closest to ``value`` (case ignored), or None if none is near."""
    names = [str(v) for v in valid]
    text = str(value)
    same_but_case = [n for n in names if n.lower() == text.lower()]
    if same_but_case:
        return same_but_case[0]
    lowered = {n.lower(): n for n in names}
    close = difflib.get_close_matches(text.lower(), list(lowered), n=1, cutoff=0.6)
    return lowered[close[0]] if close else None


def did_you_mean(value, valid: Iterable) -> str:
    """``" (did you mean 'x'?)"`` for a near miss, else ``""``."""
    near = suggestion(value, valid)
    return f" (did you mean {near!r}?)" if near is not None else ""


class InvalidChoiceError(InvalidParameterError):
    """A value that must be one of a known set of names is not.

    ``field`` names the input (``"scene"``, ``"policy"``, ``"env_kwargs"``...), ``value`` is what
    was given, ``reason`` the rest of the message (what would be valid, a did-you-mean). The
    message reads ``"<field>: <reason>"``; ``rbenv`` names the command-line flag instead.
    """

    def __init__(self, field: str, value, reason: str):
        self.field, self.value, self.reason = field, value, reason
        super().__init__(f"{field}: {reason}")


def invalid_choice(field: str, value, valid: Iterable, *, what: str = "one of",
                   extra: str = "") -> InvalidChoiceError:
    """The error for ``value`` not in ``valid``: ``'x' is not <what> a, b, c (did you mean 'a'?)``
    plus ``extra`` (a sentence on what else is accepted)."""
    names = [str(v) for v in valid]
    reason = f"{value!r} is not {what} {', '.join(names)}{did_you_mean(value, names)}"
    return InvalidChoiceError(field, value, reason + (f"; {extra}" if extra else ""))


def check_choice(field: str, value, valid: Iterable, **kwargs) -> None:
    """Raise :func:`invalid_choice` unless ``value`` is in ``valid``."""
    valid = list(valid)
    if value not in valid:
        raise invalid_choice(field, value, valid, **kwargs)


class MissingExtraError(RbenvValueError):
    """An optional dependency (a module of one of the package's extras) is not installed."""


def install_hint(extra: str) -> str:
    """The command that installs ``extra`` (in a checkout, and from an index)."""
    return f'pip install -e ".[{extra}]" in a checkout, or pip install "rbenv[{extra}]"'


def missing_extra(error: ModuleNotFoundError, feature: str) -> MissingExtraError | None:
    """The one-line error for ``error`` (a module not found) if the module belongs to an
    extra (:data:`EXTRAS`), naming ``feature`` (what needed it) and the extra; else None."""
    name = (getattr(error, "name", None) or "").split(".")[0]
    extra = EXTRAS.get(name)
    if extra is None:
        return None
    return MissingExtraError(f"{feature} needs {name}, which is not installed; it comes with the "
                             f"{extra} extra: {install_hint(extra)}")


def require(module: str, feature: str):
    """Import ``module`` (a module of an extra) or raise :class:`MissingExtraError` naming the
    extra and ``feature``."""
    import importlib

    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as e:
        error = missing_extra(e, feature)
        if error is None:
            raise
        raise error from None
