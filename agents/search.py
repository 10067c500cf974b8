"""Policy search for the linear candidate scorer: an evolution strategy against chance.

PPO on the Deep-Sets scorer did not beat ``uniform`` (``docs/agents.md``): its gradient is
estimated from rewards that a coin flip among the same candidates already earns, and 3 M
decisions did not move it. This module searches the few weights of the linear scorer
(:mod:`agents.linear_terms`) directly on what the project measures: the censored pictures to
99 % and the energy spent by then, each *relative to* ``uniform`` on the same scenarios and
seeds (common random numbers), so the noise of the scenario cancels and every generation asks
only "which weights beat chance here?".

The method (an evolution strategy with mirrored sampling and rank shaping, as in Salimans et
al. 2017, "Evolution strategies as a scalable alternative to reinforcement learning"):

1. Start from ``mu = 0``: the scorer *is* ``uniform`` there.
2. Each generation draws ``scenarios`` training scenarios (:func:`agents.conditions.draw_scenario`,
   the conditions of a ``mixed`` run: N in {3, 6, 14, 30, 40}, crowds, clutter, headings and
   swarm duty) and ``seeds`` seeds for each, and plays ``uniform``, ``mu`` and ``pairs``
   mirrored pairs ``mu +- std * noise`` on all of them.
3. A member's cost is ``mean_s log(P_s / P_s^uniform) + energy_weight * mean_s log(E_s /
   E_s^uniform)`` over the scenarios ``s`` (P: censored mean pictures to 99 %, E: mean energy
   to 99 %): the logs of geometric-mean ratios, so that one scenario where a member jams (12
   pictures against 3) weighs as much as one where it is 4 times faster, not more.
4. The costs become centered ranks; ``mu`` moves by ``-step_size`` times the mean over the
   pairs of ``(rank(+) - rank(-)) * noise``. A pair is played on the same episodes, so what
   differs between its two members is the direction of the perturbation alone.

Every ``validate_every`` generations ``mu`` and the run's own start (``uniform``, or the
weights of ``start``) play the validation condition (14 robots at one per m², a training N,
seeds 900000 and up, never an evaluation seed, free motion and swarm duty; with ``crowd`` or
``dense`` also 4 robots per m²): the curve in ``progress.csv`` is the run's progress against its
own start, with paired intervals.

A search may start from a saved agent and move one gate's terms alone (``start``, ``moves``):
the tenth round's search started from the seventh round's agent and moved only the six terms
behind the ``dense`` gate (``dense``: the bundled agent's 36 terms), on arenas of 2.5 to 6
robots per m², where the ninth round had set two of them by hand (``docs/agents.md``).

The run folder holds ``search.json`` (the config, the state and
the history after each generation, written atomically: a search killed at any point resumes at
the generation it was in) and ``agent.zip`` (the final ``mu`` as an SB3 agent,
:func:`agents.linear_agent.save_linear_agent`).
"""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import time
from collections.abc import Callable
from concurrent.futures import Executor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from agents.conditions import (
    ConditionRanges,
    Scenario,
    draw_scenario,
)
from agents.evaluation import validate_against_uniform
from agents.linear_agent import LINEAR_SPEC, linear_weights
from agents.linear_chooser import LinearChooser, chooser
from agents.linear_terms import DENSE, LINEAR_TERMS, SIZE_TERMS
from agents.policy import BUNDLED_NAME
from agents.run_folder import write_text_atomic
from agents.search_costs import Costing, costs, pool, pooled_player
from agents.spec import AgentSpec
from anonloc_env._checks import check_number

__all__ = ["LinearChooser", "SearchConfig", "chooser", "search"]

#: The numbers of robots a search with ``size`` draws from, beyond ``TRAINING_ROBOTS``
#: (none of them an evaluation condition's N: 10, 20, 50, 100, 300, 1000).
SIZE_ROBOTS = (70, 150, 200)


