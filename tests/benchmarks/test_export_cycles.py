"""benchmarks.export_cycles: the TRM cycle table, and an emulated Cortex-M4 call of an exported
policy that computes what the host's compiled C computes."""

from __future__ import annotations

import importlib.util
import json
import shutil

import numpy as np
import pytest
from rbenv.agents.policies import export as ex

from benchmarks import export_cycles as ec


@pytest.mark.parametrize(("mnemonic", "op_str", "taken", "expected"), [
    ("vadd.f32", "s14, s14, s15", False, 1), ("vmul.f32", "s15, s15, s13", False, 1),
    ("vfma.f32", "s0, s1, s2", False, 3), ("vmla.f32", "s0, s1, s2", False, 3),
    ("vdiv.f32", "s0, s15, s14", False, 14), ("vdivle.f32", "s15, s18, s16", False, 14),
    ("vsqrt.f32", "s0, s0", False, 14), ("vldr", "s15, [r3]", False, 2),
    ("vldmia", "r3!, {s13}", False, 2), ("vpush", "{s16, s17, s18}", False, 4),
    ("ldr", "r6, [pc, #408]", False, 2), ("push", "{r4, r5, r6, lr}", False, 5),
    ("pop", "{r4, r5, r6, pc}", True, 5 + ec.BRANCH_REFILL), ("bne.n", "7a", True, 3),
    ("bne.n", "7a", False, 1), ("adds", "r0, #1", False, 1), ("sdiv", "r0, r1, r2", False, 12),
])
def test_cycles_follow_the_cortex_m4_trm_tables(mnemonic, op_str, taken, expected):
    assert ec.cycles(mnemonic, op_str, taken) == expected


@pytest.mark.skipif(shutil.which("arm-none-eabi-gcc") is None
                    or importlib.util.find_spec("unicorn") is None
                    or importlib.util.find_spec("capstone") is None
                    or shutil.which("cc") is None,
                    reason="needs arm-none-eabi-gcc with newlib, cc, unicorn and capstone")
def test_an_emulated_call_matches_the_host_and_counts_every_multiply_add(tmp_path):
    """A small tanh network: the emulated Cortex-M4 returns the host C's action, and rbenv_policy
    spends at least one cycle per multiply-add plus a tanhf call per hidden unit."""
    rng = np.random.default_rng(0)
    layers = (ex.Dense(rng.normal(0, 0.5, (16, 7)).astype(np.float32),
                       rng.normal(0, 0.1, 16).astype(np.float32)), ex.Activation("tanh"),
              ex.Dense(rng.normal(0, 0.5, (3, 16)).astype(np.float32),
                       np.zeros(3, np.float32)))
    head = ex.Head("tanh_scale", -np.ones(3), np.ones(3))
    info = {"env_id": "rbenv/SatelliteReorient-v0", "scene": "cubesat-12u", "env_kwargs": {},
            "observation_layout": {"q_err": 4, "omega_B": 3}}
    flight = ex.FlightPolicy(7, np.zeros(7, np.float32), np.ones(7, np.float32), 10.0, layers,
                             head, info)
    ex.write_c(flight, tmp_path)
    fp = ex.footprint(flight)
    (tmp_path / "footprint.json").write_text(json.dumps(fp))
    (tmp_path / "export.json").write_text(json.dumps({**info, "obs_dim": 7, "act_dim": 3}))
    result = ec.measure(tmp_path, 3, ec.arm_tools())
    assert result["max_abs_diff_to_host_c"] <= 1e-6
    assert result["cycles_per_multiply_add"] >= 1
    assert result["cycles_by_function"]["tanhf"] > 0
    assert result["cycles_per_call"]["max"] > fp["multiply_adds"] + 19 * 10
    assert result["object_sections"][".rodata"] >= fp["weight_bytes"]
