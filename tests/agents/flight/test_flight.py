"""rbenv replay and rbenv identify on telemetry these tests make: a flight flown in rbenv by the
flight PD (an independent loop over a single env), written in the dashboard's CSV format."""

from __future__ import annotations

import json
import math
from datetime import datetime

import gymnasium as gym
import numpy as np
import pytest
from rbenv.agents.baselines.controllers import InnoCubePD
from rbenv.agents.cli import main
from rbenv.agents.flight import identify, replay
from rbenv.agents.flight.telemetry import Telemetry, load, write_folder

import rbenv
from rbenv.satellite.actuators.wheels import parse_wheels
from rbenv.satellite.scene import scene_table

ENV_ID = "rbenv/SatelliteReorient-v1"
START = datetime(2025, 12, 15, 21, 50, 8)
FLOWN = {"realized_gain": 0.7, "deadband_rpm_s": 3.0, "startup_delay_s": 4.0}


def scene_file(tmp_path, name, **wheels) -> str:
    """innocube-3u with the given fixed wheel keys (None removes one) and the true attitude
    (no sensors: the log below is of the true state)."""
    data = scene_table("innocube-3u")
    data.pop("sensors", None)
    data["wheels"] = {k: v for k, v in {**data["wheels"], **wheels}.items() if v is not None}
    data["name"] = name
    path = tmp_path / f"{name}.toml"
    path.write_text(identify.dump_toml(data))
    return str(path)


def fly(scene: str, starts, seconds: int = 40, off_after: int | None = None) -> Telemetry:
    """Slews from each (angle deg about axis, rate deg/s) start in turn, the wheels' speeds
    carried over, logged every 2 s; one Telemetry of all (the target switches between). From
    start ``off_after`` on, the controller is off: zero commands, the satellite drifts."""
    env = gym.make(ENV_ID, scene=scene, action_mode="acceleration")
    pd = InnoCubePD.from_env(env)
    log = {k: [] for k in ("q", "rate_dps", "wheel_rpm", "command_rpm_s")}
    wheel, clock = np.zeros(3), -1.0
    for i, (angle, axis, rate) in enumerate(starts):
        off = off_after is not None and i >= off_after
        half = math.radians(angle) / 2
        q = np.array([math.cos(half), *(math.sin(half) * np.asarray(axis, float))])
        obs, _ = env.reset(seed=0, options={"q": q, "q_target": [1.0, 0, 0, 0],
                                            "omega_B": np.radians(rate), "wheel_speed": wheel,
                                            "wheel_clock_s": [clock]})
        st = env.unwrapped._st
        for k in range(seconds + 1):
            action, _ = pd.predict(obs)
            action = np.zeros_like(action) if off else action
            if k % 2 == 0:  # the 2 s log
                log["q"].append(np.asarray(st.q, float))
                log["rate_dps"].append(np.degrees(np.asarray(st.omega_B, float)))
                log["wheel_rpm"].append(np.asarray(st.wheel_speed, float) * 30 / math.pi)
                log["command_rpm_s"].append(action[:3] * 100.0)
            if k < seconds:
                obs, *_ = env.step(action)
                st = env.unwrapped._st
        wheel, clock = np.asarray(st.wheel_speed, float), 1e3
    n = len(log["q"])
    return Telemetry(folder=None, start_utc=START, time_s=2.0 * np.arange(n),
                     **{k: np.array(v) for k, v in log.items()})


STARTS = [(120.0, (0.0, 0.6, 0.8), (0.5, -1.0, 3.0)), (150.0, (1.0, 0.0, 0.0), (0.0, 0.0, 0.0))]


@pytest.fixture(scope="module")
def flight(tmp_path_factory):
    """A folder with two slews flown with FLOWN wheels, and the scene file they flew."""
    tmp = tmp_path_factory.mktemp("flight")
    scene = scene_file(tmp, "flown", **FLOWN)
    write_folder(tmp / "log" / "15.12.2025 21.50-22.05", fly(scene, STARTS))
    return tmp, scene


