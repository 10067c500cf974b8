"""The BenchMARL tasks (agents/benchmarl.py): settings from YAML, checked; specs an MLP takes; the
global state; a short MAPPO run whose policy then drives robots through ``baselines``' protocol.
Skipped where BenchMARL is not installed (the ``benchmarl`` extra)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("benchmarl", reason="needs the benchmarl extra (pip install -e '.[benchmarl]')")

import torch

from agents.benchmarl import (
    CONF,
    AnonLocTask,
    BenchmarlExcitation,
    experiment,
    pettingzoo_env,
    settings,
)
from agents.candidate_features import CANDIDATES
from agents.evaluation import play
from agents.pettingzoo import flat_size
from anonloc_env import make_config

SMALL = {"n_robots": 3, "max_cycles": 100}  # five decisions of 20 control steps


def built(task: AnonLocTask) -> object:
    """The task's TorchRL env with the task's transforms, as BenchMARL builds its test env."""
    from torchrl.envs import Compose, TransformedEnv

    task_class = task.get_from_yaml()
    task_class.config["overrides"] = dict(SMALL)
    env = task_class.get_env_fun(1, task is AnonLocTask.RAW, 3, "cpu")()
    return task_class, TransformedEnv(env, Compose(*task_class.get_env_transforms(env)))


@pytest.mark.parametrize("task", list(AnonLocTask))
def test_the_yaml_files_load_into_checked_settings(task: AnonLocTask) -> None:
    loaded = task.get_from_yaml()
    assert (CONF / f"{task.name.lower()}.yaml").is_file()
    chosen = settings(task.name, loaded.config)
    assert chosen.env_config().n_robots == 10
    assert loaded.supports_discrete_actions() is (task is AnonLocTask.BELIEF)
    assert loaded.supports_continuous_actions() is (task is AnonLocTask.RAW)


def test_bad_settings_are_refused_naming_the_key(tmp_path: Path) -> None:
    file = tmp_path / "belief.yaml"
    file.write_text("preset: default\ncondition: swarm\nbudgett: 0.3\n")
    with pytest.raises(ValueError, match=r"unknown BELIEF task setting\(s\) \['budgett'\]"):
        AnonLocTask.BELIEF.get_from_yaml(str(file))
    with pytest.raises(ValueError, match="condition must be one of"):
        settings("BELIEF", {"condition": "herd"})
    with pytest.raises(ValueError, match="budget must be in"):
        settings("BELIEF", {"budget": 1.5})
    with pytest.raises(ValueError, match="n_robotz"):
        settings("RAW", {"overrides": {"n_robotz": 3}})
    with pytest.raises(ValueError, match="unknown RAW task setting"):
        settings("RAW", {"condition": "free"})  # a belief setting


@pytest.mark.parametrize("task", list(AnonLocTask))
def test_every_input_is_a_row_per_robot_and_the_state_is_the_true_poses(task: AnonLocTask) -> None:
    """What BenchMARL's MLP needs: every observation leaf ``(N, F)`` and the state ``(3 N,)``;
    the state is the PettingZoo env's ``state()`` (true poses), row-major, at every step."""
    task_class, env = built(task)
    twin = pettingzoo_env(task.name, task_class.config)
    spec = task_class.observation_spec(env)
    for key, leaf in spec.items(True, True):
        assert leaf.shape[:-1] == (3,), key
    if task is AnonLocTask.BELIEF:
        assert spec["robot", "observation"].shape == (3, flat_size())
    else:
        rows = twin.observation_space("robot_0")["detections"].shape[0]
        assert spec["robot", "observation", "detections"].shape == (3, 3 * rows)
    assert task_class.state_spec(env)["state"].shape == (9,)
    assert task_class.action_mask_spec(env) is None
    torch.manual_seed(0)
    start = env.reset(seed=5)
    rollout = env.rollout(3, auto_reset=False, tensordict=start)
    twin.reset(seed=5)
    np.testing.assert_array_equal(start["state"].numpy(), twin.state().reshape(-1))
    for t in range(3):
        actions = rollout["robot", "action"][t].numpy()
        twin.step(dict(zip(twin.possible_agents, actions, strict=True)))
        np.testing.assert_array_equal(rollout["next", "state"][t].numpy(), twin.state().ravel())


@pytest.mark.slow
def test_mappo_trains_on_the_belief_task_and_its_policy_drives_the_robots(
    tmp_path: Path,
) -> None:
    """Two MAPPO iterations of 60 frames on N = 3 (about 40 s on 2 busy cores): every frame is
    collected, the actor changes, BenchMARL logs; then the trained actor drives a ``bayes`` team
    through ``agents.evaluation.play``, one of the C candidates per robot and picture, the same
    for the same seed."""
    task = AnonLocTask.BELIEF.get_from_yaml()
    task.config["overrides"] = dict(SMALL)
    run = experiment(
        task, "mappo", frames=120, frames_per_batch=60, envs=2, folder=tmp_path,
        minibatch=30, epochs=2,
    )  # fmt: skip
    before = [p.detach().clone() for p in run.group_policies["robot"].parameters()]
    run.run()
    assert run.total_frames == 120
    assert run.n_iters_performed == 2
    assert np.isfinite(run.mean_return)
    after = list(run.group_policies["robot"].parameters())
    assert any(not torch.equal(a, b) for a, b in zip(before, after, strict=True))
    assert list(tmp_path.rglob("collection_*.csv")), "no CSV log written"

    picks: list[np.ndarray] = []

    class Recorded(BenchmarlExcitation):
        def decide(self, pick: np.ndarray) -> None:
            picks.append(np.asarray(pick))
            super().decide(pick)

    config = make_config(**SMALL)
    first = play(config, "free", 0.2, lambda: Recorded(run), [7], 4)
    again = play(config, "free", 0.2, lambda: BenchmarlExcitation(run), [7], 4)
    assert first[0].records == again[0].records
    assert picks
    for pick in picks:
        assert pick.shape == (3,)
        assert pick.min() >= 0
        assert pick.max() < CANDIDATES
    assert {rec.picture for rec in first[0].records} == set(range(5))
