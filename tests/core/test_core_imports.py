"""rbenv.core runs without the learning stack; what its modules import is checked statically
(tests/test_layers.py: only NumPy, SciPy in core.reference, numba in core.compiled)."""

import subprocess
import sys


def test_core_runs_without_learners_renderers_or_agents():
    code = (
        "import sys, numpy as np\n"
        "from rbenv.core import inertia, quaternion, RigidBody, BodyState, simulate\n"
        "body = RigidBody(mass=1.0, inertia=inertia.solid_box(1.0, (1, 2, 3)))\n"
        "simulate(body, BodyState(angular_velocity=[0.1, 0.2, 0.3]), 0.1, 10)\n"
        "forbidden = ('torch', 'stable_baselines3', 'rbenv.agents', 'pygame', 'matplotlib',\n"
        "             'numba', 'ray')\n"
        "bad = [m for m in forbidden if m in sys.modules]\n"
        "assert not bad, bad\n"
        "print('ok')\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "ok"
