"""The agent bundled with the package: one set of weights for every N, camera and duty."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("torch")
pytest.importorskip("stable_baselines3")

import anonloc_env
import baselines
from agents.candidate_features import CONTEXT_SPEC
from agents.evaluation import censored, censored_pictures, play
from agents.linear_agent import linear_weights, save_linear_agent
from agents.linear_terms import DENSE
from agents.policy import BUNDLED, LearnedExcitation, as_saved, load_model
from agents.spec import saved_spec
from baselines.excitations.rest import RestWhenSure
from baselines.registry import make_excitation
from tests.cli_helpers import read_csv, run_script


def _scenario(n: int, **camera: object) -> dict[str, object]:
    side = math.sqrt(n)
    return {
        "n_robots": n,
        "arena_size": (side, side),
        "camera": {"pixel_noise": 1.0, "orientation": False, **camera},
    }


def test_the_bundled_agent_ships_with_the_package() -> None:
    assert BUNDLED.is_file()
    model = load_model("bundled")
    assert model.action_space.n == 8


@pytest.mark.parametrize("n", [2, 10, 100, 1000])
def test_the_bundled_agent_runs_at_any_n_with_the_same_weights(n: int) -> None:
    env = anonloc_env.parallel_env(**_scenario(n), max_cycles=45)
    team = baselines.make_team("agent", env)  # no path: the bundled agent
    assert isinstance(team.excitation, RestWhenSure)  # it rests once sure, as its spec says
    assert team.excitation.sure == 0.9999
    learned = team.excitation.inner
    assert isinstance(learned, LearnedExcitation)
    weights = learned.model.policy.state_dict()
    reference = load_model(BUNDLED).policy.state_dict()
    assert all(np.array_equal(weights[k], reference[k]) for k in reference)
    observations, _ = env.reset(seed=1)
    team.reset(np.random.SeedSequence(4).spawn(n))
    robot = env.action_space("robot_0")
    for _ in range(45):
        actions = team.act([observations[a] for a in env.possible_agents])
        assert actions.shape == (n, 2)
        assert all(robot.contains(a.astype(np.float32)) for a in actions)
        observations, *_ = env.step(dict(zip(env.possible_agents, actions, strict=True)))
    assert learned.cset is not None  # it scored and chose at the pictures


def _twelve(
    path: Path | None, density: float, seed: int = 3, clutter: bool = False
) -> list[object]:
    """An episode of 12 robots at ``density`` per m^2 (with ``clutter``: 10 % missed, 2 false
    positives a picture), 8 pictures, played by the agent at ``path`` (None: the bundled one)."""
    side = math.sqrt(12 / density)
    camera = {"p_miss": 0.1, "false_positives": 2.0} if clutter else {}
    env = anonloc_env.parallel_env(
        n_robots=12,
        arena_size=(side, side),
        camera={"pixel_noise": 1.0, "orientation": False, **camera},
    )
    team = baselines.make_team("agent", env, **({} if path is None else {"path": str(path)}))
    return baselines.runner.run_episode(env, team, seed, max_pictures=8).records


def test_the_bundled_agent_is_its_base_on_a_clean_camera_in_open_space(tmp_path: Path) -> None:
    """Ninth round: the bundled agent's ``*dense`` terms act only where the picture holds at
    least ``DENSE`` rows per m^2, its ``*missing`` terms only where the camera misses robots. On
    a clean camera at 1 per m^2 it plays its base, the seventh round's agent without the
    ``density`` feature, episode for episode; at 4 per m^2, or with misses, it plays
    differently."""
    spec = saved_spec(BUNDLED)
    assert spec is not None
    assert DENSE == 2.5
    weights = linear_weights("bundled")
    assert weights["entropy_after*dense"] == -100.0
    assert weights["energy*dense"] == -50.0
    assert weights["energy*missing"] == -20.0
    base_spec = dataclasses.replace(
        spec,
        context_features=CONTEXT_SPEC,
        terms=tuple(t for t in spec.terms if t.name.split("*")[1] not in ("dense", "missing")),
    )
    kept = np.array([weights[t.name] for t in base_spec.terms])
    base = save_linear_agent(kept, tmp_path / "base.zip", base_spec)
    for seed in (3, 4):
        assert _twelve(None, 1.0, seed) == _twelve(base, 1.0, seed)
    assert _twelve(None, 4.0) != _twelve(base, 4.0)
    assert _twelve(None, 1.0, clutter=True) != _twelve(base, 1.0, clutter=True)


def test_same_seed_same_actions_with_the_bundled_agent() -> None:
    env = anonloc_env.parallel_env(**_scenario(12, p_miss=0.1, false_positives=2.0))
    runs = [baselines.runner.run_episode(env, baselines.make_team("agent", env), 5)]
    runs.append(baselines.runner.run_episode(env, baselines.make_team("agent", env), 5))
    assert runs[0].records == runs[1].records
    other = baselines.runner.run_episode(env, baselines.make_team("agent", env), 5, policy_seed=9)
    assert other.records != runs[0].records


def test_make_gives_one_robots_policy_of_the_bundled_agent() -> None:
    env = anonloc_env.parallel_env(**_scenario(4))
    policy = baselines.make("agent", env)
    observations, _ = env.reset(seed=0)
    action, _ = policy.predict(observations["robot_0"])
    assert env.action_space("robot_0").contains(action.astype(np.float32))


def test_anonloc_eval_runs_the_bundled_agent_with_no_path(tmp_path: Path) -> None:
    out = tmp_path / "e.csv"
    done = run_script(
        "eval", "--agent", "bundled", "--seeds", "1", "--out", out, "--workers", "1",
        "--quiet", "--pictures", "3", "--set", "n_robots=4", "--set", "arena_size=[2.0, 2.0]",
        timeout=180,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    rows = read_csv(out)
    assert {r["policy"] for r in rows} == {"agent"}
    assert len(rows) >= 4


@pytest.mark.slow
def test_the_bundled_agent_beats_random_motion_on_a_small_condition() -> None:
    """Free motion, 10 robots at one per square metre, 1 px, no headings, 20 episodes on seeds
    no run trains on: the bundled agent needs fewer pictures to 99 % than random motion.

    Measured when the agent was bundled (``docs/agents.md``): the agent about 3 and random
    about 4.6 pictures, each mean with a standard error near 0.15 over 20 episodes; the test
    asks for 0.5 pictures fewer, more than 2 standard errors of the difference short of the
    measured gap."""
    config = anonloc_env.make_config(**_scenario(10), max_cycles=401)
    seeds = range(300_000, 300_020)
    model = load_model("bundled")
    agent = censored_pictures(play(config, "free", 0.2, lambda: as_saved(model),
                                   seeds, 20), 20)  # fmt: skip
    random = censored_pictures(
        play(config, "free", 0.2, lambda: make_excitation("random"), seeds, 20), 20
    )
    assert agent <= random - 0.5, (agent, random)


@pytest.mark.slow
@pytest.mark.parametrize(("condition", "picture_ratio"), [("free", 1.15), ("swarm", 1.05)])
def test_the_bundled_agent_saves_energy_against_uniform(
    condition: str, picture_ratio: float
) -> None:
    """10 robots at one per square metre, 1 px, no headings, free motion and swarm duty, 20
    episodes on the evaluation seeds (never searched on): the bundled agent spends less energy
    to 99 % than ``uniform``, its no-learning ablation, at no more than ``picture_ratio`` times
    its pictures.

    Measured when the agent was bundled at rest (``docs/agents.md``, the same seeds): free
    0.70x the energy at 1.09x the pictures, swarm 0.89x at 0.88x (without rest: 0.87x at 1.09x
    and 0.94x at 0.93x). It does not beat ``uniform`` on
    pictures in free motion (issue 24's target, missed): the bound says what it was measured
    to do, with room for one episode's difference (1/20 of about 3 pictures, 1.7 %)."""
    config = anonloc_env.make_config(**_scenario(10), max_cycles=601)
    seeds = range(100_000, 100_020)
    model = load_model("bundled")
    runs = {
        name: [censored(r, 30) for r in play(config, condition, 0.2, make, seeds, 30)]
        for name, make in (
            ("agent", lambda: as_saved(model)),
            ("uniform", lambda: make_excitation("uniform")),
        )
    }
    agent, uniform = (np.array(runs[k]) for k in ("agent", "uniform"))
    assert agent[:, 1].mean() < uniform[:, 1].mean(), (agent.mean(0), uniform.mean(0))
    assert agent[:, 0].mean() <= picture_ratio * uniform[:, 0].mean(), (
        agent.mean(0),
        uniform.mean(0),
    )
