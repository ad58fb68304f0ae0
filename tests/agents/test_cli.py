"""The rbenv command: writes only what is asked, imports torch only for models, named errors."""

import json
import os
import shutil
import subprocess
import sys

import pytest
from rbenv.agents import cli


def test_evaluate_writes_nothing_unless_asked(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["evaluate", "--policy", "pd", "--episodes", "3"]) == 0
    assert "| pd | 3 | 100.0%" in capsys.readouterr().out
    assert list(tmp_path.iterdir()) == []


def test_evaluate_out_folder_gets_the_summary_and_the_plot(tmp_path):
    out = tmp_path / "eval"
    assert cli.main(["evaluate", "--policy", "bangbang", "--episodes", "2", "--out",
                     str(out)]) == 0
    assert json.loads((out / "evaluation.json").read_text())["episodes"] == 2
    assert (out / "episodes.png").stat().st_size > 1000


@pytest.mark.slow
def test_evaluating_a_baseline_imports_no_torch_sb3_or_matplotlib():
    code = ("import sys; from rbenv.agents.cli import main; "
            "main(['evaluate', '--policy', 'pd', '--episodes', '4']); "
            "print(sorted(m for m in ('torch', 'stable_baselines3', 'matplotlib') "
            "if m in sys.modules))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().splitlines()[-1] == "[]"


@pytest.mark.slow
def test_a_documented_error_is_printed_without_a_traceback(tmp_path):
    done = subprocess.run([sys.executable, "-m", "rbenv.agents.cli", "train", "--resume", "--out",
                           str(tmp_path)], capture_output=True, text=True, timeout=120)
    assert done.returncode == 2
    assert done.stderr.startswith("rbenv train: error: ") and "is not a training run" in done.stderr
    assert "Traceback" not in done.stderr


def test_bad_json_option_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as exit_:
        cli.main(["train", "--env-kwargs", "{nope"])
    assert exit_.value.code == 2 and "not valid JSON" in capsys.readouterr().err


def test_bench_lists_every_benchmark_module():
    names = cli.benchmarks()
    assert {"accuracy", "train_speed"} <= set(names) and "common" not in names


def test_bench_writes_under_out(tmp_path, monkeypatch):
    """`rbenv bench NAME --out DIR` runs the checkout's benchmark module in a child process,
    which writes through benchmarks.common into DIR, without importing benchmarks here."""
    checkout = tmp_path / "checkout"
    (checkout / "benchmarks").mkdir(parents=True)
    (checkout / "benchmarks" / "__init__.py").write_text("")
    shutil.copy(cli.CHECKOUT / "benchmarks" / "common.py", checkout / "benchmarks" / "common.py")
    (checkout / "benchmarks" / "fake_bench.py").write_text(
        "from benchmarks import common\n"
        "if __name__ == '__main__':\n"
        "    common.write_json('fake_bench', {'value': 1})\n")
    monkeypatch.setattr(cli, "CHECKOUT", checkout)
    assert cli.benchmarks() == ["fake_bench"]
    assert cli.main(["bench", "fake_bench", "--out", str(tmp_path / "res")]) == 0
    assert json.loads((tmp_path / "res" / "fake_bench.json").read_text())["value"] == 1


def test_an_install_without_benchmarks_has_no_bench_command_and_says_why(tmp_path,
                                                                        monkeypatch, capsys):
    monkeypatch.setattr(cli, "CHECKOUT", tmp_path)  # an install: no benchmarks/ beside rbenv
    assert cli.benchmarks() == []
    with pytest.raises(SystemExit) as exit_:
        cli.main(["bench", "inertia"])
    err = " ".join(capsys.readouterr().err.split())
    assert exit_.value.code == 2 and "benchmarks of a source checkout" in err
    assert "python -m benchmarks.NAME" in err
    with pytest.raises(SystemExit):
        cli.main(["--help"])
    listed = capsys.readouterr().out.split("{", 1)[1].split("}", 1)[0].split(",")
    assert "evaluate" in listed and "bench" not in listed


def test_help_states_where_files_go(capsys):
    for command in ("evaluate", "bench", "train"):
        with pytest.raises(SystemExit):
            cli.main([command, "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "current directory" in text and "--plot PATH" in text and "--threads" in text


def test_bench_finds_rbenv_benchmarks_when_another_benchmarks_folder_shadows_it(tmp_path):
    # torchrl's wheel installs a top-level `benchmarks` folder (a namespace package).
    (tmp_path / "benchmarks").mkdir()
    (tmp_path / "benchmarks" / "foreign_bench.py").write_text("def main(): pass\n")
    code = "from rbenv.agents.cli import benchmarks; print(benchmarks())"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=tmp_path, timeout=60, env={**os.environ, "PYTHONPATH": str(tmp_path)})
    assert done.returncode == 0, done.stderr
    assert "train_speed" in done.stdout and "foreign_bench" not in done.stdout
