"""One vector contract (rbenv.envs.vector) for both backends: the NumPy and the torch vector
env (CPU, float64) return the same info, masks and final entries.

Same seeds, same actions, in each autoreset mode, with a masked reset in the middle of the run
(and in DISABLED after each end): the info of both has the same keys (torch adds
``diverged``, its sticky divergence flag, with its mask), the same ``_key`` masks, values
equal within 1e-12, and on the SAME_STEP steps where sub-envs end the same ``final_obs`` rows
and ``final_info`` (every key, zero where a sub-env did not end); on a SAME_STEP step where no
sub-env ended the NumPy env has no final entries and the torch env has them with every mask
False (its documented layout: no host read). Observations and rewards
agree within 1e-12 as well (tests/rbenv/test_torch_env.py checks the episodes in depth).
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import rbenv

torch = pytest.importorskip("torch", reason="torch is not installed (train extra)")

N, EPISODE, STEPS = 4, 5, 18
MASK = np.array([True, False, True, False])
TORCH_ONLY = {"diverged", "_diverged"}  # the torch env's divergence flag (module doc)
FINAL_MASKS = ("_final_obs", "_final_info")
FINALS = {"final_obs", "final_info", *FINAL_MASKS}


def _values(value) -> np.ndarray:
    if isinstance(value, torch.Tensor):
        value = value.cpu().numpy()
    return np.asarray(value, dtype=float)


def _same_info(info_t: dict, info_n: dict, where: str) -> None:
    """Equal keys (torch's own aside), equal masks, equal values (float64 round-off)."""
    if "final_info" in info_t and "final_info" not in info_n:  # SAME_STEP, no sub-env ended
        for key in FINAL_MASKS:
            assert not info_t[key].any(), f"{where} {key}"
        assert not any(info_t["final_info"][k].any() for k in info_t["final_info"]
                       if k.startswith("_")), where
        info_t = {k: v for k, v in info_t.items() if k not in FINALS}
    assert set(info_t) - TORCH_ONLY == set(info_n), where
    for key, want in info_n.items():
        got = info_t[key]
        what = f"{where} info[{key!r}]"
        if key == "final_info":
            _same_info(got, want, f"{where} final_info")
        elif key == "final_obs":
            rows = np.flatnonzero(info_n["_final_obs"])
            assert len(rows), what
            for i in rows:
                np.testing.assert_allclose(_values(got[i]), want[i].astype(float), rtol=0,
                                           atol=1e-6, err_msg=f"{what} row {i}")  # float32
        elif key.startswith("_"):
            assert isinstance(got, torch.Tensor) and got.dtype == torch.bool, what
            assert got.tolist() == want.tolist(), what
        else:
            np.testing.assert_allclose(_values(got), _values(want), rtol=0, atol=1e-12,
                                       err_msg=what)


@pytest.mark.parametrize("mode", list(AutoresetMode), ids=lambda m: m.value)
def test_numpy_and_torch_return_the_same_info_masks_and_final_entries(mode):
    kwargs = {"max_episode_steps": EPISODE, "autoreset_mode": mode}
    ne = gym.make_vec(rbenv.ENV_ID, num_envs=N, **kwargs)
    te = gym.make_vec(rbenv.ENV_ID, num_envs=N, backend="torch", **kwargs)
    obs_n, info_n = ne.reset(seed=3)
    obs_t, info_t = te.reset(seed=3)
    _same_info(info_t, info_n, "reset")
    assert info_n["_is_success"].all()
    rng = np.random.default_rng(1)
    ended = finals = 0
    for t in range(STEPS):
        action = rng.uniform(-1.2, 1.2, ne.action_space.shape)
        obs_n, r_n, term_n, trunc_n, info_n = ne.step(action)
        obs_t, r_t, term_t, trunc_t, info_t = te.step(torch.as_tensor(action))
        where = f"step {t}"
        np.testing.assert_allclose(_values(obs_t), obs_n.astype(float), rtol=0, atol=1e-6,
                                   err_msg=f"{where} obs")  # the NumPy env's obs is float32
        np.testing.assert_allclose(_values(r_t), r_n, rtol=0, atol=1e-12,
                                   err_msg=f"{where} reward")
        assert term_t.tolist() == term_n.tolist() and trunc_t.tolist() == trunc_n.tolist()
        _same_info(info_t, info_n, where)
        done = term_n | trunc_n
        ended += int(done.sum())
        finals += "final_info" in info_n
        if mode is AutoresetMode.SAME_STEP:
            assert ("final_info" in info_n) == bool(done.any()), where
        if mode is AutoresetMode.DISABLED and done.any():
            _, info_n = ne.reset(options={"reset_mask": done})
            _, info_t = te.reset(options={"reset_mask": torch.as_tensor(done)})
            _same_info(info_t, info_n, f"{where} reset of {done.tolist()}")
            assert info_n["_is_success"].tolist() == done.tolist()
        if t == 2:  # a masked reset in every mode, the NumPy mask given to both
            _, info_n = ne.reset(options={"reset_mask": MASK})
            _, info_t = te.reset(options={"reset_mask": MASK})
            _same_info(info_t, info_n, f"{where} masked reset")
            assert info_t["_is_success"].tolist() == MASK.tolist()
            assert (_values(info_t["time_s"])[~MASK] == 0).all()
    assert ended >= N, "the run would not cross autoresets"
    assert (finals > 0) == (mode is AutoresetMode.SAME_STEP)
