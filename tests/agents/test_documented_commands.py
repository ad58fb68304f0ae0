"""Every command the README and docs/ show works, not only parses.

The commands are each ``rbenv``/``python -m rbenv`` line of a fenced code block, and each whole
command in a cell of a Markdown table (the results tables give the command of each figure).
Every one is given to the command's own parser, and then, where it can run here:

- ``evaluate`` runs with its own arguments and 2 episodes (--json, --plot, --video and --out go
  to a temporary folder, and what they write is read back);
- ``export`` runs on the run folder it names, writing into a temporary folder;
- ``replay`` runs on telemetry these tests write in the dashboard's format (two short slews;
  the flight data has no license and is never read);
- ``train`` runs with ``--dry-run``: every check that runs before anything is written, and
  nothing is written.

The run folders, exports and RL Zoo model the lines name (``runs/...``, ``RUN_DIR``,
``flight/ppo``) are made once per session in a shared folder, each by the documented line that
makes it, shortened to a few hundred steps (:data:`RECIPES`). Lines that cannot run here are
listed in :data:`NOT_RUN` and :data:`KINDS_NOT_RUN` with the reason, and still parse. Each
``python -m MODULE`` named anywhere is a module that exists, and relative links resolve.
"""

from __future__ import annotations

import importlib.util
import json
import math
import os
import re
import shlex
import shutil
from datetime import datetime
from pathlib import Path

import numpy as np
import pytest
from rbenv.agents import cli
from rbenv.agents.flight.telemetry import Telemetry, write_folder

from rbenv.satellite.usage import MissingExtraError

ROOT = Path(__file__).resolve().parents[2]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
KINDS = "train|evaluate|bench|suite|export|replay|identify"
COMMAND = re.compile(r"(?:^|[`\s])(?:\.venv/bin/)?(?:python -m rbenv|rbenv)"
                     rf" ((?:{KINDS})\b[^`\n#|]*)")
TABLE_CELL = re.compile(rf"`python -m rbenv ((?:{KINDS})\b[^`]*)`")
PLACEHOLDER = re.compile(r"(?:^|[\s/=])[A-Z][A-Z_]*(?=$|[\s/])")  # S, DIR, RUN_DIR
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


def _table_cells(text: str):
    """The commands in the cells of Markdown tables, outside fenced code blocks: whole
    ``python -m rbenv ...`` commands, not a flag or a placeholder's form named in prose."""
    inside = False
    for line in text.splitlines():
        if line.lstrip().startswith("```"):
            inside = not inside
        elif not inside and line.lstrip().startswith("|"):
            yield from (m.group(1) for m in TABLE_CELL.finditer(line))


def _synopsis(command: str) -> bool:
    """A usage synopsis, not a command: [optional] parts, a|b choices or ... outside quotes."""
    bare = re.sub(r"'[^']*'|\"[^\"]*\"", "", command)
    return any(mark in bare for mark in ("[", "|", "..."))


def _commands() -> list[tuple[str, str]]:
    found = []
    for page in PAGES:
        text, name = page.read_text(), page.relative_to(ROOT).as_posix()
        for line in _code_lines(text):
            found += [(name, m.group(1).strip()) for m in COMMAND.finditer(line)
                      if not _synopsis(m.group(1))]
        found += [(name, " ".join(c.split())) for c in _table_cells(text)
                  if not _synopsis(c) and " " in c.strip() and not PLACEHOLDER.search(c)]
    return list(dict.fromkeys(found))


COMMANDS = _commands()


def _id(item) -> str:
    page, command = item
    return f"{page}: {command}"[:150]


# --- what cannot run here -----------------------------------------------------------------------

KINDS_NOT_RUN = {
    "bench": "a benchmark: minutes to hours, and it writes its results (parsed only)",
    "suite": "the learning suite trains every algorithm x task x scene x seed: hours",
    "identify": "fits a scene to flight telemetry with hundreds of simulated flights: minutes",
}
NOT_RUN = {
    ("docs/ray.md", "train --engine rllib --out runs/rllib-ppo-cubesat-12u-seed0 --resume "
                    "--trust-pickle"):
        "resumes an RLlib run folder: needs Ray and an RLlib run (CI's Ray stage tests resume)",
}
NEEDS_RAY = "--engine rllib needs Ray (the ray extra; CI runs the Ray tests in their own venv)"


# --- the shared folder: run folders, exports, an RL Zoo model, telemetry ------------------------

