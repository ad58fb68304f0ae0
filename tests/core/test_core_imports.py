"""core depends on NumPy only: no gymnasium, no rbenv, and SciPy only via core.reference."""

import subprocess
import sys


def test_core_imports_numpy_only():
    code = (
        "import sys, core, numpy as np\n"
        "from core import inertia, quaternion, RigidBody, BodyState, simulate\n"
        "body = RigidBody(mass=1.0, inertia=inertia.solid_box(1.0, (1, 2, 3)))\n"
        "simulate(body, BodyState(angular_velocity=[0.1, 0.2, 0.3]), 0.1, 10)\n"
        "forbidden = ('gymnasium', 'scipy', 'rbenv', 'agents', 'torch')\n"
        "bad = [m for m in forbidden if m in sys.modules]\n"
        "assert not bad, bad\n"
        "import core.reference\n"
        "assert 'scipy' in sys.modules and 'gymnasium' not in sys.modules\n"
        "print('ok')\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "ok"
