"""Every command the README and docs/ show still parses: each ``rbenv``/``python -m rbenv`` line
of a fenced code block is given to the command's own parser (nothing runs), and each
``python -m MODULE`` named anywhere is a module that exists."""

from __future__ import annotations

import importlib.util
import re
import shlex
from pathlib import Path

import pytest
from rbenv.agents import cli

ROOT = Path(__file__).resolve().parents[2]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
COMMAND = re.compile(r"(?:^|[`\s])(?:\.venv/bin/)?(?:python -m rbenv|rbenv)"
                     r" ((?:train|evaluate|bench|suite|export|replay|identify)\b[^`\n#|]*)")
MODULE = re.compile(r"python -m ((?:rbenv|benchmarks)[\w.]*)")


def _code_lines(text: str):
    """The lines of the fenced code blocks, continuation lines (ending in a backslash) joined."""
    inside, pending = False, ""
    for line in text.splitlines():
        if line.lstrip().startswith("```"):
            inside, pending = not inside, ""
            continue
        if inside:
            if line.rstrip().endswith("\\"):
                pending += line.rstrip()[:-1] + " "
                continue
            yield pending + line
            pending = ""


def _commands() -> list[tuple[str, str]]:
    found = []
    for page in PAGES:
        for line in _code_lines(page.read_text()):
            for match in COMMAND.finditer(line):
                if "[" in match.group(1):  # a usage synopsis, not a command
                    continue
                found.append((page.relative_to(ROOT).as_posix(), match.group(1).strip()))
    return found


COMMANDS = _commands()


def test_the_pages_show_commands():
    assert len(COMMANDS) > 10 and any(p == "README.md" for p, _ in COMMANDS)


@pytest.mark.parametrize(("page", "command"), COMMANDS)
def test_a_documented_command_parses(page, command):
    words = shlex.split(command)
    if words[0] == "bench" and len(words) > 1 and not cli.benchmarks():
        pytest.skip("no benchmarks/ folder (an installed wheel)")
    try:
        cli.parse(words)
    except SystemExit as e:
        if e.code == 0:  # --help
            return
        pytest.fail(f"{page}: `rbenv {command}` does not parse (exit {e.code})")


@pytest.mark.parametrize("module", sorted({m for page in PAGES
                                          for m in MODULE.findall(page.read_text())
                                          if m != "rbenv"}))
def test_a_documented_module_exists(module):
    assert importlib.util.find_spec(module.rstrip(".")) is not None, module


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_relative_links_resolve(page):
    missing = [t for t in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", page.read_text())
               if not t.startswith(("http://", "https://", "mailto:"))
               and not (page.parent / t).exists()]
    assert not missing, missing