def test_replay_of_the_scene_that_flew_follows_the_log(flight):
    """rbenv flying the same PD in the same scene from the logged (3-digit) starts follows the
    log to the rounding; the metrics are those of the logged error itself."""
    tmp, scene = flight
    result = replay.replay(tmp / "log", scene, "innocube-pd", env_id=ENV_ID)
    assert [m["index"] for m in result["maneuvers"]] == [0, 1]
    assert result["maneuvers"][1]["t0"] == 42.0 and result["maneuvers"][1]["duration_s"] == 40.0
    assert result["summary"]["median_abs_error_diff_deg"] < 0.05
    for m in result["maneuvers"]:
        flight_, sim = m["flight"], m["sim"]
        assert sim["steady_deg"] == pytest.approx(flight_["steady_deg"], abs=0.05)
    ideal = replay.replay(tmp / "log", scene_file(tmp, "ideal", realized_gain=None,
                                                  deadband_rpm_s=None, startup_delay_s=None),
                          "innocube-pd", env_id=ENV_ID)
    assert ideal["summary"]["median_abs_error_diff_deg"] > 10 * result["summary"][
        "median_abs_error_diff_deg"]  # the check can fail: ideal wheels do not follow


def test_a_piece_flown_by_no_controller_is_replayed_open_loop_and_left_out(flight, tmp_path):
    """Issue 44, item 7: a last piece that logs only zero commands (the controller off, the
    satellite drifting) is replayed with those commands, not flown by the policy, and the
    summary compares the policy with the flight on the other pieces only."""
    _, scene = flight
    drift = (100.0, (0.0, 0.0, 1.0), (0.4, 0.3, -0.5))
    write_folder(tmp_path / "log" / "run", fly(scene, [*STARTS, drift], off_after=2))
    result = replay.replay(tmp_path / "log", scene, "innocube-pd", env_id=ENV_ID)
    modes = [m["mode"] for m in result["maneuvers"]]
    assert modes == ["closed_loop", "closed_loop", "open_loop"]
    last = result["maneuvers"][2]
    assert last["flight"]["steady_deg"] > 90.0  # it drifted: nobody turned it
    assert last["median_abs_error_diff_deg"] < 0.05  # the drift is followed, not a slew
    alone = replay.replay(flight[0] / "log", scene, "innocube-pd", env_id=ENV_ID)
    assert result["summary"]["open_loop"] == {
        "maneuvers": 1, "median_abs_error_diff_deg": pytest.approx(
            float(np.median(np.abs(result["replays"][2].sim_deg
                                   - result["replays"][2].flight_deg))))}
    for key, value in alone["summary"].items():
        if key != "open_loop":
            assert result["summary"][key] == pytest.approx(value), key
    assert alone["summary"]["open_loop"]["maneuvers"] == 0
    table = replay.format_table(result)
    assert "nobody: open loop, logged commands 0" in table
    assert "1 sub-maneuver(s) logged only zero commands" in table


def test_metrics_against_hand_counts():
    t = np.arange(0.0, 42.0, 2.0)  # 0 ... 40 s
    err = np.where(t < 10.0, 50.0, 0.5)
    err[t == 30.0] = 1.2  # above 1° once more: settles after it
    out = replay.metrics(t, err)
    assert out["settle_1deg_s"] == 32.0
    assert out["steady_deg"] == pytest.approx(np.mean(err[t >= 20.0]))
    assert replay.metrics(t, np.full_like(t, 2.0))["settle_1deg_s"] is None
    assert replay.metrics(t, np.full_like(t, 0.2))["settle_1deg_s"] == 0.0
    nan_tail = np.where(t < 30.0, 0.5, np.nan)  # an episode that ended early never settles
    assert replay.metrics(t, nan_tail)["settle_1deg_s"] is None


