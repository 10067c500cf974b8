"""Play a team of localizing robots in one env and score them against the ground truth.

Every robot localizes at once (the paper's "worst conditions"). The runner reads ``true_index``
from ``infos`` only to score; the policies never see ``infos``.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from anonloc_env.actions import to_commands
from anonloc_env.env import AnonLocEnv
from anonloc_env.odometry import Interval
from anonloc_env.rewards import energy
from baselines.policies import Team


@dataclass(frozen=True)
class PictureRecord:
    """One robot at one picture.

    Attributes:
        localizer: which localizer decided: ``""`` for the team's own, else a listener's name.
        robot: the robot's index (``robot_{i}``).
        picture: the picture's index (0 at reset).
        time: when it was taken (s).
        estimate: the row the robot believes is itself, -1 if undecided.
        true_index: the row that is itself (-1 if it is not in the picture).
        correct: ``estimate == true_index`` and decided.
        belief_true: the belief the robot gave its true row (or to "not in the picture").
        energy: wheel travel since reset (m), see ``anonloc_env.rewards.energy``.
    """

    localizer: str
    robot: int
    picture: int
    time: float
    estimate: int
    true_index: int
    correct: bool
    belief_true: float
    energy: float


@dataclass(frozen=True)
class Decision:
    """A robot's first decision (the paper's measure), or its absence.

    Attributes:
        robot: the robot's index.
        picture: index of the picture of the first decision, -1 if it never decided.
        time: when that picture was taken (s), nan if never.
        correct: whether that first decision was right.
        energy: wheel travel until then (m), nan if never.
    """

    robot: int
    picture: int
    time: float
    correct: bool
    energy: float


@dataclass
class EpisodeResult:
    """Everything one episode produced.

    Attributes:
        seed: the env seed.
        n_robots: N.
        records: one per robot, picture and localizer.
        pictures: the scored pictures' rows ``(n, 3)``.
        true_rows: ``(N,)`` true row of each robot in each scored picture (ground truth).
        intervals: the robots' own motion between consecutive scored pictures.
    """

    seed: int
    n_robots: int
    records: list[PictureRecord]
    pictures: list[np.ndarray] = field(default_factory=list)
    true_rows: list[np.ndarray] = field(default_factory=list)
    intervals: list[Interval] = field(default_factory=list)

    def decisions(self, localizer: str = "") -> list[Decision]:
        """Each robot's first decision (by the team's localizer, or the named listener)."""
        first: dict[int, PictureRecord] = {}
        for rec in self.records:
            if rec.localizer == localizer and rec.estimate >= 0 and rec.robot not in first:
                first[rec.robot] = rec
        out = []
        for robot in range(self.n_robots):
            if robot in first:
                rec = first[robot]
                out.append(Decision(robot, rec.picture, rec.time, rec.correct, rec.energy))
            else:
                out.append(Decision(robot, -1, float("nan"), False, float("nan")))
        return out

    def rows(self) -> list[dict[str, object]]:
        """The records as plain dicts (for tables and files)."""
        return [asdict(r) for r in self.records]


def run_episode(
    env: AnonLocEnv,
    team: Team,
    seed: int,
    *,
    max_pictures: int | None = None,
    stop_when_decided: bool = False,
    policy_seed: int | None = None,
) -> EpisodeResult:
    """Play one episode.

    Args:
        env: the environment (its robots are the team's robots, in order).
        team: a team with one slot per robot of ``env``.
        seed: seeds the env's reset.
        max_pictures: stop once this many pictures were scored (None: run to truncation).
        stop_when_decided: stop at the first picture where every robot has decided (by the
            team's localizer and every listener).
        policy_seed: seeds the robots' own random choices (default: ``seed``); robot i gets the
            i-th child of ``SeedSequence(policy_seed)``.
    """
    n = env.config.n_robots
    if team.n != n:
        raise ValueError(f"team has {team.n} robots but the env has {n}")
    observations, infos = env.reset(seed=seed)
    root = np.random.SeedSequence(seed if policy_seed is None else policy_seed)
    team.reset(root.spawn(n))
    agents = env.possible_agents
    spent = np.zeros(n)
    records: list[PictureRecord] = []
    pictures: list[np.ndarray] = []
    true_rows: list[np.ndarray] = []
    scored = 0
    while True:
        actions = team.act([observations[a] for a in agents])
        if observations[agents[0]]["new_picture"][0] > 0.5:
            for name in ("", *team.listeners):
                records.extend(_score(env, team, name, infos, spent, agents))
            assert env.picture is not None
            pictures.append(env.picture.detections)
            true_rows.append(np.array([infos[a]["true_index"] for a in agents]))
            scored += 1
            done = max_pictures is not None and scored >= max_pictures
            if done or (stop_when_decided and _all_decided(team)):
                break
        if not env.agents:
            break
        v, w = to_commands(actions, env.config.robot)
        spent += energy(env.config, v, w)
        observations, _, _, _, infos = env.step(dict(zip(agents, actions, strict=True)))
    return EpisodeResult(
        seed=seed,
        n_robots=n,
        records=records,
        pictures=pictures,
        true_rows=true_rows,
        intervals=list(team.intervals),
    )


def _all_decided(team: Team) -> bool:
    return all(bool(np.all(team.estimates(name) >= 0)) for name in (None, *team.listeners))


def _score(
    env: AnonLocEnv,
    team: Team,
    name: str,
    infos: dict,
    spent: np.ndarray,
    agents: list[str],
) -> list[PictureRecord]:
    picture = env.picture
    assert picture is not None
    estimates = team.estimates(name or None)
    beliefs = team.beliefs(name or None)
    out = []
    for i, agent in enumerate(agents):
        true = int(infos[agent]["true_index"])
        if true >= 0 and beliefs.shape[1] > true:
            belief_true = float(beliefs[i, true])
        else:  # not in the picture: the belief that it is in none of the rows
            belief_true = float(max(0.0, 1.0 - beliefs[i].sum())) if beliefs.shape[1] else 1.0
        est = int(estimates[i])
        out.append(
            PictureRecord(
                localizer=name,
                robot=i,
                picture=picture.index,
                time=picture.time,
                estimate=est,
                true_index=true,
                correct=est >= 0 and est == true,
                belief_true=belief_true,
                energy=float(spent[i]),
            )
        )
    return out
