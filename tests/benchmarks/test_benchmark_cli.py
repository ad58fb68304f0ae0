"""Every benchmark refuses an argument it does not know, before it measures anything.

A benchmark that ignored its arguments ran in full on ``--help`` (or a typo) and rewrote the
committed results in ``benchmarks/results``.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
MODULES = sorted(p.stem for p in (ROOT / "benchmarks").glob("*.py")
                 if '__name__ == "__main__"' in p.read_text())


@pytest.mark.slow
@pytest.mark.parametrize("module", MODULES)
def test_an_unknown_argument_is_an_error_not_a_run(module):
    done = subprocess.run([sys.executable, "-m", f"benchmarks.{module}", "--no-such-option"],
                          cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert done.returncode == 2, (module, done.stdout[-500:], done.stderr[-500:])
    # argparse's refusal: the unknown option, or a required one missing (ab_speed's --baseline)
    assert "error: unrecognized arguments: --no-such-option" in done.stderr or \
        "error: the following arguments are required" in done.stderr