TINY = {"--checkpoint-every": "128", "--eval-every": "128", "--eval-episodes": "2",
        "--env-kwargs": json.dumps({"max_episode_steps": 30}), "--timesteps": "256"}
TINY_SB3 = {**TINY, "--n-envs": "4", "--no-report": None, "--no-progress": None}
TINY_PPO = {**TINY_SB3, "--hyperparams": json.dumps({"n_steps": 32, "batch_size": 64,
                                                     "n_epochs": 1})}
TINY_OFF = {**TINY_SB3, "--hyperparams": json.dumps({"learning_starts": 64, "batch_size": 32,
                                                     "buffer_size": 1000})}
TINY_TORCHRL = {**TINY, "--no-report": None, "--hyperparams": json.dumps(
    {"n_envs": 8, "n_steps": 16, "batch_size": 64, "n_epochs": 2,
     "policy_kwargs": {"net_arch": [16, 16]}})}
# A run folder a line names -> the documented line that makes it, and its shortening.
RECIPES = {
    "runs/ppo-cubesat-12u-seed0": (("docs/export.md", "train --out runs/ppo-cubesat-12u-seed0"),
                                   TINY_PPO),
    "runs/ppo-desat-12u-rw": (("docs/tasks.md", "train --env-id rbenv/SatelliteDesaturate-v0 "
                               "--scene cubesat-12u-rw --out runs/ppo-desat-12u-rw"), TINY_PPO),
    "runs/sac-v0-seed0": (("docs/off-policy.md", "train --algo sac --env-id "
                           "rbenv/SatelliteReorient-v0 --out runs/sac-v0-seed0 --eval-every "
                           "50000 --checkpoint-every 50000 --no-progress"), TINY_OFF),
    "runs/torchrl": (("docs/torch.md", "train --engine torchrl --device cpu --out runs/torchrl"),
                     TINY_TORCHRL),
}
EXPORTS = {"flight/ppo": ("docs/export.md", "export runs/ppo-cubesat-12u-seed0 --format c "
                                            "--format onnx --out flight/ppo")}
SHIPPED = {"runs/innocube": "docs/innocube/policy",  # the shipped InnoCube run: its recipe's
           "runs/my-sat": "docs/innocube/policy"}    # result (docs/innocube/learned-policy.md)
ZOO = "logs/ppo/rbenv-SatelliteReorient-v0_1"  # results.md: RUN=logs/ppo/... of an RL Zoo run
# Placeholders of the pages, as path parts: what each stands for there.
PLACEHOLDERS = {"RUN_DIR": "runs/ppo-cubesat-12u-seed0", "$RUN": ZOO, "RUN": "runs/sac-v0-seed0",
                "NAME": "innocube-3u"}
CHECKPOINT = re.compile(r"(.*/checkpoints)/(?:CHECKPOINT|policy_\d+\.pt)")
START = datetime(2025, 12, 15, 21, 50, 8)


def _with(words: list[str], flags: dict) -> list[str]:
    """``words`` with each flag of ``flags`` set to its value (appended: argparse's last wins;
    a None value is a switch)."""
    return [*words, *(w for k, v in flags.items() for w in ((k,) if v is None else (k, v)))]


def _two_slews() -> Telemetry:
    """Two slews of an InnoCube-like log on the 2 s grid, a target switch between: 140° and
    110° decaying, the wheels spun up, commands within the clamp."""
    t = 2.0 * np.arange(40)
    angle = np.concatenate([140.0 * np.exp(-t[:20] / 12.0), 110.0 * np.exp(-t[:20] / 12.0)])
    half = np.radians(angle) / 2.0
    q = np.column_stack([np.cos(half), 0.6 * np.sin(half), 0.8 * np.sin(half),
                         np.zeros_like(half)])
    rate = np.column_stack([-0.6 * angle / 12.0, -0.8 * angle / 12.0, 0.1 * np.ones_like(t)])
    wheel = np.column_stack([10.0 * t, -8.0 * t, 50.0 * np.ones_like(t)])
    command = np.zeros((len(t), 3))
    command[2:] = [20.0, -15.0, 4.0]
    return Telemetry(folder=None, start_utc=START, time_s=t, q=q, rate_dps=rate,
                     wheel_rpm=wheel, command_rpm_s=command)