@dataclass(frozen=True)
class SearchConfig:
    """An evolution-strategy search of the linear scorer (see the module documentation)."""

    generations: int = 12
    """Generations to run, >= 1."""
    pairs: int = 7
    """Mirrored pairs ``mu +- std * noise`` played per generation, >= 1."""
    scenarios: int = 8
    """Training scenarios drawn per generation (``agents.conditions.draw_scenario``), >= 1."""
    seeds: int = 2
    """Episodes (seeds) per scenario and member, >= 1."""
    pictures: int = 12
    """Pictures per episode; an episode that never reaches 99 % counts there, >= 2."""
    energy_weight: float = 0.5
    """Weight of the energy ratio to ``uniform`` in the cost (the picture ratio's is 1), >= 0."""
    std: float = 0.5
    """The spread of the perturbations of every weight, > 0."""
    step_size: float = 1.0
    """How far ``mu`` moves along the estimated gradient of the ranks per generation, > 0."""
    validate_every: int = 2
    """Generations between two validations of ``mu`` against ``uniform``, >= 1."""
    validation_episodes: int = 30
    """Episodes of each validation condition (free, swarm, and crowd with ``crowd``), >= 2."""
    seed: int = 0
    """Seeds the scenarios, the draws and the episodes."""
    minutes: float = 60.0
    """Wall-clock budget (min): no generation starts after it."""
    crowd: bool = False
    """Whether the scorer sees the crowd features (``agents.crowd_features``) and has their
    terms (:data:`agents.linear_terms.CROWD_TERMS`, 28, against 18 without); its validation
    then adds a crowd (4 robots per m², key ``crowd``)."""
    crowd_only: bool = False
    """With ``crowd``: the search moves only the terms gated by ``crowding`` (the others stay
    zero), so that the agent is ``uniform`` (``uniform-rest`` with ``rest``) where no robot is
    near it and learns only where robots jostle."""
    rest: float | None = None
    """The belief at which a robot holds still until the next picture, in (0.5, 1]
    (``baselines.excitations.rest.RestWhenSure``): every member and the baseline rest, so the
    search is against ``uniform-rest``, and the saved agent's spec records it; None: no rest,
    the search is against ``uniform``."""
    size: bool = False
    """Whether the scorer has the size terms (:data:`agents.linear_terms.SIZE_TERMS`: every
    base times ``rows_free``, the number of robots in free motion) and the search also draws
    70, 150 and 200 robots (:data:`SIZE_ROBOTS`), so that a preference can change with N."""
    against: str = "ablation"
    """The baseline of every ratio: ``ablation`` (zero weights at the members' rest:
    ``uniform-rest`` with ``rest``, else ``uniform``) or ``uniform`` (plain ``uniform``, the
    reference of issue 24's targets, also when the members rest)."""
    energy_cap: float | None = None
    """The energy ratio to the baseline at or under which energy costs nothing, in (0, 10]
    (:func:`agents.search_costs.member_costs`); None: every ratio costs its log."""
    dense: bool = False
    """Whether the scorer reads the arena's density and the camera's misses: the crowd feature
    ``density`` and the terms behind the ``dense`` and ``missing`` gates
    (:meth:`agents.spec.AgentSpec.with_density`); with ``size`` the search has the bundled
    agent's 36 terms."""
    moves: str | None = None
    """The gate whose terms alone the search moves (a gate of its terms: ``always``,
    ``decided``, ``on_duty``, ``rows_free``, ``crowding``, ``dense``, ``missing``); every other
    term keeps its start weight. With ``dense``, the search draws only arenas of at least
    ``agents.linear_terms.DENSE`` robots per m² and validates only in the crowd, since below
    that the members all play their start. None: every term moves."""
    start: str | None = None
    """A saved linear agent (``agent.zip``, its folder, or ``bundled``) whose weights, matched
    by term name, are the first ``mu`` (a term it lacks starts at 0); None: zeros, ``uniform``."""
    workers: int = 1
    """Processes that play the episodes, in [1, 256]; the result does not depend on it."""
    ranges: ConditionRanges = field(default_factory=ConditionRanges)
    """The training conditions (:class:`agents.conditions.ConditionRanges`)."""

    def __post_init__(self) -> None:
        check_number("generations", self.generations, 1, 10_000, integer=True)
        check_number("pairs", self.pairs, 1, 1_000, integer=True)
        check_number("scenarios", self.scenarios, 1, 1_000, integer=True)
        check_number("seeds", self.seeds, 1, 1_000, integer=True)
        check_number("pictures", self.pictures, 2, 10_000, integer=True)
        check_number("energy_weight", self.energy_weight, 0.0, 1e6)
        check_number("std", self.std, 1e-6, 1e6)
        check_number("step_size", self.step_size, 1e-6, 1e6)
        check_number("validate_every", self.validate_every, 1, 10_000, integer=True)
        check_number("validation_episodes", self.validation_episodes, 2, 10_000, integer=True)
        check_number("seed", self.seed, 0, 2**63 - 1, integer=True)
        check_number("minutes", self.minutes, 0.0, 1e6)
        if self.rest is not None:
            check_number("rest", self.rest, 0.5, 1.0, low_open=True)
        check_number("workers", self.workers, 1, 256, integer=True)
        if self.energy_cap is not None:
            check_number("energy_cap", self.energy_cap, 0.0, 10.0, low_open=True)
        if self.against not in ("ablation", "uniform"):
            raise ValueError(f"against must be 'ablation' or 'uniform', got {self.against!r}")
        if self.start not in (None, BUNDLED_NAME) and not Path(str(self.start)).exists():
            raise ValueError(
                f"start must be a saved linear agent or {BUNDLED_NAME!r}: no {self.start}"
            )
        if self.crowd_only and not self.crowd:
            raise ValueError("crowd_only needs crowd (the crowd features and their terms)")
        if self.moves is not None:
            gates = sorted({t.name.split("*")[1] for t in search_spec(self).terms})
            if self.crowd_only or self.moves not in gates:
                raise ValueError(
                    f"moves must be a gate of the search's terms, one of {gates}, and not with "
                    f"crowd_only; got {self.moves!r}"
                )


