"""``anonloc train``'s options are generated from ``TrainConfig`` (CleanRL style): every field
can be set from the command line, with the field's default and docstring."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

pytest.importorskip("stable_baselines3")

from agents.train import TrainConfig
from anonloc_cli.app import TRAIN_FIELDS, TRAIN_OWN
from anonloc_cli.config_options import config_fields
from tests.cli_helpers import run_script

#: Fields set by the command's own options: --scenario/--set, --quiet, --out, ...
OWN = {"preset": "--scenario", "overrides": "--set", "progress": "--quiet"}


def test_every_field_of_the_config_is_an_option_with_its_default() -> None:
    fields = {f.name: f for f in dataclasses.fields(TrainConfig)}
    read = config_fields("agents", "train.py", "TrainConfig")
    assert set(read) | set(OWN) == set(fields)
    for name, field in read.items():
        assert field.default == fields[name].default, name
        assert field.doc, f"{name} has no docstring to show as help"
    help_text = run_script("train", "--help").stdout
    for name in fields:
        option = OWN.get(name, "--" + name.replace("_", "-"))
        assert option in help_text, option
    assert set(fields) >= TRAIN_OWN
    assert set(TRAIN_FIELDS) == set(read)


def test_a_generated_option_reaches_the_config_and_bad_values_are_named(tmp_path: Path) -> None:
    """A bad value is refused by the config, naming the field, before any work; a good one
    lands in the run's TrainConfig."""
    from agents import train
    from anonloc_cli import learning

    run = learning._new_config(
        train, scenario="default", sets=[], gamma=0.9, hidden=8, reward="team", ent_coef=0.01
    )
    assert (run.gamma, run.hidden, run.reward, run.ent_coef) == (0.9, 8, "team", 0.01)
    bad = run_script("train", "--gamma", "1.5", "--out", tmp_path, "--name", "s")
    assert bad.returncode != 0
    assert "gamma" in bad.stderr
    assert not (tmp_path / "s").exists()


def test_the_train_budget_default_is_the_one_duty_budget() -> None:
    """``TrainConfig.budget`` spells its default out (the CLI reads defaults from the source
    without importing it); it must stay the one definition in ``baselines``."""
    from baselines.excitations.swarm import DUTY_BUDGET

    assert TrainConfig().budget == DUTY_BUDGET