class World:
    """The folder the commands run in (``docs`` linked to the checkout's), with what they need
    made on first use."""

    def __init__(self, root: Path):
        self.root = root
        (root / "docs").symlink_to(ROOT / "docs", target_is_directory=True)
        self.telemetry = write_folder(root / "telemetry" / "15.12.2025 21.50-22.05",
                                      _two_slews()).parent

    def need(self, word: str) -> None:
        """Make what ``word`` (a path a command names) lies in, if it is one of ours."""
        for path in (*RECIPES, *EXPORTS, *SHIPPED, ZOO):
            if (word == path or word.startswith(path + "/")) and not (self.root / path).exists():
                self._make(path)

    def _make(self, path: str) -> None:
        if path in EXPORTS and importlib.util.find_spec("onnx") is None:
            pytest.skip("no onnx (the export extra) to export flight/ppo as the page does")
        cwd = os.getcwd()
        os.chdir(self.root)
        try:
            if path in RECIPES:
                line, tiny = RECIPES[path]
                assert line in COMMANDS, f"the recipe of {path} is no longer documented: {line}"
                assert cli.main(_with(shlex.split(line[1]), tiny)) == 0
            elif path in EXPORTS:
                self.need(shlex.split(EXPORTS[path][1])[1])
                assert EXPORTS[path] in COMMANDS
                assert cli.main(shlex.split(EXPORTS[path][1])) == 0
            elif path in SHIPPED:
                shutil.copytree(ROOT / SHIPPED[path], self.root / path)
            else:
                _zoo_model(self.root / ZOO)
        finally:
            os.chdir(cwd)

    def argv(self, words: list[str]) -> list[str]:
        """``words`` with the pages' placeholders filled in, and a checkpoint named by the
        page (whose step count a shortened run does not reach) the run's newest of that kind."""
        out = []
        for i, word in enumerate(words):
            if i and words[i - 1] == "--out":  # a run to resume, or a folder to write
                self.need(word)
                out.append(word)
                continue
            word = "/".join(PLACEHOLDERS.get(part, part) for part in word.split("/"))
            self.need(word)
            found = CHECKPOINT.fullmatch(word)
            if found:
                folder = self.root / found.group(1)
                newest = max(folder.glob("policy_*.pt"),
                             key=lambda p: int(p.stem.split("_")[1]), default=None)
                assert newest is not None, f"no policy_N.pt checkpoint in {folder}"
                word = f"{found.group(1)}/{newest.name}"
            out.append(word)
        return out


