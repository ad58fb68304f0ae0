"""Command-line flags generated from dataclass fields and their docstrings (CleanRL's manner).

Each field of a config dataclass is written once, with its default and its docstring (the
string literal under it, read by :func:`rbenv.envs.options.field_docs`); :func:`add_fields` turns
the fields into ``--kebab-case`` flags whose help is that docstring and whose default is the
field's, and :func:`given` reads back only the flags the user gave, so a default is never
restated in argparse. Types map as: ``int``,
``float``, ``str`` (``X | None`` too) to the same type; ``bool`` to ``--flag/--no-flag``;
``dict`` to a JSON object; ``Literal[...]`` to choices.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import types
import typing

from rbenv.envs.options import field_docs

NO_DEFAULT = "(no default)"


def flag(name: str) -> str:
    """The flag of a field: ``n_envs`` -> ``--n-envs``."""
    return "--" + name.replace("_", "-")


def json_object(text: str) -> dict:
    """An argparse type: a JSON object."""
    try:
        value = json.loads(text)
    except json.JSONDecodeError as e:
        raise argparse.ArgumentTypeError(f"not valid JSON ({e}): {text!r}") from None
    if not isinstance(value, dict):
        raise argparse.ArgumentTypeError(f"must be a JSON object, got {text!r}")
    return value


def _argparse_kwargs(hint) -> dict:
    """argparse keyword arguments (type, choices, action) for a resolved type hint."""
    args = [a for a in typing.get_args(hint) if a is not type(None)]
    if typing.get_origin(hint) in (typing.Union, types.UnionType) and len(args) == 1:
        hint = args[0]  # X | None: None is the default, never typed on the command line
    if typing.get_origin(hint) is typing.Literal:
        choices = typing.get_args(hint)
        return {"type": type(choices[0]), "choices": choices}
    if hint is bool:
        return {"action": argparse.BooleanOptionalAction}
    if hint is dict or typing.get_origin(hint) is dict:
        return {"type": json_object, "metavar": "JSON"}
    if hint in (int, float, str):
        return {"type": hint}
    raise TypeError(f"no command-line form for a field of type {hint!r}")


def _default_text(f: dataclasses.Field) -> str:
    if f.default is None:
        return "unset"
    if f.default is not dataclasses.MISSING:
        return repr(f.default)
    if f.default_factory is not dataclasses.MISSING:
        return json.dumps(f.default_factory())
    return NO_DEFAULT


def add_fields(parser, cls: type, *, skip=(), seen: set | None = None) -> None:
    """Add a flag for every field of dataclass ``cls`` not in ``skip`` (nor in ``seen``, the
    names already added, which it extends). The parser's value stays unset unless given."""
    hints = typing.get_type_hints(cls)
    docs = field_docs(cls)
    seen = set() if seen is None else seen
    for f in dataclasses.fields(cls):
        if f.name in skip or f.name in seen:
            continue
        seen.add(f.name)
        help_text = f"{docs.get(f.name, '')} (default: {_default_text(f)})".strip()
        parser.add_argument(flag(f.name), dest=f.name, default=argparse.SUPPRESS,
                            help=help_text.replace("%", "%%"), **_argparse_kwargs(hints[f.name]))


def given(args: argparse.Namespace, cls: type) -> dict:
    """The fields of ``cls`` the user gave on the command line, by name."""
    names = {f.name for f in dataclasses.fields(cls)}
    return {k: v for k, v in vars(args).items() if k in names}
