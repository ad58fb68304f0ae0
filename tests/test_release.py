"""The release as a user gets it: ``python -m build`` makes a wheel and an sdist that ``twine
check`` passes; the wheel, installed in a fresh venv away from the checkout, runs the README's
Quick start and a smoke-sized ``rbenv train`` with the scenes from inside the wheel. The version
is the changelog's newest, and CITATION.cff names it.

Offline: the build runs without isolation (setuptools from the test extra); the fresh venv gets
its dependencies (numpy, gymnasium, torch, SB3, ...) from this interpreter's site-packages
through a .pth file, with rbenv itself left out, so the rbenv it imports is the wheel's. Needs
the ``docs`` extra (build, twine); without it the module skips and says so.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
import sysconfig
import venv
import zipfile
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow  # builds the wheel and installs it in a new venv (CI runs it)

try:
    import tomllib
except ImportError:  # Python 3.10: the tomli dependency
    import tomli as tomllib

pytest.importorskip("build", reason="build is not installed (docs extra)")
pytest.importorskip("twine", reason="twine is not installed (docs extra)")

ROOT = Path(__file__).resolve().parents[1]
SOURCES = ("pyproject.toml", "README.md", "LICENSE", "CHANGELOG.md", "core", "rbenv", "agents")
IGNORE = shutil.ignore_patterns("__pycache__", "*.pyc", "*.egg-info")
VERSION = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]


@pytest.fixture(scope="module")
def dist(tmp_path_factory) -> Path:
    """The wheel and sdist, built offline from a copy of the checkout."""
    src, out = tmp_path_factory.mktemp("src"), tmp_path_factory.mktemp("dist")
    for name in SOURCES:
        path = ROOT / name
        if path.is_dir():
            shutil.copytree(path, src / name, ignore=IGNORE)
        else:
            shutil.copy2(path, src / name)
    done = subprocess.run([sys.executable, "-m", "build", "--no-isolation", "--sdist", "--wheel",
                           "--outdir", str(out), str(src)],
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    return out


def test_wheel_and_sdist_pass_twine_check(dist):
    wheel = dist / f"rbenv-{VERSION}-py3-none-any.whl"
    sdist = dist / f"rbenv-{VERSION}.tar.gz"
    assert wheel.exists() and sdist.exists(), sorted(p.name for p in dist.iterdir())
    done = subprocess.run([sys.executable, "-m", "twine", "check", "--strict", str(wheel),
                           str(sdist)], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    assert done.stdout.count("PASSED") == 2, done.stdout
    with zipfile.ZipFile(wheel) as z:
        scenes = [n for n in z.namelist() if n.startswith("rbenv/scenes/")]
    import rbenv

    assert sorted(Path(n).stem for n in scenes) == rbenv.list_scenes()
    print(f"wheel {wheel.name}: {wheel.stat().st_size / 1e3:.0f} kB")


def _dependency_view(tmp: Path) -> Path:
    """A folder of links to this interpreter's site-packages, rbenv's own entries left out."""
    site = Path(sysconfig.get_paths()["purelib"])
    view = tmp / "deps"
    view.mkdir()
    for entry in site.iterdir():
        name = entry.name.lower()
        if name.startswith(("rbenv", "__editable__")) or name.endswith(".pth"):
            continue
        (view / entry.name).symlink_to(entry)
    return view


def test_the_wheel_runs_the_quick_start_and_a_training_run_away_from_the_checkout(dist,
                                                                                   tmp_path):
    env_dir = tmp_path / "venv"
    venv.EnvBuilder(with_pip=False).create(env_dir)
    python = env_dir / "bin" / "python"
    purelib = subprocess.run([str(python), "-c",
                              "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                             capture_output=True, text=True, check=True).stdout.strip()
    wheel = dist / f"rbenv-{VERSION}-py3-none-any.whl"
    with zipfile.ZipFile(wheel) as z:
        z.extractall(purelib)  # what pip install --no-deps does for a pure wheel
    (Path(purelib) / "zz_dependencies.pth").write_text(str(_dependency_view(tmp_path)) + "\n")
    work = tmp_path / "user"
    work.mkdir()
    quick = _readme_quick_start()
    code = quick + (
        "\nimport rbenv, pathlib\n"
        "print('RBENV', pathlib.Path(rbenv.__file__).parent, rbenv.__version__,"
        " len(rbenv.list_scenes()))\n")
    done = subprocess.run([str(python), "-c", code], cwd=work, capture_output=True, text=True,
                          timeout=600, env={"PATH": "/usr/bin:/bin", "MPLBACKEND": "Agg",
                                            "SDL_VIDEODRIVER": "dummy"})
    assert done.returncode == 0, done.stderr[-3000:]
    where, version, scenes = done.stdout.split("RBENV ")[1].split()
    assert where == str(Path(purelib) / "rbenv")  # the wheel's rbenv, not the checkout's
    assert version == VERSION and int(scenes) == 7
    run = work / "run"
    done = subprocess.run([str(python), "-m", "rbenv", "train", "--timesteps", "2048",
                           "--n-envs", "8", "--eval-episodes", "4", "--report-episodes", "8",
                           "--no-progress", "--out", str(run)],
                          cwd=work, capture_output=True, text=True, timeout=600,
                          env={"PATH": "/usr/bin:/bin", "MPLBACKEND": "Agg"})
    assert done.returncode == 0, done.stderr[-3000:]
    assert (run / "policy.pt").exists() and (run / "report.md").exists()
    # benchmarks/ is not in the wheel: its command line has no bench, and says so.
    done = subprocess.run([str(python), "-m", "rbenv", "bench", "inertia"], cwd=work,
                          capture_output=True, text=True, timeout=300,
                          env={"PATH": "/usr/bin:/bin"})
    assert done.returncode == 2 and "benchmarks of a source checkout" in done.stderr, \
        done.stderr[-3000:]


def _readme_quick_start() -> str:
    """The README's Quick start Python block."""
    text = (ROOT / "README.md").read_text()
    section = text[text.index("## Quick start"):]
    return re.search(r"```python\n(.*?)```", section, re.S).group(1)


def test_version_changelog_and_citation_agree():
    import rbenv

    assert rbenv.__version__ == VERSION or rbenv.__version__.startswith("0.0.0")
    changelog = (ROOT / "CHANGELOG.md").read_text()
    releases = re.findall(r"^## \[(\d+\.\d+\.\d+)\]", changelog, re.M)
    assert releases[0] == VERSION, releases
    assert "## [Unreleased]" in changelog
    for section in ("### Added", "### Changed"):
        assert section in changelog.split(f"## [{releases[1]}]")[0]
    cff = (ROOT / "CITATION.cff").read_text()
    assert re.search(rf"^version: {re.escape(VERSION)}$", cff, re.M)
    assert re.search(r"^cff-version: 1\.2\.0$", cff, re.M)


def test_readme_stays_short_and_names_every_scene():
    import rbenv

    text = (ROOT / "README.md").read_text()
    assert len(text.splitlines()) <= 150
    quick = _readme_quick_start()
    for scene in rbenv.list_scenes():
        assert re.search(rf"[\s,]{re.escape(scene)}(,|\n)", quick), scene
    assert "benchmarks/results/accuracy.png" in text and (ROOT / "benchmarks" / "results" /
                                                          "accuracy.png").exists()
