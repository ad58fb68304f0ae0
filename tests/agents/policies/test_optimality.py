"""Optimality in every evaluation: settle time and propellant as ratios to the per-episode lower
bounds where the scene has them, and a plain statement where it has none."""

from __future__ import annotations

import json

import numpy as np
import pytest
from rbenv.agents.baselines import bounds as rb
from rbenv.agents.cli import main
from rbenv.agents.policies import optimality
from rbenv.agents.policies.evaluate import evaluate, format_table

import rbenv

SEED = 1_000_000


@pytest.fixture(scope="module")
def pd_and_bangbang():
    return [evaluate(name, episodes=24, seed=SEED) for name in ("pd", "bangbang")]


def test_no_policy_beats_a_bound(pd_and_bangbang):
    """A ratio below 1 would disprove a bound (a bound above an achieved value is a bug)."""
    for r in pd_and_bangbang:
        per = r.optimality_per_episode
        for name in ("settle_ratio", "fuel_ratio", "fuel_ratio_own_time"):
            v = np.asarray(per[name], float)
            assert np.isfinite(v).sum() >= 20, name
            assert np.nanmin(v) >= 1.0, (r.policy, name, np.nanmin(v))


def test_ratios_equal_the_bounds_computed_directly(pd_and_bangbang):
    """The same episodes' bounds from rbenv.agents.baselines.bounds, by hand, give the same
    ratios."""
    limits = rb.scene_limits("cubesat-12u")
    starts = rb.episode_starts(24, SEED, env_id=rbenv.ENV_ID)
    settle = rb.settle_time_bound(limits, starts["angle"], starts["omega_B"],
                                  starts["bias_B"])["sampled"]
    fuel = rb.fuel_bound(limits, starts["angle"], starts["omega_B"], starts["bias_B"])["kg"]
    for r in pd_and_bangbang:
        ok = r.success
        np.testing.assert_allclose(r.optimality_per_episode["settle_ratio"][ok],
                                   r.settle_time_s[ok] / settle[ok], rtol=1e-12)
        keep = ok & (fuel > 0)
        np.testing.assert_allclose(r.optimality_per_episode["fuel_ratio"][keep],
                                   r.fuel_kg[keep] / fuel[keep], rtol=1e-12)
        s = r.summary()["optimality"]
        assert s["settle_ratio"]["median"] == pytest.approx(
            float(np.median(r.settle_time_s[ok] / settle[ok])))
        assert len(s["per_episode"]["settle_ratio"]) == 24


def test_the_baselines_sit_where_docs_bounds_puts_them(pd_and_bangbang):
    """docs/bounds.md on 500 episodes: PD 2.63× the settle bound, bang-bang 2.00×."""
    pd, bb = (r.summary()["optimality"]["settle_ratio"]["median"] for r in pd_and_bangbang)
    assert 2.4 < pd < 2.9 and 1.85 < bb < 2.2
    table = format_table(pd_and_bangbang)
    assert "| settle / bound | fuel / bound |" in table
    assert "Optimality: medians over successful episodes" in table


@pytest.mark.parametrize(("env_id", "kwargs", "reason"), [
    (rbenv.TRACK_ID, {}, "the bounds cover reorientation and detumbling"),
    (rbenv.DESATURATE_ID, {}, "the bounds cover reorientation and detumbling"),
    (rbenv.ENV_ID, {"scene": "boom-sat"}, "disturbance noise"),
    (rbenv.ENV_ID, {"randomize": {"inertia_scale": 0.1}}, "randomizes the model"),
    (rbenv.ENV_ID, {"scene": "cubesat-12u-dr"}, "randomizes the model"),
])
def test_where_no_bound_holds_the_evaluation_says_why(env_id, kwargs, reason):
    r = evaluate("pd", episodes=2, seed=0, env_id=env_id, env_kwargs=kwargs)
    assert r.optimality["defined"] is False and reason in r.optimality["reason"]
    assert r.optimality_per_episode == {}
    assert f"Optimality: no lower bounds here: {r.optimality['reason']}" in format_table([r])
    assert isinstance(optimality.episode_bounds(2, 0, env_id, kwargs), str)


def test_the_evaluate_json_carries_the_ratios_episode_by_episode(tmp_path, capsys):
    out = tmp_path / "pd.json"
    assert main(["evaluate", "--policy", "pd", "--episodes", "6", "--seed", str(SEED),
                 "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    data = data[0] if isinstance(data, list) else data
    opt = data["optimality"]
    assert opt["defined"] is True
    assert len(opt["per_episode"]["settle_bound_s"]) == 6
    assert all(v is None or v >= 1.0 for v in opt["per_episode"]["settle_ratio"])
    assert "settle / bound" in capsys.readouterr().out


@pytest.mark.parametrize(("env_id", "scene", "which"), [
    (rbenv.ENV_ID, "cubesat-6u-rw", "reorient: energy-rate settle bound"),
    (rbenv.DETUMBLE_ID, "cubesat-12u", "detumble: settle and propellant bounds"),
])
def test_wheels_and_detumbling_have_their_settle_bounds(env_id, scene, which):
    r = evaluate("pd", episodes=4, seed=SEED, env_id=env_id, scene=scene)
    assert r.optimality["defined"] and r.optimality["bounds"]["which"].startswith(which)
    assert ("fuel_ratio" in r.optimality_per_episode) == ("propellant" in which)
