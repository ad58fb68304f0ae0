"""What the benchmarks write stays small: compact JSON, palette PNGs, findings-only fuzz records,
and the committed results under 3 MB."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from benchmarks import common

ROOT = Path(__file__).resolve().parents[2]
LIMIT_BYTES = 3_000_000  # issue 42: committed results under 3 MB


def test_dumps_is_json_with_a_list_of_numbers_on_one_line():
    data = {"curve": [0.5, 1e-300, -2, None, "x"], "empty": {}, "none": [],
            "rows": [{"a": [1, 2], "b": {"c": True}}, [3.25, 4]], "third": 1.0 / 3.0}
    text = common.dumps(data)
    assert json.loads(text) == data
    assert '"curve": [0.5, 1e-300, -2, null, "x"]' in text.splitlines()[1]
    assert len(text.splitlines()) == 15


def test_save_figure_writes_a_palette_png_with_the_lines_colours_exact(tmp_path, monkeypatch):
    plt = pytest.importorskip("matplotlib.pyplot")
    from PIL import Image

    monkeypatch.setattr(common, "RESULTS", tmp_path)
    fig, ax = common.pyplot().subplots(figsize=(4, 3))
    colours = ["#1f77b4", "#ff7f0e", "#2ca02c"]
    for i, c in enumerate(colours):
        ax.plot(np.linspace(0, 1, 50), np.sin(np.linspace(0, 6, 50) + i), color=c, lw=3)
    path = common.save_figure(fig, "figure")
    plt.close(fig)
    with Image.open(path) as im:
        assert im.mode == "P"
        rgb = {tuple(c) for c in np.asarray(im.convert("RGB")).reshape(-1, 3)}
    for c in colours:
        assert tuple(int(c[k:k + 2], 16) for k in (1, 3, 5)) in rgb, c


def test_fuzz_lists_the_findings_unless_asked_for_every_probe(tmp_path):
    def run(*extra):
        out = tmp_path / f"fuzz{len(extra)}.json"
        done = subprocess.run([sys.executable, "benchmarks/fuzz.py", "--rows",
                               "env at numerical extremes", "--out", str(out), *extra],
                              cwd=ROOT, capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stderr[-2000:]
        return json.loads(out.read_text())

    findings, every = run(), run("--all-probes")
    row = every["rows"]["env at numerical extremes"]
    counted = Counter(p["class"] for p in every["probes"])
    assert len(every["probes"]) == row["tried"] > 0
    assert all(counted[k] == row[k] for k in counted)
    assert findings["rows"] == every["rows"]
    assert findings["probes"] == [p for p in every["probes"]
                                  if p["class"] not in ("clear error", "accepted, finite")]


def test_the_committed_results_stay_under_3_mb():
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    done = subprocess.run(["git", "ls-files", "-z", "benchmarks/results"], cwd=ROOT,
                          capture_output=True, check=True)
    files = [ROOT / f for f in done.stdout.decode().split("\0") if f]
    total = sum(f.stat().st_size for f in files if f.is_file())
    assert len(files) > 100 and total < LIMIT_BYTES, total