def test_the_replay_command_writes_exactly_the_documented_fields(flight, tmp_path):
    folder, scene = flight
    out = tmp_path / "r.json"
    assert main(["replay", str(folder / "log"), "--scene", scene, "--policy", "innocube-pd",
                 "--env-id", ENV_ID, "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert set(data) == {"scene", "policy", "maneuvers", "summary"}
    assert data["scene"] == "flown" and data["policy"] == "innocube-pd"
    assert set(data["maneuvers"][0]) == {"folder", "index", "t0", "duration_s", "mode",
                                         "median_abs_error_diff_deg", "flight", "sim"}
    assert data["maneuvers"][0]["folder"] == "15.12.2025 21.50-22.05"
    for side in ("flight", "sim"):
        assert set(data["maneuvers"][0][side]) == {"settle_1deg_s", "steady_deg"}
    assert set(data["summary"]) == {"median_abs_error_diff_deg", "flight_steady_deg_mean",
                                    "sim_steady_deg_mean", "flight_settle_1deg_s_median",
                                    "sim_settle_1deg_s_median", "open_loop"}
    assert data["summary"]["open_loop"] == {"maneuvers": 0, "median_abs_error_diff_deg": None}


def test_replay_plot_draws_one_panel_per_sub_maneuver(flight, tmp_path):
    pytest.importorskip("matplotlib")
    folder, scene = flight
    result = replay.replay(folder / "log", scene, "innocube-pd", env_id=ENV_ID)
    path = replay.plot(result, tmp_path / "replay.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.slow
def test_identify_recovers_the_realized_gain_and_writes_a_scene(flight, tmp_path):
    """From a data sheet that says gain 0.8, the fit finds the 0.7 that flew, within its 3σ
    and 0.02; the scene it writes loads and carries the value."""
    folder, _ = flight
    sheet = scene_file(tmp_path, "sheet", **{**FLOWN, "realized_gain": 0.8})
    fit = identify.identify(folder / "log", sheet, env_id=ENV_ID, only=("realized_gain",))
    gain, sigma = fit.values["realized_gain"], fit.sigmas["realized_gain"]
    assert gain == pytest.approx(0.7, abs=0.02)
    assert abs(gain - 0.7) <= 3 * sigma + 1e-3
    assert fit.cost["fit"]["rms"] < fit.cost["start"]["rms"]
    path = identify.write_scene(fit, tmp_path / "identified.toml")
    data = scene_table(path)
    assert data["name"] == "sheet-identified"
    assert data["wheels"]["realized_gain"] == pytest.approx(gain)
    assert "realized_gain" in data["sources"][-1]


@pytest.mark.slow
def test_identify_profiles_the_start_up_delay(flight, tmp_path):
    folder, _ = flight
    sheet = scene_file(tmp_path, "sheet", **{**FLOWN, "startup_delay_s": 9.0})
    fit = identify.identify(folder / "log", sheet, env_id=ENV_ID,
                            only=("startup_delay_s", "realized_gain"), max_nfev=3,
                            delay_grid_s=tuple(float(d) for d in range(9)))
    assert fit.values["startup_delay_s"] == 4.0
    assert 0.5 <= fit.sigmas["startup_delay_s"] <= 2.0


def test_plot_without_matplotlib_names_the_extra(flight, tmp_path, monkeypatch):
    folder, scene = flight
    result = replay.replay(folder / "log", scene, "innocube-pd", env_id=ENV_ID)
    monkeypatch.setitem(__import__("sys").modules, "matplotlib", None)
    with pytest.raises(ImportError, match=r"rbenv\[train\]"):
        replay.plot(result, tmp_path / "replay.png")


def test_rotor_inertia_from_momentum_conservation(flight):
    """The linear cross-check recovers the rotor inertia that flew (5.4e-5 kg m²) from the
    logged (3-digit) attitude, rates and wheel speeds alone."""
    folder, scene = flight
    table = scene_table(scene)
    value, sigma = identify.rotor_inertia_from_momentum(
        load(folder / "log"), rbenv.load_scene(scene).body.inertia,
        parse_wheels(table["wheels"]).axes_B)
    assert value == pytest.approx(5.4e-5, rel=0.03)
    assert 0 < sigma < 0.03 * value