def moved_terms(config: SearchConfig) -> np.ndarray:
    """``(T,)`` 1 for each term the search moves, 0 for those it keeps at their start
    (``SearchConfig.moves``) or at zero (``SearchConfig.crowd_only``)."""
    terms = search_spec(config).terms
    gate = "crowding" if config.crowd_only else config.moves
    if gate is None:
        return np.ones(len(terms))
    return np.array([t.name.endswith(f"*{gate}") for t in terms], np.float64)


def search_spec(config: SearchConfig) -> AgentSpec:
    """The spec of the agent a search finds: linear, with the crowd features when
    ``config.crowd``, at rest when ``config.rest``."""
    spec = dataclasses.replace(LINEAR_SPEC, rest=config.rest)
    spec = spec.with_crowd_features() if config.crowd else spec
    spec = dataclasses.replace(spec, terms=spec.terms + SIZE_TERMS) if config.size else spec
    return spec.with_density() if config.dense else spec


def costing(config: SearchConfig) -> Costing:
    """How ``config``'s generations play and judge their episodes: the baseline rests like the
    members with ``against == "ablation"``, never with ``"uniform"``."""
    return Costing(
        pictures=config.pictures,
        rest=config.rest,
        baseline_rest=config.rest if config.against == "ablation" else None,
        energy_weight=config.energy_weight,
        energy_cap=config.energy_cap,
    )


def search_ranges(config: SearchConfig) -> ConditionRanges:
    """The conditions a search draws from: ``config.ranges``, with :data:`SIZE_ROBOTS` added to
    its robots when ``config.size``, and from :data:`agents.linear_terms.DENSE` robots per m²
    up when it moves only the ``dense`` terms."""
    ranges = config.ranges
    if config.size:
        robots = tuple(sorted({*ranges.robots, *SIZE_ROBOTS}))
        ranges = dataclasses.replace(ranges, robots=robots)
    if config.moves == "dense":
        low, high = ranges.density
        ranges = dataclasses.replace(ranges, density=(max(low, DENSE), max(high, DENSE)))
    return ranges


