"""Identification in a crowd (issue 23): why confident decisions went wrong, and the results per
density.

Every robot runs the ``bayes`` identifier (decisions at belief 0.99) and one excitation; the
scenario is :func:`benchmarks.excitations.scenario` at a given density (robots per square metre;
1 px of noise, no detected headings, a picture every second).

Subcommands:

* ``diagnose``: plays episodes with motions that do not read the beliefs (``distinct``,
  ``random``), replays their pictures and motion through the identifier without the contact
  model of :mod:`anonloc_env.identify.contact` (``crowd_push_share=None``, ``contact_break=0``)
  and with it, and sorts every confident wrong decision by what the true poses show: a *jam*
  (the robot pressed in each of the last three intervals and moved less than half its size in
  each), a *slide* (pressed, pushed two intervals running, and moving), a *swap* (the row taken
  is a robot that touched it, within 1.5 sizes, at one of the last three pictures), a *crossing*
  (that robot came within 3 sizes) and *other*.
* ``results``: the grid of densities, robot counts and excitations: pictures to 99 % (censored
  mean, 95 % bootstrap interval), episodes reaching 99 %, confident decisions wrong, the share
  right at every picture, its largest fall after 95 %, and the reliability table (top belief
  against how often the top row is right) pooled per density; ``--json`` writes them;
  ``--no-escape`` plays the candidate excitations (``greedy``, ``uniform``, the agent) with the
  back-off before their bump reflex (``baselines.excitations.reflex``); ``--gaps-wait S``
  plays ``gaps`` with another wait limit (``GapSettings.wait``).
* ``plot``: the reliability curves per density and the share right over time, from that JSON.
* ``record``: writes one crowded episode's pictures and motion (the test's recorded episode).
* ``losses``: how robots that were right stopped being right between two pictures (undecided
  or wrong, and how many of them pressed), per excitation.

Usage::

    python -m benchmarks.crowds diagnose --seeds 500 520 --json diag.json
    python -m benchmarks.crowds results --densities 1 2 4 6 --robots 30 100 --episodes 4 \\
        --first-seed 9000 --json crowds.json
    python -m benchmarks.crowds plot crowds.json docs/assets/crowds
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import itertools
import json
import math
import os
import tempfile
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np

import anonloc_env
import baselines
from anonloc_env.config import EnvConfig
from anonloc_env.env import AnonLocEnv
from anonloc_env.identify import Identifier, SensorModel
from anonloc_env.odometry import Interval
from baselines.decisions import Decisions
from baselines.excitations import BumpReflex, Excitation, GapSeeking, GapSettings
from baselines.localizers import BayesLocalizer
from baselines.registry import EXCITATIONS
from baselines.runner import EpisodeResult, run_episode
from baselines.scoring import bootstrap_mean, first_identified, summarize
from benchmarks.excitations import scenario
from benchmarks.identify_quality import Scores, reliability

#: Decisions are taken at this belief.
THRESHOLD = 0.99
#: The episodes' length (pictures).
PICTURES = 30


@dataclass
class Played:
    """One episode and what the scoring of a crowd needs besides it.

    Attributes:
        result: the runner's episode.
        poses: ``(N, 3)`` true poses at each scored picture (ground truth).
        top: ``(N,)`` each robot's top belief at each scored picture.
        top_row: ``(N,)`` the row of that top belief.
        rules: each other decision rule's ``(N,)`` decisions at each scored picture (see
            ``RULES``).
    """

    result: EpisodeResult
    poses: list[np.ndarray] = field(default_factory=list)
    top: list[np.ndarray] = field(default_factory=list)
    top_row: list[np.ndarray] = field(default_factory=list)
    rules: dict[str, list[np.ndarray]] = field(default_factory=dict)


class _PoseTap:
    """The env, passed through, noting the true poses whenever a picture arrives."""

    def __init__(self, env: AnonLocEnv, played: Played) -> None:
        self._env, self._played = env, played

    def __getattr__(self, name: str) -> Any:
        return getattr(self._env, name)

    def _note(self, observations: Mapping[str, Any], infos: Mapping[str, Any]) -> None:
        agents = self._env.possible_agents
        if observations and observations[agents[0]]["new_picture"][0] > 0.5:
            self._played.poses.append(np.array([infos[a]["pose"] for a in agents]))

    def reset(self, **kwargs: Any) -> Any:
        observations, infos = self._env.reset(**kwargs)
        self._note(observations, infos)
        return observations, infos

    def step(self, actions: Any) -> Any:
        out = self._env.step(actions)
        self._note(out[0], out[4])
        return out


def parse_changes(texts: Sequence[str]) -> dict[str, tuple[str, float]]:
    """``NAME=VALUE`` (set) and ``NAME*=FACTOR`` (scale) changes of ``SensorModel`` fields, as
    ``{name: (op, number)}`` (``filter_position``: 0 or 1); a name that is no numeric field of
    the model is refused."""
    numeric = {
        "push_share",
        "crowd_push_share",
        "crowd_push_tail",
        "crowd_jam",
        "crowd_jam_tail",
        "contact_break",
        "filter_position",
        "crowd_noise",
    }
    out: dict[str, tuple[str, float]] = {}
    for text in texts:
        op = "*=" if "*=" in text else "="
        name, _, value = text.partition(op)
        if name not in numeric:
            raise ValueError(f"--model changes one of {sorted(numeric)}, got {text!r}")
        try:
            out[name] = (op, float(value))
        except ValueError:
            raise ValueError(f"--model {name} takes a number, got {value!r}") from None
    return out


def changed(model: SensorModel, changes: Mapping[str, tuple[str, float]]) -> SensorModel:
    """``model`` with ``changes`` (see :func:`parse_changes`) applied; a field the model leaves
    unset (None) stays so."""
    fields: dict[str, Any] = {}
    for name, (op, number) in changes.items():
        now = getattr(model, name)
        if now is None:
            continue
        value = now * number if op == "*=" else number
        if name == "crowd_jam":
            fields[name] = int(value)
        elif isinstance(now, bool):
            fields[name] = bool(value)
        else:
            fields[name] = float(value)
    return dataclasses.replace(model, **fields)


class ModelChanges:
    """Within ``with ModelChanges(changes):`` every ``SensorModel.from_config`` (so every
    ``bayes`` team's identifier) has ``changes`` applied (see :func:`changed`): the tuning
    variants of ``docs/crowds.md``. Nothing changes without changes."""

    def __init__(self, changes: Mapping[str, tuple[str, float]]) -> None:
        self.changes = dict(changes)

    def __enter__(self) -> ModelChanges:
        from anonloc_env.identify import model as sensor

        self._saved = original = sensor._from_config
        if self.changes:
            changes = self.changes

            @functools.lru_cache(maxsize=64)
            def patched(config: EnvConfig, scale_known: bool) -> SensorModel:
                return changed(original(config, scale_known), changes)

            sensor._from_config = patched  # type: ignore[assignment]  # the switch
        return self

    def __exit__(self, *exc: object) -> None:
        from anonloc_env.identify import model as sensor

        sensor._from_config = self._saved  # type: ignore[assignment]


def make_excitation(name: str, extra: Mapping[str, Callable[[], Excitation]]) -> Excitation:
    """A named excitation, or one of ``extra`` (e.g. the learned agent)."""
    return extra[name]() if name in extra else EXCITATIONS[name]()


def without_escape(
    names: Sequence[str], extra: Mapping[str, Callable[[], Excitation]]
) -> dict[str, Callable[[], Excitation]]:
    """``extra`` with every one of ``names`` made with the back-off before the bump reflex (a
    pressed robot backs off as after a first bump; ``GreedySettings.escape=None``): the
    candidate excitations as they were. The others are unchanged."""

    def old(name: str) -> Excitation:
        excitation = make_excitation(name, extra)
        reflex = getattr(excitation, "backoff", None)
        if isinstance(reflex, BumpReflex):
            excitation.backoff = BumpReflex(reflex.settings, None)  # type: ignore[attr-defined]
        return excitation

    return {**extra, **{name: functools.partial(old, name) for name in names}}


#: Decision rules scored beside ``bayes``'s own (``--rules``; ``baselines.decisions``): the
#: keyword arguments of ``Decisions`` besides the threshold. The decisions never reach the motion
#: (every excitation reads beliefs), so each rule is scored on the very episodes ``bayes`` plays.
#: ``threshold`` is the plain rule (``bayes``'s own in open space before the thirteenth round,
#: and in a crowd before the tenth); ``hold 0.9, release 0.05`` the tenth round's default in a
#: crowd, ``pressed 0.8`` the eleventh's (``Decisions.crowd`` in a crowd; in open space since the
#: thirteenth round it holds touched robots alone).
RULES: dict[str, dict[str, float]] = {
    "threshold": {},
    "hold 0.9, release 0.05": {"keep": 0.9, "release": 0.05},
    "pressed 0.8": {"keep": 0.9, "release": 0.05, "pressed_keep": 0.8},
    "pressed 0.7": {"keep": 0.9, "release": 0.05, "pressed_keep": 0.7},
}


def play(
    env: AnonLocEnv,
    name: str,
    seed: int,
    pictures: int = PICTURES,
    extra: Mapping[str, Callable[[], Excitation]] | None = None,
    rules: Sequence[str] = (),
) -> Played:
    """Play one episode of ``bayes`` with excitation ``name``, noting poses and top beliefs (and
    the decisions of ``rules``, names of ``RULES``)."""
    played = Played(EpisodeResult(seed, env.config.n_robots, []))
    team = baselines.make_team("bayes", env, excitation=make_excitation(name, extra or {}))
    beliefs = team.beliefs
    deciders = {rule: Decisions(THRESHOLD, **RULES[rule]) for rule in rules}
    played.rules = {rule: [] for rule in rules}

    def noted(listener: str | None = None) -> np.ndarray:
        table = beliefs(listener)
        if listener is None:
            empty = table.shape[1] == 0
            played.top.append(np.zeros(len(table)) if empty else table.max(axis=1))
            played.top_row.append(np.full(len(table), -1) if empty else table.argmax(axis=1))
            identifier = cast(BayesLocalizer, team.localizer).identifier
            for rule, decider in deciders.items():
                played.rules[rule].append(decider.decide(identifier, table))
        return table

    team.beliefs = noted  # type: ignore[method-assign]  # a tap on the scored beliefs
    tap = cast(AnonLocEnv, _PoseTap(env, played))
    played.result = run_episode(tap, team, seed, max_pictures=pictures)
    played.poses = played.poses[: len(played.result.pictures)]
    played.rules = {k: v[: len(played.result.pictures)] for k, v in played.rules.items()}
    return played


# -- diagnosis ------------------------------------------------------------------------------------
def replay(model: SensorModel, result: EpisodeResult) -> list[tuple[np.ndarray, np.ndarray]]:
    """Each picture's ``(top belief, top row)`` per robot, the episode's pictures and motion
    taken in by a fresh identifier of ``model``."""
    identifier = Identifier(model, result.n_robots)
    out = []
    intervals: list[Interval | None] = [None, *result.intervals]
    for rows, interval in zip(result.pictures, intervals, strict=False):
        identifier.update(rows, interval)
        belief = identifier.belief()
        if belief.shape[1] == 0:
            out.append((np.zeros(result.n_robots), np.full(result.n_robots, -1)))
        else:
            out.append((belief.max(axis=1), belief.argmax(axis=1)))
    return out


def without_contact_model(model: SensorModel) -> SensorModel:
    """``model`` without the crowd's contact model, filtered positions and noise floor (issue
    23): what the identifier was."""
    return dataclasses.replace(
        model, crowd_push_share=None, contact_break=0.0, filter_position=False, crowd_noise=1.0
    )


CAUSES = ("jam", "slide", "swap", "crossing", "other")


def cause(played: Played, k: int, robot: int, taken: int, size: float) -> str:
    """Why robot ``robot`` took row ``taken`` of picture ``k`` (see the module)."""
    poses, result = played.poses, played.result
    true = result.true_rows[k]
    other = np.flatnonzero(true == taken)
    recent = range(max(0, k - 3), k + 1)
    near = math.inf
    if len(other):
        j = int(other[0])
        near = min(np.hypot(*(poses[q][robot, :2] - poses[q][j, :2])) for q in recent)
        if near < 1.5 * size:
            return "swap"
    legs = list(range(max(1, k - 2), k + 1))
    pushed = [was_pushed(result.intervals[q - 1], robot) for q in legs]
    moved = [np.hypot(*(poses[q][robot, :2] - poses[q - 1][robot, :2])) for q in legs]
    if len(legs) == 3 and all(pushed) and max(moved) < 0.5 * size:
        return "jam"
    if any(a and b for a, b in itertools.pairwise(pushed)):
        return "slide"
    if near < 3.0 * size:
        return "crossing"
    return "other"


def was_pushed(interval: Interval, robot: int) -> bool:
    """Whether a contact pushed ``robot`` in ``interval``."""
    return interval.push is not None and bool(interval.push[robot] > 0.0)


def losses(result: EpisodeResult) -> dict[str, int]:
    """How robots stopped being right between two pictures: ``undecided`` or ``wrong`` at the
    later picture, and how many of those were ``pressed`` (pushed in that interval and the one
    before, the contact model's test)."""
    records = [r for r in result.records if r.localizer == ""]
    pictures = max((r.picture for r in records), default=-1) + 1
    right = np.zeros((pictures, result.n_robots), bool)
    decided = np.zeros((pictures, result.n_robots), bool)
    for r in records:
        right[r.picture, r.robot], decided[r.picture, r.robot] = r.correct, r.estimate >= 0
    out = {"undecided": 0, "wrong": 0, "pressed": 0}
    for k in range(1, min(pictures, len(result.intervals) + 1)):
        for robot in np.flatnonzero(right[k - 1] & ~right[k]):
            out["wrong" if decided[k, robot] else "undecided"] += 1
            before = k >= 2 and was_pushed(result.intervals[k - 2], robot)
            out["pressed"] += int(before and was_pushed(result.intervals[k - 1], robot))
    return out


def diagnose(
    density: float, n: int, names: Sequence[str], seeds: Sequence[int]
) -> dict[str, dict[str, Any]]:
    """Confident wrong decisions without and with the contact model, sorted by cause."""
    config = scenario(n, PICTURES, density)
    env = anonloc_env.AnonLocEnv(config, reward_fn=anonloc_env.EnergyCost())
    model = SensorModel.from_config(config)
    out: dict[str, dict[str, Any]] = {}
    for name in names:
        counts = {label: {c: 0 for c in CAUSES} for label in ("before", "after")}
        decided = {"before": 0, "after": 0}
        examples: list[list[int]] = []
        for seed in seeds:
            played = play(env, name, seed)
            for label, m in (("before", without_contact_model(model)), ("after", model)):
                for k, (top, row) in enumerate(replay(m, played.result)):
                    true = played.result.true_rows[k]
                    sure = np.flatnonzero(top >= THRESHOLD)
                    decided[label] += len(sure)
                    for i in sure[row[sure] != true[sure]]:
                        c = cause(played, k, int(i), int(row[i]), config.robot.size)
                        counts[label][c] += 1
                        if label == "before" and len(examples) < 20:
                            examples.append([seed, k, int(i)])
        out[name] = {"decided": decided, "wrong": counts, "examples": examples}
    return out


# -- results --------------------------------------------------------------------------------------
def score_cell(episodes: Sequence[Played]) -> dict[str, Any]:
    """The measures of one (density, N, excitation) cell."""
    results = [p.result for p in episodes]
    summary = summarize(results)
    records = [r for res in results for r in res.records if r.localizer == ""]
    decided = [r for r in records if r.estimate >= 0]
    wrong = sum(not r.correct for r in decided)
    pictures = max(len(p.result.pictures) for p in episodes)
    share = [
        float(np.mean([r.correct for r in records if r.picture == k])) for k in range(pictures)
    ]
    scores = Scores(pictures)
    expected = 0.0  # sum of 1 - belief over the confident decisions: the wrong ones if calibrated
    for p in episodes:
        for top in p.top:
            sure = top[top >= THRESHOLD]
            expected += float(np.sum(1.0 - sure))
    for p in episodes:
        for k, (top, row) in enumerate(zip(p.top, p.top_row, strict=False)):
            true = p.result.true_rows[k]
            scores.top.extend(top.tolist())
            scores.top_right.extend((row == true).tolist())
    return {
        "episodes": summary.episodes,
        "reached": summary.identified,
        "pictures": dataclasses.asdict(summary.pictures_all),
        "decided": len(decided),
        "wrong": wrong,
        "expected_wrong": expected,
        "share": share,
        "fall_after_95": largest_fall(share),
        "reliability": reliability(scores),
        "rules": {rule: score_rule(episodes, rule) for rule in episodes[0].rules},
    }


def score_rule(episodes: Sequence[Played], rule: str) -> dict[str, Any]:
    """The measures of ``score_cell`` for the decisions of ``rule`` (``Played.rules``)."""
    censored, decided, wrong, shares, reached = [], 0, 0, [], 0
    for p in episodes:
        estimates = np.array(p.rules[rule])  # (pictures, N)
        true = np.array(p.result.true_rows[: len(estimates)])
        right = (estimates >= 0) & (estimates == true)
        decided += int((estimates >= 0).sum())
        wrong += int(((estimates >= 0) & ~right).sum())
        shares.append(right.mean(axis=1))
        ones = np.ones(right.T.shape, bool)
        first, _ = first_identified(right.T, ones, np.zeros(right.T.shape))
        censored.append(first if first is not None else len(estimates))  # as summarize()
        reached += first is not None
    share = np.mean(shares, axis=0).tolist()
    return {
        "reached": reached,
        "pictures": dataclasses.asdict(bootstrap_mean(censored)),
        "decided": decided,
        "wrong": wrong,
        "share": share,
        "fall_after_95": largest_fall(share),
    }


def largest_fall(share: Sequence[float], after: float = 0.95) -> float | None:
    """The largest drop of ``share`` between two pictures once it reached ``after`` (None if it
    never did). A share equal to ``after`` up to rounding has reached it (the same share summed
    in another order is 0.95 in one JSON and 0.9499999999999999 in another)."""
    reached = [k for k, s in enumerate(share) if s >= after - 1e-9]
    if not reached:
        return None
    tail = np.asarray(share[reached[0] :])
    return float(max(0.0, np.max(tail[:-1] - tail[1:]))) if len(tail) > 1 else 0.0


def results(
    densities: Sequence[float],
    robots: Sequence[int],
    names: Sequence[str],
    episodes: int,
    first_seed: int,
    extra: Mapping[str, Callable[[], Excitation]] | None = None,
    json_path: str | None = None,
    rules: Sequence[str] = (),
) -> list[dict[str, Any]]:
    """Every cell of the grid, on the same seeds for every excitation (written to ``json_path``
    after every cell, if given), with the decision rules ``rules`` scored beside the plain one."""
    out = []
    for density in densities:
        for n in robots:
            config = scenario(n, PICTURES, density)
            env = anonloc_env.AnonLocEnv(config, reward_fn=anonloc_env.EnergyCost())
            for name in names:
                seeds = range(first_seed, first_seed + episodes)
                cell = score_cell([play(env, name, s, extra=extra, rules=rules) for s in seeds])
                cell.update(density=density, n=n, excitation=name)
                out.append(cell)
                print(_line(cell), flush=True)
                for rule in rules:
                    print(_line(cell, rule), flush=True)
                if json_path:
                    write_json(json_path, out)
    return out


HEADER = (
    "| robots/m² | N | excitation | pictures to 99 % [95 %] | reached 99 % "
    "| confident decisions wrong | largest fall after 95 % |\n|---|---|---|---|---|---|---|"
)


def _line(cell: Mapping[str, Any], rule: str | None = None) -> str:
    """A table row of ``cell``: its plain decisions, or those of ``rule`` (named after the
    excitation)."""
    scored = cell if rule is None else cell["rules"][rule]
    p = scored["pictures"]
    wrong = 100.0 * scored["wrong"] / max(scored["decided"], 1)
    fall = scored["fall_after_95"]
    fall_text = "never 95 %" if fall is None else f"{100 * fall:.1f} pt"
    name = cell["excitation"] if rule is None else f"{cell['excitation']}, {rule}"
    expected = scored.get("expected_wrong")
    count = (
        f"{scored['wrong']}" if expected is None else f"{scored['wrong']}; {expected:.1f} expected"
    )
    return (
        f"| {cell['density']:g} | {cell['n']} | {name} | {p['mean']:.2f} "
        f"[{p['low']:.2f}, {p['high']:.2f}] | {scored['reached']}/{cell['episodes']} "
        f"| {wrong:.2f} % of {scored['decided']:,} ({count}) | {fall_text} |"
    )


def write_json(path: str, data: Any) -> None:
    """Write ``data`` to ``path`` atomically."""
    folder = os.path.dirname(os.path.abspath(path))
    with tempfile.NamedTemporaryFile("w", dir=folder, delete=False, suffix=".tmp") as f:
        json.dump(data, f, indent=1)
    os.replace(f.name, path)


def cluttered(config: EnvConfig, p_miss: float = 0.0, false_positives: float = 0.0) -> EnvConfig:
    """``config`` with a camera that misses each robot with probability ``p_miss`` and sees
    ``false_positives`` false detections per picture on average (both 0: ``config`` itself)."""
    if p_miss == 0.0 and false_positives == 0.0:
        return config
    camera = dataclasses.replace(config.camera, p_miss=p_miss, false_positives=false_positives)
    return dataclasses.replace(config, camera=camera)


def record(
    path: str,
    density: float,
    n: int,
    name: str,
    seed: int,
    pictures: int,
    p_miss: float = 0.0,
    false_positives: float = 0.0,
) -> None:
    """Write one episode's pictures, motion and true rows to ``path`` (``.npz``), on a camera
    with misses and false positives if given (see ``cluttered``)."""
    config = cluttered(scenario(n, pictures, density), p_miss, false_positives)
    env = anonloc_env.AnonLocEnv(config, reward_fn=anonloc_env.EnergyCost())
    result = play(env, name, seed, pictures).result
    arrays: dict[str, np.ndarray] = {
        "pictures": np.concatenate(result.pictures),  # each picture's rows, one after the other
        "counts": np.array([len(rows) for rows in result.pictures]),
        "true_rows": np.stack(result.true_rows),
        "density": np.array(density),
        "p_miss": np.array(p_miss),
        "false_positives": np.array(false_positives),
    }
    for key in ("d", "dphi", "path", "sum_ds2", "sum_dth2", "push", "push_sum"):
        values = [getattr(iv, key) for iv in result.intervals]
        if key in ("push", "push_sum"):
            shape = (n, 2) if key == "push_sum" else (n,)
            values = [np.zeros(shape) if v is None else v for v in values]
        arrays[key] = np.stack(values)
    np.savez_compressed(path, **arrays)  # type: ignore[arg-type]  # numpy's stubs


def open_space(
    names: Sequence[str],
    excitations: Sequence[str],
    episodes: int,
    first_seed: int,
    extra: Mapping[str, Callable[[], Excitation]] | None = None,
) -> list[dict[str, Any]]:
    """The agents' evaluation conditions ``names`` with and without the contact model, on the
    same seeds: each excitation's censored mean pictures to 99 % and its confident decisions
    wrong, both ways (the model is switched through ``SensorModel.from_config``'s constant)."""
    from agents.evaluation import censored
    from agents.evaluation import play as play_condition
    from anonloc_env.identify import model as sensor
    from benchmarks.agent_conditions import crowded_conditions, evaluation_conditions

    conditions = evaluation_conditions() | crowded_conditions()
    share, out = sensor.CROWD_PUSH_SHARE, []
    try:
        for name in names:
            config, condition, budget = conditions[name]
            seeds = range(first_seed, first_seed + episodes)
            for excitation in excitations:
                row: dict[str, Any] = {"condition": name, "excitation": excitation}
                for label, value in (("before", None), ("after", share)):
                    sensor.CROWD_PUSH_SHARE = value  # type: ignore[assignment]  # the switch
                    sensor._from_config.cache_clear()
                    make = functools.partial(make_excitation, excitation, extra or {})
                    results = play_condition(config, condition, budget, make, seeds, PICTURES)
                    found = [censored(r, PICTURES)[0] for r in results]
                    decided = [x for r in results for x in r.records if x.estimate >= 0]
                    row[label] = dataclasses.asdict(bootstrap_mean(found))
                    row[f"{label}_wrong"] = sum(not x.correct for x in decided) / len(decided)
                out.append(row)
                print(json.dumps(row), flush=True)
    finally:
        sensor.CROWD_PUSH_SHARE = share
        sensor._from_config.cache_clear()
    return out


def load_recorded(path: str) -> tuple[EnvConfig, EpisodeResult]:
    """The scenario and episode :func:`record` wrote to ``path`` (pictures, motion, true rows;
    the camera's misses and false positives where it wrote them)."""
    with np.load(path) as z:
        arrays = {key: z[key] for key in z.files}
    true_rows = arrays["true_rows"]
    n = true_rows.shape[1]
    if "counts" in arrays:  # pictures of any size, one after the other
        pictures = list(np.split(arrays["pictures"], np.cumsum(arrays["counts"])[:-1]))
    else:  # recorded before there were misses: one (N, 3) picture each
        pictures = list(arrays["pictures"])
    intervals = []
    for k in range(len(pictures) - 1):
        pushed = bool(arrays["push"][k].any())
        intervals.append(
            Interval(
                d=arrays["d"][k],
                dphi=arrays["dphi"][k],
                path=arrays["path"][k],
                sum_ds2=arrays["sum_ds2"][k],
                sum_dth2=arrays["sum_dth2"][k],
                push=arrays["push"][k] if pushed else None,
                push_sum=arrays["push_sum"][k] if pushed else None,
            )
        )
    result = EpisodeResult(0, n, [], pictures, list(true_rows), intervals)
    config = scenario(n, PICTURES, float(arrays["density"]))
    clutter = (float(arrays.get("p_miss", 0.0)), float(arrays.get("false_positives", 0.0)))
    return cluttered(config, *clutter), result


def _agent(path: str | None) -> dict[str, Callable[[], Excitation]]:
    """``{"agent": ...}`` for a saved agent (the ``rl`` extra), or nothing."""
    if not path:
        return {}
    from agents.policy import as_saved, load_model

    model = load_model(path)
    return {"agent": lambda: as_saved(model)}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    d = sub.add_parser("diagnose")
    d.add_argument("--density", type=float, default=4.0)
    d.add_argument("--robots", type=int, default=30)
    d.add_argument("--excitations", nargs="+", default=["distinct", "random"])
    d.add_argument("--seeds", type=int, nargs=2, default=[500, 520], metavar=("FIRST", "END"))
    d.add_argument("--json")
    r = sub.add_parser("results")
    r.add_argument("--densities", type=float, nargs="+", default=[1.0, 2.0, 4.0, 6.0])
    r.add_argument("--robots", type=int, nargs="+", default=[30, 100])
    r.add_argument("--excitations", nargs="+", default=["distinct", "greedy", "random", "gaps"])
    r.add_argument("--agent", help="a saved agent (agent.zip, or 'bundled') added as 'agent'")
    r.add_argument("--episodes", type=int, default=4)
    r.add_argument("--first-seed", type=int, default=9000)
    r.add_argument("--json")
    r.add_argument(
        "--no-escape", action="store_true", help="the candidate excitations without the bump reflex"
    )
    r.add_argument("--gaps-wait", type=float, help="gaps' wait limit (s; inf: none)")
    r.add_argument(
        "--rules", action="store_true", help="score the decision rules of RULES beside bayes's own"
    )
    r.add_argument(
        "--model",
        nargs="+",
        default=[],
        metavar="CHANGE",
        help="identifier model changes, NAME=VALUE or NAME*=FACTOR (e.g. crowd_push_tail=1)",
    )
    t = sub.add_parser("table", help="the markdown table of a results JSON")
    t.add_argument("results")
    p = sub.add_parser("plot")
    p.add_argument("results")
    p.add_argument("out", help="path prefix: writes PREFIX-reliability.png, PREFIX-share.png")
    o = sub.add_parser("open-space")
    o.add_argument("--conditions", nargs="+", default=["free N=10", "swarm N=10", "clutter N=20"])
    o.add_argument("--excitations", nargs="+", default=["distinct", "random", "greedy"])
    o.add_argument("--agent", help="a saved agent (agent.zip, or 'bundled') added as 'agent'")
    o.add_argument("--episodes", type=int, default=10)
    o.add_argument("--first-seed", type=int, default=100_000)
    o.add_argument("--json")
    lo = sub.add_parser("losses", help="how robots stopped being right, per excitation")
    lo.add_argument("--density", type=float, default=4.0)
    lo.add_argument("--robots", type=int, default=100)
    lo.add_argument("--excitations", nargs="+", default=["greedy", "gaps"])
    lo.add_argument("--seeds", type=int, nargs=2, default=[20000, 20006], metavar=("FIRST", "END"))
    c = sub.add_parser("record")
    c.add_argument("out")
    c.add_argument("--density", type=float, default=4.0)
    c.add_argument("--robots", type=int, default=30)
    c.add_argument("--excitation", default="distinct")
    c.add_argument("--seed", type=int, default=500)
    c.add_argument("--pictures", type=int, default=12)
    c.add_argument("--p-miss", type=float, default=0.0, help="the camera's miss probability")
    c.add_argument("--false-positives", type=float, default=0.0, help="per picture, on average")
    args = parser.parse_args(argv)
    if args.command == "diagnose":
        seeds = range(*args.seeds)
        found = diagnose(args.density, args.robots, args.excitations, seeds)
        print(json.dumps(found, indent=1))
        if args.json:
            write_json(args.json, found)
    elif args.command == "results":
        names, extra = list(args.excitations), _agent(args.agent)
        names += [name for name in extra if name not in names]  # --excitations agent: once
        if args.no_escape:
            extra = without_escape(names, extra)
        if args.gaps_wait is not None:
            extra["gaps"] = functools.partial(GapSeeking, GapSettings(wait=args.gaps_wait))
        print(
            "| robots/m² | N | excitation | pictures to 99 % | reached | wrong | fall after 95 % |"
        )
        print("|---|---|---|---|---|---|---|")
        grid = (args.densities, args.robots, names, args.episodes, args.first_seed)
        with ModelChanges(parse_changes(args.model)):
            results(*grid, extra, args.json, list(RULES) if args.rules else [])
    elif args.command == "open-space":
        names, extra = list(args.excitations), _agent(args.agent)
        names += list(extra)
        rows = open_space(args.conditions, names, args.episodes, args.first_seed, extra)
        if args.json:
            write_json(args.json, rows)
    elif args.command == "losses":
        env = anonloc_env.AnonLocEnv(
            scenario(args.robots, PICTURES, args.density), reward_fn=anonloc_env.EnergyCost()
        )
        for name in args.excitations:
            total = {"undecided": 0, "wrong": 0, "pressed": 0}
            for seed in range(*args.seeds):
                for key, count in losses(play(env, name, seed).result).items():
                    total[key] += count
            print(name, json.dumps(total), flush=True)
    elif args.command == "table":
        with open(args.results) as f:
            cells = sorted(json.load(f), key=lambda c: (c["density"], c["n"]))
        print(HEADER)
        for cell in cells:
            print(_line(cell))
        if any(cell.get("rules") for cell in cells):
            print("\n" + HEADER)
            for cell in cells:
                for rule in cell.get("rules", {}):
                    print(_line(cell, rule))
    elif args.command == "plot":
        from benchmarks.plot_crowds import plot

        with open(args.results) as f:
            plot(json.load(f), args.out)
    else:
        episode = (args.density, args.robots, args.excitation, args.seed, args.pictures)
        record(args.out, *episode, args.p_miss, args.false_positives)


if __name__ == "__main__":
    main()
