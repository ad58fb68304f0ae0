"""rbenv train's flags are the config's fields: one flag per field, its help the field's docstring,
its default the field's (never restated), and only the flags given reach the config."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import pytest
from rbenv.agents import cli
from rbenv.agents.training import flags
from rbenv.agents.training.config import SessionOptions, TrainConfig
from rbenv.agents.training.rllib import RLlibConfig

from rbenv.satellite.usage import InvalidChoiceError

CLASSES = (TrainConfig, RLlibConfig, SessionOptions)


def _train_args(argv):
    return cli._parser().parse_args(["train", *argv])


@pytest.mark.parametrize("cls", CLASSES, ids=lambda c: c.__name__)
def test_every_field_has_a_docstring(cls):
    docs = flags.field_docs(cls)
    missing = [f.name for f in dataclasses.fields(cls) if not docs.get(f.name)]
    assert not missing, f"{cls.__name__} fields without a docstring: {missing}"


def test_every_field_is_a_flag_whose_help_is_its_docstring_and_default(capsys):
    with pytest.raises(SystemExit):
        cli.main(["train", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for cls in CLASSES:
        docs = flags.field_docs(cls)
        for f in dataclasses.fields(cls):
            assert flags.flag(f.name) in text, f.name
            assert docs[f.name] in text, f.name
    assert "(default: 200000)" in text and "(default: 'ppo')" in text


def test_no_flag_given_makes_the_dataclass_defaults():
    args = _train_args([])
    assert flags.given(args, TrainConfig) == {}
    assert TrainConfig(**flags.given(args, TrainConfig)) == TrainConfig()
    assert SessionOptions(**flags.given(args, SessionOptions)) == SessionOptions()


def test_given_flags_are_parsed_by_field_type():
    args = _train_args(["--timesteps", "512", "--seed", "3", "--env-kwargs", '{"a": 1}',
                        "--no-progress", "--trust-pickle", "--algo", "sac"])
    assert flags.given(args, TrainConfig) == {"timesteps": 512, "seed": 3,
                                              "env_kwargs": {"a": 1}, "algo": "sac"}
    assert flags.given(args, SessionOptions) == {"progress": False, "trust_pickle": True}


def test_a_choice_outside_the_literal_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as exit_:
        _train_args(["--algo", "dqn"])
    err = capsys.readouterr().err
    assert exit_.value.code == 2 and "argument --algo: 'dqn' is not one of ppo, sac" in err


def test_a_flag_of_the_other_engine_is_refused_naming_it():
    with pytest.raises(InvalidChoiceError, match=r"belongs to --engine rllib, not to --engine "
                       "sb3") as error:
        cli.main(["train", "--env-runners", "2", "--out", "unused"])
    assert error.value.field == "env_runners"


def test_field_docs_reads_the_string_under_each_field_through_bases():
    @dataclass
    class Base:
        a: int = 1
        """The a."""
        b: int = 2  # a comment is not a docstring

    @dataclass
    class Child(Base):
        c: dict = field(default_factory=dict)
        """The c,
        on two lines."""

    assert flags.field_docs(Child) == {"a": "The a.", "c": "The c, on two lines."}


def test_an_unset_scene_is_the_tasks_own_default():
    """rbenv train --env-id rbenv/SatelliteDesaturate-v0 trains where gym.make(env_id) runs:
    the wheel scene, not the package's default thruster scene (which the task cannot run on)."""
    import gymnasium as gym
    from rbenv.agents.training.config import TrainConfig

    cfg = TrainConfig(env_id="rbenv/SatelliteDesaturate-v0").resolve()
    env = gym.make("rbenv/SatelliteDesaturate-v0")
    try:
        assert cfg.scene == env.unwrapped.plant.scene.name == "cubesat-6u-rw"
    finally:
        env.close()
    assert cfg.out == "runs/ppo-cubesat-6u-rw-seed0"
    assert TrainConfig().resolve().scene == "cubesat-12u"
    assert TrainConfig(env_id="rbenv/SatelliteDesaturate-v0", scene="cubesat-12u-rw").scene \
        == "cubesat-12u-rw"