def validation_keys(config: SearchConfig) -> tuple[str, ...] | None:
    """The validation conditions a search plays (``agents.evaluation.validation_scenarios``):
    only the crowd when it moves only the ``dense`` terms (elsewhere every member is its start),
    else all of them (None)."""
    return ("crowd",) if config.moves == "dense" else None


def first_mu(config: SearchConfig) -> list[float]:
    """The search's first ``mu``: zeros (``uniform``), or ``config.start``'s weights by term
    name (zero for a term it lacks, and with ``crowd_only`` for a term the search does not
    move)."""
    terms = search_spec(config).terms
    if config.start is None:
        return [0.0] * len(terms)
    weights = linear_weights(config.start)
    kept = moved_terms(config) if config.crowd_only else np.ones(len(terms))
    return [weights.get(t.name, 0.0) * float(k) for t, k in zip(terms, kept, strict=True)]


def validate(
    weights: np.ndarray,
    episodes: int,
    pictures: int,
    rest: float | None = None,
    spec: AgentSpec = LINEAR_SPEC,
    crowd: bool = False,
    executor: Executor | None = None,
    start: np.ndarray | None = None,
    keys: tuple[str, ...] | None = None,
    start_cache: dict[str, np.ndarray] | None = None,
) -> dict[str, float]:
    """``weights`` against the search's ``start`` (default zero weights: ``uniform`` bit for
    bit; both at rest once sure, with ``rest``) on the validation condition
    (:func:`agents.evaluation.validate_against_uniform`), in free motion and on swarm duty (and,
    with ``crowd``, in a crowd of 4 robots per m²; only those in ``keys`` when given): the
    picture and energy ratios with paired 95 % intervals (keys ``free_pictures``,
    ``free_pictures_low``, ... ``swarm_energy_high``, ``crowd_...``) and the censored mean
    pictures of both (``free_mean``, ``free_start``, ...); ``weights`` of ``spec``'s terms.
    ``executor`` plays the episodes in its processes (the same episodes; None: here).
    ``start_cache``: the start's episodes by condition, played on the first call and reused
    (the start never changes within a search; see
    :func:`agents.evaluation.validate_against_uniform`)."""
    out: dict[str, float] = {}
    reference = np.zeros(len(spec.terms)) if start is None else np.asarray(start)
    ablation = chooser(reference, rest, spec)
    player = None if executor is None else pooled_player(executor, (weights, reference), rest, spec)
    validations = validate_against_uniform(
        chooser(weights, rest, spec), episodes, pictures, ablation, crowd, player, keys, start_cache
    )
    for condition, v in validations.items():
        out[f"{condition}_mean"] = v.mean
        out[f"{condition}_start"] = v.uniform
        for what, ratio in (("pictures", v.pictures), ("energy", v.energy)):
            out[f"{condition}_{what}"] = ratio.mean
            out[f"{condition}_{what}_low"] = ratio.low
            out[f"{condition}_{what}_high"] = ratio.high
    return out


@dataclass
class SearchState:
    """Where a search stands after a generation (``search.json``)."""

    generation: int = 0
    decisions: int = 0
    mu: list[float] = field(default_factory=lambda: [0.0] * len(LINEAR_TERMS))
    seconds: float = 0.0


def generation_scenarios(config: SearchConfig, generation: int) -> list[tuple[Scenario, list[int]]]:
    """The scenarios and seeds of one generation (drawn from ``config.seed`` and the
    generation's number, so a resumed search plays what the interrupted one would have)."""
    rng = np.random.default_rng([config.seed, generation, 0x5EA4C])
    out = []
    for _ in range(config.scenarios):
        scenario = draw_scenario(rng, search_ranges(config))
        seeds = [int(s) for s in rng.integers(0, 2**31, config.seeds)]
        out.append((scenario, seeds))
    return out