def _zoo_model(folder: Path) -> None:
    """What ``rl_zoo3.train --algo ppo --env rbenv/SatelliteReorient-v0`` leaves: a pickled SB3
    .zip and its VecNormalize statistics in a folder of the same name (untrained)."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import VecNormalize

    env_id = "rbenv/SatelliteReorient-v0"
    venv = VecNormalize(make_vec_env(env_id, n_envs=1))
    (folder / "rbenv-SatelliteReorient-v0").mkdir(parents=True)
    PPO("MlpPolicy", venv, n_steps=64, batch_size=64, device="cpu").save(
        folder / "rbenv-SatelliteReorient-v0.zip")
    venv.save(folder / "rbenv-SatelliteReorient-v0" / "vecnormalize.pkl")


@pytest.fixture(scope="module")
def world(tmp_path_factory):
    return World(tmp_path_factory.mktemp("world"))


def _files(root: Path) -> set[str]:
    """Every file and folder under ``root`` (links not followed)."""
    found = set()
    for folder, dirs, files in os.walk(root):
        found.update(os.path.relpath(os.path.join(folder, n), root) for n in (*dirs, *files))
    return found


# --- the tests --------------------------------------------------------------------------------

def test_the_pages_show_commands():
    kinds = {shlex.split(c)[0] for _, c in COMMANDS}
    assert len(COMMANDS) > 10 and any(p == "README.md" for p, _ in COMMANDS)
    assert {"train", "evaluate", "export", "replay"} <= kinds
    # the README's B-dot figure (issue 44), a table cell of docs/results.md
    assert any("--policy bdot" in c and p == "docs/results.md" for p, c in COMMANDS)


def test_every_line_listed_as_not_run_is_still_documented():
    assert set(NOT_RUN) <= set(COMMANDS)


@pytest.mark.parametrize(("page", "command"), COMMANDS, ids=[_id(c) for c in COMMANDS])
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


OUTPUTS = {"evaluate": ("--json", "--plot", "--video", "--out"), "replay": ("--json", "--plot"),
           "export": ("--out",)}


def _redirect(words: list[str], kind: str, tmp_path: Path) -> dict:
    """Point each output flag of ``words`` into ``tmp_path`` (in place); {flag: new path}."""
    moved = {}
    for i, word in enumerate(words[:-1]):
        if word in OUTPUTS.get(kind, ()):
            words[i + 1] = moved[word] = str(tmp_path / f"{word[2:]}-{Path(words[i + 1]).name}")
    return moved


RUNS = [item for item in COMMANDS
        if shlex.split(item[1])[0] in ("evaluate", "export", "replay", "train")]


@pytest.mark.slow
@pytest.mark.parametrize(("page", "command"), RUNS, ids=[_id(c) for c in RUNS])
def test_a_documented_command_runs(page, command, world, tmp_path, monkeypatch, capsys):
    """The line with its own arguments (evaluate: 2 episodes; train: --dry-run), in the shared
    folder; it writes only where its output flags were pointed, and that is read back."""
    if (page, command) in NOT_RUN:
        pytest.skip(NOT_RUN[(page, command)])
    words = shlex.split(command)
    kind = words[0]
    if "--engine rllib" in command and importlib.util.find_spec("ray") is None:
        pytest.skip(NEEDS_RAY)
    if kind == "replay":  # whatever folder the page names: the telemetry written here
        words[1] = str(world.telemetry)
    cwd = world.root
    if kind == "train" and "--resume" not in words:  # a new run: into an empty folder
        cwd = tmp_path / "cwd"
        cwd.mkdir()
        (cwd / "docs").symlink_to(ROOT / "docs", target_is_directory=True)
    try:
        argv = world.argv(words)
    except MissingExtraError as e:  # what the line needs is made with an extra not installed
        pytest.skip(str(e))
    if ".c" in {Path(w).suffix for w in argv} and shutil.which("cc") is None:
        pytest.skip("no C compiler (cc) to build an exported policy.c")
    moved = _redirect(argv, kind, tmp_path)
    if kind == "evaluate":
        argv += ["--episodes", "2"]
    if kind == "train":
        argv += ["--dry-run"]
    monkeypatch.chdir(cwd)
    before = _files(cwd)
    capsys.readouterr()
    try:
        assert cli.main(argv) == 0, f"{page}: `rbenv {command}` failed"
    except MissingExtraError as e:  # an install without that extra: the line says which
        pytest.skip(str(e))
    printed = capsys.readouterr().out
    assert _files(cwd) == before, f"{page}: `rbenv {command}` wrote outside its outputs"
    if kind == "train":
        assert "dry run: every check passed; nothing written" in printed
    elif kind == "evaluate":
        assert "| 2 |" in printed  # the table's episodes
        summary = moved.get("--json")
        if "--out" in moved:
            summary = Path(moved["--out"]) / "evaluation.json"
        if summary:
            assert json.loads(Path(summary).read_text())["episodes"] == 2
    elif kind == "export":
        out = Path(moved["--out"])
        formats = [argv[i + 1] for i, w in enumerate(argv) if w == "--format"] or ["c"]
        assert (out / "export.json").is_file()
        assert all((out / {"c": "policy.c", "onnx": "policy.onnx"}[f]).is_file()
                   for f in formats)
    else:  # replay: one record per slew of the telemetry
        if "--json" in moved:
            data = json.loads(Path(moved["--json"]).read_text())
            assert len(data["maneuvers"]) == 2
            assert all(math.isfinite(m["median_abs_error_diff_deg"]) for m in data["maneuvers"])


PARSED_ONLY = [item for item in COMMANDS if shlex.split(item[1])[0] in KINDS_NOT_RUN]


@pytest.mark.parametrize(("page", "command"), PARSED_ONLY, ids=[_id(c) for c in PARSED_ONLY])
def test_a_command_not_run_here_says_why(page, command):
    """bench, suite and identify lines parse (above) and are not run, for the reason listed."""
    assert KINDS_NOT_RUN[shlex.split(command)[0]]


@pytest.mark.parametrize("module", sorted({m for page in PAGES
                                          for m in MODULE.findall(page.read_text())
                                          if m != "rbenv"}))
def test_a_documented_module_exists(module):
    assert importlib.util.find_spec(module.rstrip(".")) is not None, module


# Pages the documentation site's build generates from the code (docs/_ext/rbenv_pages.py);
# the site's build itself fails on a link to one that does not exist (tests/docs).
GENERATED = [ROOT / "docs" / "reference" / name for name in ("envs", "scenes", "results")]


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_relative_links_resolve(page):
    missing = [t for t in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", page.read_text())
               if not t.startswith(("http://", "https://", "mailto:"))
               and not (page.parent / t).exists()
               and not any((page.parent / t).resolve().is_relative_to(g) for g in GENERATED)]
    assert not missing, missing
