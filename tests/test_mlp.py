"""The learned localizer ``mlp`` (baselines.mlp): shipped weights, protocol, determinism, skill,
and a clear error for a bad weights file."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import anonloc_env
import baselines
from agents.localizer_training import crowd
from baselines.mlp import FEATURES, WEIGHTS, MLPLocalizer, load_weights
from baselines.runner import run_episode


def test_the_shipped_weights_load_and_are_small() -> None:
    weights = load_weights()
    assert WEIGHTS.stat().st_size < 300_000
    assert weights.layers[0][0].shape[0] == len(FEATURES)
    assert "mlp" in baselines.policy_names()


def test_make_runs_it_through_the_same_protocol() -> None:
    env = anonloc_env.parallel_env("paper-motion")
    policy = baselines.make("mlp", env)
    observations, _ = env.reset(seed=0)
    for _ in range(300):
        action, _ = policy.predict(observations["robot_0"])
        assert env.action_space("robot_0").contains(action.astype(np.float32))
        observations, *_ = env.step({a: env.action_space(a).sample() for a in env.agents})
    team = baselines.make_team("mlp", env)
    assert isinstance(team.localizer, MLPLocalizer)
    with pytest.raises(ValueError, match="faithful"):
        baselines.make_team("mlp", env, mode="faithful")
    with pytest.raises(ValueError, match="threshold"):
        baselines.make_team("mlp", env, threshold=1.0)


def _episode(config: anonloc_env.EnvConfig, seed: int, pictures: int = 8):
    env = anonloc_env.AnonLocEnv(config, reward_fn=anonloc_env.EnergyCost())
    team = baselines.make_team("mlp", env, excitation="random")
    return run_episode(env, team, seed, max_pictures=pictures)


def test_same_seed_same_beliefs() -> None:
    a, b = _episode(crowd(6, True), 3), _episode(crowd(6, True), 3)
    assert a.records == b.records
    assert a.records != _episode(crowd(6, True), 4).records


def test_it_beats_chance_clearly_and_works_for_any_n() -> None:
    # Ten robots with detected headings, 3 seeded episodes of 8 pictures: after the first pair
    # the belief in the true row averages far above chance (1/10), and most robots decide right.
    records = [
        r
        for seed in (11, 12, 13)
        for r in _episode(crowd(10, True), seed).records
        if r.picture > 0 and r.true_index >= 0
    ]
    belief = np.mean([r.belief_true for r in records])
    assert belief > 0.6, belief
    decided = [r for r in records if r.estimate >= 0]
    assert len(decided) > 0.3 * len(records)
    assert np.mean([r.correct for r in decided]) > 0.9
    # The same weights for 3 and 30 robots, with misses and false positives.
    for n in (3, 30):
        result = _episode(crowd(n, True, p_miss=0.1, false_positives=2.0), 0, pictures=3)
        assert {r.robot for r in result.records} == set(range(n))


def test_paper_motion_first_decisions_are_mostly_right() -> None:
    from baselines.paper import play

    config = anonloc_env.make_config("paper-motion")
    right = []
    for seed in range(6):
        result = play("motion", seed, listeners={"mlp": MLPLocalizer(config, 2)})
        right += [d.correct for d in result.decisions("mlp")]
    assert sum(right) >= 10, right  # of 12 robots; chance is about half of those deciding


def test_bad_weights_files_are_refused_naming_the_file(tmp_path: Path) -> None:
    config = anonloc_env.make_config("paper-motion")
    missing = tmp_path / "none.npz"
    with pytest.raises(FileNotFoundError, match=r"none\.npz"):
        MLPLocalizer(config, 2, weights=missing)
    garbage = tmp_path / "garbage.npz"
    garbage.write_bytes(b"not a zip file at all")
    with pytest.raises(ValueError, match=r"garbage\.npz"):
        baselines.make_team("mlp", config=config, weights=garbage)
    wrong = tmp_path / "wrong.npz"
    np.savez(wrong, W0=np.zeros((3, 1)), b0=np.zeros(1))
    with pytest.raises(ValueError, match=r"wrong\.npz.*missing"):
        load_weights(wrong)
    shipped = dict(np.load(WEIGHTS))
    shipped["features"] = np.array(["other"] * len(FEATURES))
    renamed = tmp_path / "renamed.npz"
    np.savez(renamed, **shipped)
    with pytest.raises(ValueError, match=r"renamed\.npz.*FEATURES"):
        load_weights(renamed)
    shipped = dict(np.load(WEIGHTS))
    shipped["W1"] = shipped["W1"][:-1]
    broken = tmp_path / "broken.npz"
    np.savez(broken, **shipped)
    with pytest.raises(ValueError, match=r"broken\.npz.*layer 1"):
        load_weights(broken)


def test_weights_round_trip(tmp_path: Path) -> None:
    weights = load_weights()
    weights.save(tmp_path / "copy.npz")
    again = load_weights(tmp_path / "copy.npz")
    x = np.random.default_rng(0).normal(size=(5, len(FEATURES)))
    np.testing.assert_array_equal(weights.scores(x), again.scores(x))
    assert again.absent == weights.absent


def test_the_cli_benches_it(tmp_path: Path) -> None:
    pytest.importorskip("typer", reason="the CLI needs the cli extra")
    from tests.cli_helpers import read_csv, run_script

    out = tmp_path / "mlp.csv"
    done = run_script(
        "bench", "--scenario", "paper-motion", "--policy", "mlp", "--policy", "bayes",
        "--seeds", "2", "--pictures", "4", "--out", out, "--quiet",
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-2000:]
    rows = read_csv(out)
    assert {r["policy"] for r in rows} == {"mlp", "bayes"}
    assert len(rows) == 2 * 2 * 2  # policies x seeds x robots
    assert "Kaplan-Meier median" in out.with_suffix(".md").read_text()