def centered_ranks(cost: np.ndarray) -> np.ndarray:
    """``cost``'s ranks scaled to [-0.5, 0.5] (ties broken by position): what the update
    reads instead of the costs themselves, so one outlier scenario cannot dominate it."""
    ranks = np.empty(len(cost))
    ranks[np.argsort(cost, kind="stable")] = np.arange(len(cost))
    return ranks / max(len(cost) - 1, 1) - 0.5


def step(
    state: SearchState,
    config: SearchConfig,
    log: Callable[[dict[str, Any]], None],
    executor: Executor | None = None,
) -> None:
    """One generation: draw mirrored pairs, play them with ``mu`` and the baseline on the same
    scenarios and seeds (in ``executor``'s processes, or here), move ``mu`` down the estimated
    gradient; ``state`` moves on."""
    start = time.perf_counter()
    rng = np.random.default_rng([config.seed, state.generation, 0xD4A3])
    mu = np.asarray(state.mu)
    noise = rng.standard_normal((config.pairs, len(mu))) * moved_terms(config)
    members = np.vstack([mu, mu + config.std * noise, mu - config.std * noise])
    scenarios = generation_scenarios(config, state.generation)
    spec = search_spec(config)
    cost, ratios, decisions = costs(members, scenarios, costing(config), spec, executor)
    ranks = centered_ranks(cost[1:])
    plus, minus = ranks[: config.pairs], ranks[config.pairs :]
    gradient = ((plus - minus)[:, None] * noise).mean(axis=0)
    state.mu = (mu - config.step_size * gradient).tolist()
    state.generation += 1
    state.seconds += time.perf_counter() - start
    state.decisions += decisions
    log(
        {
            "seconds": round(state.seconds, 1),
            "decisions": state.decisions,
            "mu_pictures": ratios[0, 0],
            "mu_energy": ratios[0, 1],
            "mu_cost": float(cost[0]),
            "best_cost": float(cost.min()),
            "step": float(config.step_size * np.linalg.norm(gradient)),
        }
    )


def _write_progress(directory: Path, history: list[dict[str, Any]]) -> None:
    """``progress.csv`` from the history, written atomically."""
    columns: list[str] = []
    for row in history:
        columns += [k for k in row if k not in columns]
    text = io.StringIO(newline="")
    writer = csv.DictWriter(text, columns)
    writer.writeheader()
    writer.writerows(history)
    write_text_atomic(directory / "progress.csv", text.getvalue())


def search(
    config: SearchConfig,
    directory: Path,
    log: Callable[[str], None] = print,
    resume: bool = False,
) -> np.ndarray:
    """Run (or, with ``resume``, continue) the search in ``directory`` and save the final
    ``mu`` as ``directory / "agent.zip"``; returns ``mu``.

    ``search.json`` holds the config, the state and the history after every generation
    (written atomically), so a search killed at any point resumes at the generation it was in
    and loses nothing but that generation's unfinished work.

    Raises:
        FileExistsError: ``directory`` holds a search and ``resume`` is False.
        FileNotFoundError: ``resume`` and there is no search in ``directory``.
        ValueError: ``resume`` with a config other than the saved one.
    """
    from agents.linear_agent import save_linear_agent

    state, history = _open(config, directory, resume)
    path = directory / "search.json"

    def save() -> None:
        data = {
            "config": _config_json(config),
            "state": dataclasses.asdict(state),
            "history": history,
        }
        write_text_atomic(path, json.dumps(data, indent=1))
        _write_progress(directory, history)

    executor = pool(config.workers)
    start_episodes: dict[str, np.ndarray] = {}  # the start's validation, played once

    def validate_mu() -> dict[str, float]:
        spec = search_spec(config)
        mu = np.asarray(state.mu)
        return validate(
            mu,
            config.validation_episodes,
            config.pictures,
            config.rest,
            spec,
            config.crowd or config.dense,
            executor,
            np.asarray(first_mu(config)),
            validation_keys(config),
            start_episodes,
        )

    started = time.perf_counter()
    try:
        while state.generation < config.generations:
            if (time.perf_counter() - started) / 60.0 > config.minutes:
                log(f"stopped at generation {state.generation}: {config.minutes} min are spent")
                break
            row: dict[str, Any] = {}
            if state.generation % config.validate_every == 0:
                row |= validate_mu()
            step(state, config, row.update, executor)
            history.append({"generation": state.generation - 1, **row})
            save()
            log(_summary(history[-1]))
        last = history[-1] if history else {}
        validated = any(k.endswith("_pictures") for k in last if not k.startswith("mu_"))
        if not (last.get("generation") == state.generation and validated):
            history.append({"generation": state.generation, **validate_mu()})
            save()
            log(_summary(history[-1]))
    finally:
        if executor is not None:
            executor.shutdown(cancel_futures=True)
    mu = np.asarray(state.mu)
    save_linear_agent(mu, directory / "agent.zip", search_spec(config))
    return mu


