"""Activations by name (rbenv.agents.policies.activations): NumPy's tanh is torch's function,
to the last place, with torch's gradient; names survive a model file and reach export."""

import numpy as np
import pytest

torch = pytest.importorskip("torch")
pytest.importorskip("stable_baselines3")

from rbenv.agents.policies import activations as act  # noqa: E402
from rbenv.agents.policies import export as ex  # noqa: E402
from rbenv.agents.policies import weights  # noqa: E402
from rbenv.core.errors import InvalidParameterError  # noqa: E402

EXTREMES = [0.0, -0.0, 1e-30, -1e-10, 1e-4, 0.5, 9.0, 20.0, -20.0, 1e4, float("inf"),
            float("-inf")]


@pytest.mark.parametrize("dtype", [torch.float32, torch.float64])
def test_tanh_is_torchs_to_one_unit_in_the_last_place(dtype):
    gen = torch.Generator().manual_seed(0)
    x = torch.cat([torch.randn(100_000, generator=gen, dtype=dtype) * 6,
                   torch.tensor(EXTREMES, dtype=dtype)])
    fast, ref = act.Tanh()(x), torch.tanh(x)
    assert fast.dtype == dtype and fast.shape == x.shape
    eps, tiny = torch.finfo(dtype).eps, torch.finfo(dtype).tiny
    assert ((fast - ref).abs() <= eps * ref.abs().clamp_min(tiny)).all()
    assert torch.equal(fast[-2:], torch.tensor([1.0, -1.0], dtype=dtype))
    assert torch.isnan(act.Tanh()(torch.tensor([float("nan")], dtype=dtype))).all()


@pytest.mark.slow
def test_tanh_gradient_is_torchs():
    x = torch.randn(64, 64, dtype=torch.float64, requires_grad=True)
    assert torch.autograd.gradcheck(act.Tanh(), (x,))
    act.Tanh()(x).pow(2).sum().backward()
    fast = x.grad.clone()
    x.grad = None
    torch.tanh(x).pow(2).sum().backward()
    assert torch.allclose(fast, x.grad, rtol=1e-12, atol=1e-15)


def test_tanh_of_a_non_contiguous_or_half_tensor():
    x = torch.randn(8, 6).t()  # not contiguous
    assert torch.allclose(act.Tanh()(x), torch.tanh(x), rtol=2e-7, atol=0)
    h = torch.randn(10).half()  # NumPy is not asked: torch's own tanh
    assert torch.equal(act.Tanh()(h), torch.tanh(h))


def test_names_and_classes_round_trip_and_an_unknown_name_is_refused():
    kwargs = {"net_arch": [64, 64], "activation_fn": "tanh"}
    classes = act.to_classes(kwargs)
    assert classes["activation_fn"] is act.Tanh and kwargs["activation_fn"] == "tanh"
    assert act.to_names(classes) == kwargs
    assert act.to_names({"activation_fn": torch.nn.Tanh})["activation_fn"] == "tanh"
    assert act.to_classes({"net_arch": [8]}) == {"net_arch": [8]}
    with pytest.raises(InvalidParameterError, match=r"activation_fn.*'swish'"):
        act.to_classes({"activation_fn": "swish"})


def _ppo(**policy_kwargs):
    import gymnasium as gym
    from stable_baselines3 import PPO

    import rbenv

    env = gym.make(rbenv.ENV_ID, max_initial_angle_deg=30.0)
    return PPO("MlpPolicy", env, policy_kwargs=act.to_classes(policy_kwargs), device="cpu",
               seed=3, n_steps=64, batch_size=64)


def test_a_model_file_names_its_activation_and_loads_it_back(tmp_path):
    model = _ppo(net_arch=[16, 16], activation_fn="tanh")
    weights.save_model(model, tmp_path / "policy.pt")
    config = weights.read_config(tmp_path / "policy.json")
    assert config["policy_kwargs"]["activation_fn"] == "tanh"
    loaded = weights.load_model(tmp_path / "policy.pt")
    assert any(isinstance(m, act.Tanh) for m in loaded.policy.modules())
    obs = np.random.default_rng(0).uniform(-1, 1, (32, *model.observation_space.shape))
    a, _ = model.predict(obs.astype(np.float32), deterministic=True)
    b, _ = loaded.predict(obs.astype(np.float32), deterministic=True)
    np.testing.assert_array_equal(a, b)


def test_torchs_tanh_and_numpys_act_alike_on_the_same_weights():
    fast, ref = _ppo(net_arch=[64, 64], activation_fn="tanh"), _ppo(net_arch=[64, 64])
    ref.policy.load_state_dict(fast.policy.state_dict())
    obs = torch.as_tensor(np.random.default_rng(1).uniform(
        -1, 1, (256, *fast.observation_space.shape)), dtype=torch.float32)
    with torch.no_grad():
        a = fast.policy.get_distribution(obs).distribution.mean
        b = ref.policy.get_distribution(obs).distribution.mean
    assert torch.allclose(a, b, rtol=0, atol=1e-6)


def test_export_reads_the_fast_tanh_as_tanh():
    layers = ex._layers([_ppo(net_arch=[8, 8], activation_fn="tanh").policy.mlp_extractor
                         .policy_net])
    assert [type(x).__name__ for x in layers] == ["Dense", "Activation", "Dense", "Activation"]
    assert {x.kind for x in layers if isinstance(x, ex.Activation)} == {"tanh"}
