"""The robustness benchmark: size map, same episodes in every condition, --quick end to end."""

from __future__ import annotations

import argparse
import json
from dataclasses import fields

import numpy as np
import pytest

from benchmarks import robustness as rb
from rbenv.satellite.draws import EpisodeDraws
from rbenv.satellite.plant import make_plant
from rbenv.satellite.randomization import ACTUATOR_FIELDS, Randomization, draw_episode_model

pytestmark = pytest.mark.slow  # trains and evaluates (CI runs it)

EPISODES = 20


def test_size_map_sets_every_field_and_one_kind_sets_only_its_own():
    assert rb.randomize_at(0.0) == {f: 0.0 for f in rb.randomize_at(0.3)}
    assert not Randomization.from_mapping(rb.randomize_at(0.0)).enabled
    full = rb.randomize_at(0.3)
    # Every field a thruster scene takes (the wheel and rod fields are refused on it), so
    # the dict replaces the scene's table.
    others = {f for f, (table, _) in ACTUATOR_FIELDS.items() if table != "thrusters"}
    assert set(full) == {f.name for f in fields(Randomization)} - others
    assert full["inertia_scale"] == full["force_scale"] == full["delay_probability"] == 0.3
    assert full["com_offset"] == pytest.approx(0.3 * rb.HALF_WIDTH_M)
    assert full["misalignment_deg"] == pytest.approx(9.0)
    for kind, names in rb.KINDS.items():
        one = rb.randomize_at(0.3, (kind,))
        assert {f for f, v in one.items() if v} == set(names)
    with pytest.raises(ValueError, match="kinds"):
        rb.randomize_at(0.1, ("gravity",))
    assert [c.size for c in rb.CONDITIONS if c.kinds == "all"] == list(rb.SIZES)


def test_sizes_scale_one_common_draw_of_the_physics():
    """Episode i meets the same perturbation direction at every size, scaled by the size."""
    draws = EpisodeDraws(np.arange(200) + rb.EVAL_SEED, np.zeros(200))
    models = {s: draw_episode_model(make_plant(rb.SCENE, randomize=rb.randomize_at(s)), draws)
              for s in (0.1, 0.2)}
    np.testing.assert_allclose(models[0.2].com_offset_B, 2 * models[0.1].com_offset_B,
                               rtol=1e-12)
    force = {s: m.action_matrix[:, :, 3] for s, m in models.items()}
    nominal = make_plant(rb.SCENE).scene.thrusters.max_force
    np.testing.assert_allclose(force[0.2] / nominal - 1, 2 * (force[0.1] / nominal - 1),
                               atol=1e-12)
    assert np.abs(force[0.2] / nominal - 1).max() <= 0.2 + 1e-12
    offset = np.linalg.norm(models[0.2].com_offset_B, axis=1)
    assert offset.max() <= 0.2 * rb.HALF_WIDTH_M + 1e-15 and offset.max() > 0.15 * rb.HALF_WIDTH_M


def _arrays(result):
    return {k: getattr(result, k) for k in ("success", "settle_time_s", "fuel_kg",
                                            "final_error_deg", "episode_time_s")}


@pytest.mark.parametrize("name", ["pd", "bangbang"])
def test_size_zero_is_the_nominal_env_episode_for_episode(name):
    from rbenv.agents.policies.evaluate import evaluate

    zero = next(c for c in rb.CONDITIONS if c.name == "all-0")
    ours = rb.evaluate_policy(rb.PolicySpec(name), zero, EPISODES, rb.EVAL_SEED)
    nominal = evaluate(name, episodes=EPISODES, seed=rb.EVAL_SEED, scene=rb.SCENE, record=0,
                       env_id=rb.ENV_ID)
    for key, value in _arrays(nominal).items():
        np.testing.assert_array_equal(_arrays(ours)[key], value, err_msg=key)


def test_perturbation_changes_the_physics_of_the_same_episodes():
    from rbenv.agents.policies.evaluate import evaluate

    big = next(c for c in rb.CONDITIONS if c.name == "all-0.3")
    perturbed = rb.evaluate_policy(rb.PolicySpec("bangbang"), big, EPISODES, rb.EVAL_SEED)
    nominal = evaluate("bangbang", episodes=EPISODES, seed=rb.EVAL_SEED, scene=rb.SCENE,
                       record=0, env_id=rb.ENV_ID)
    # Same starts (the perturbation has its own draws), different outcomes.
    assert not np.array_equal(perturbed.fuel_kg, nominal.fuel_kg)
    assert np.mean(perturbed.fuel_kg) > np.mean(nominal.fuel_kg)  # deadbeat law on a wrong model


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("robustness")
    args = rb.add_arguments(argparse.ArgumentParser()).parse_args(
        ["--quick", "--out", str(out), "--suite", str(out / "no-suite")])
    return out, args, rb.main(args)


@pytest.mark.slow  # trains a tiny PPO
def test_quick_run_writes_every_policy_and_condition(quick):
    out, _, data = quick
    assert data["missing"] == ["ppo-reorient-cubesat-12u-seed0",
                               "ppo-reorient-cubesat-12u-dr-seed0"]
    assert list(data["conditions"]) == [c.name for c in rb.CONDITIONS]
    for cond in data["conditions"].values():
        assert set(cond["policies"]) == {"pd", "pd-wn0.5", "pd-wn0.8", "bangbang",
                                         rb.randomized_group(4096), rb.randomized_group(8192)}
        for stats in cond["policies"].values():
            assert 0.0 <= stats["success_rate"]["mean"] <= 1.0
            assert stats["fuel_g"]["mean"] > 0.0
    record = json.loads(rb.train_record(out, 0, 8192).read_text())
    assert record["randomize"] == rb.randomize_at(rb.TRAIN_SIZE)
    config = json.loads((rb.run_dir(out, 0, 8192) / "config.json").read_text())
    assert config["env_kwargs"] == {"randomize": rb.randomize_at(rb.TRAIN_SIZE)}
    assert record["selected_timesteps"] in record["validation"]["curve"]["timesteps"]
    # The larger budget continued the smaller one's run: its early checkpoints are that run's.
    assert record["continued_from"] == rb.run_dir(out, 0, 4096).name
    assert record["validation"]["curve"]["timesteps"] == [4096, 8192]
    evals = json.loads(rb.eval_record(out, rb.PolicySpec("pd"), rb.CONDITIONS[0]).read_text())
    assert len(evals["success"]) == EPISODES
    md = (out / "robustness.md").read_text()
    assert "| all, s = 0.3 |" in md and "PPO, trained at s = 0.3" in md
    assert (out / "robustness.png").stat().st_size > 0
    assert json.loads((out / "robustness.json").read_text())["conditions"] == data["conditions"]


def test_quick_run_resumes_from_its_json_without_training_or_evaluating(quick, monkeypatch):
    _, args, data = quick

    def refuse(*_a, **_k):
        raise AssertionError("recomputed a cached result")

    monkeypatch.setattr("rbenv.agents.training.sb3.train", refuse)
    monkeypatch.setattr(rb, "evaluate_policy", refuse)
    again = rb.main(args)
    assert again["conditions"] == data["conditions"]