#: The config fields a resumed search may change: they change how fast it runs, not what it finds.
RESUMABLE_FIELDS = ("workers", "minutes")


def _open(
    config: SearchConfig, directory: Path, resume: bool
) -> tuple[SearchState, list[dict[str, Any]]]:
    """The state and history a search in ``directory`` starts from (see :func:`search`)."""
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / "search.json"
    if path.exists() and not resume:
        raise FileExistsError(f"{directory} holds a search: resume it, or choose another folder")
    if not resume:
        return SearchState(mu=first_mu(config)), []
    if not path.exists():
        raise FileNotFoundError(f"no search to resume in {directory}")
    saved = json.loads(path.read_text())
    before = {**_config_json(SearchConfig()), **saved["config"]}
    now = _config_json(config)
    for name in RESUMABLE_FIELDS:
        before.pop(name, None)
        now.pop(name, None)
    if before != now:
        raise ValueError(f"{directory} was searched with another config: {saved['config']}")
    return SearchState(**saved["state"]), saved["history"]


def saved_config(directory: Path, **changes: Any) -> SearchConfig:
    """The config of the search saved in ``directory`` (its ``search.json``), with ``changes``
    (fields of :class:`SearchConfig`) applied: what ``anonloc search OUT --resume`` continues
    with, the options given on its command line replacing the saved ones (:func:`search` then
    refuses any but ``workers`` and ``minutes`` that differs).

    Raises:
        FileNotFoundError: no search in ``directory``.
        ValueError: a saved field or a change is not a valid :class:`SearchConfig` field.
    """
    path = Path(directory) / "search.json"
    if not path.exists():
        raise FileNotFoundError(f"no search to resume in {directory}")
    saved = dict(json.loads(path.read_text())["config"])
    ranges: dict[str, Any] = {
        k: tuple(v) if isinstance(v, list) else v for k, v in saved.pop("ranges").items()
    }
    known = {f.name for f in dataclasses.fields(SearchConfig)}
    unknown = sorted((set(saved) | set(changes)) - known)
    if unknown:
        raise ValueError(f"not fields of SearchConfig: {unknown}")
    return SearchConfig(**{**saved, "ranges": ConditionRanges(**ranges), **changes})


def _config_json(config: SearchConfig) -> dict[str, Any]:
    data: dict[str, Any] = json.loads(json.dumps(dataclasses.asdict(config)))
    return data


def _summary(row: dict[str, Any]) -> str:
    text = f"generation {row['generation']}"
    if "mu_pictures" in row:
        text += (
            f": train pictures {row['mu_pictures']:.3f}x, energy {row['mu_energy']:.3f}x uniform"
            f", cost {row['mu_cost']:.3f} (best member {row['best_cost']:.3f}), step"
            f" {row['step']:.2f}"
        )
    if any(c + "_pictures" in row for c in ("free", "swarm", "crowd")):
        text += "; validation " + ", ".join(
            f"{c} {row[c + '_pictures']:.3f}x [{row[c + '_pictures_low']:.2f}, "
            f"{row[c + '_pictures_high']:.2f}] pictures, {row[c + '_energy']:.3f}x energy"
            for c in ("free", "swarm", "crowd")
            if c + "_pictures" in row
        )
    return text
