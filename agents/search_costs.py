"""What a search's members cost: episodes against a baseline on the same seeds, in one process
or in a pool of worker processes.

Every member of a generation and the baseline play the same scenarios and seeds (common random
numbers), so what differs between two members is their weights alone. Each scenario's member
ratios, censored pictures to 99 % and energy to 99 % over the baseline's, enter the cost as logs
(:func:`member_costs`). The episodes are independent jobs: with ``workers > 1`` they run in a
pool of processes started with ``spawn`` (never forked: the main process may hold torch's
threads), the largest scenarios first, and the costs are the same bits as in one process
(tested), because every episode is seeded by its own seed alone.
"""

from __future__ import annotations

import math
import multiprocessing
from collections.abc import Sequence
from concurrent.futures import Executor, ProcessPoolExecutor
from dataclasses import dataclass

import numpy as np

from agents.conditions import Scenario
from agents.evaluation import Player, censored, play
from agents.linear_agent import LINEAR_SPEC
from agents.linear_chooser import chooser
from agents.spec import AgentSpec


@dataclass(frozen=True)
class Costing:
    """How a generation's episodes are played and judged (from ``agents.search.SearchConfig``).

    Attributes:
        pictures: pictures per episode (an episode that never reaches 99 % counts there).
        rest: the members' rest (``RestWhenSure``'s ``sure``; None: they never rest).
        baseline_rest: the baseline's (zero weights) rest: ``rest`` to measure against the
            ablation (``uniform-rest``), None for plain ``uniform``.
        energy_weight: the weight of the energy part of the cost (:func:`member_costs`).
        energy_cap: the energy ratio under which energy costs nothing (None: no cap).
    """

    pictures: int
    rest: float | None
    baseline_rest: float | None
    energy_weight: float
    energy_cap: float | None


def play_weights(
    scenario: Scenario,
    weights: np.ndarray,
    seeds: Sequence[int],
    pictures: int,
    rest: float | None = None,
    spec: AgentSpec = LINEAR_SPEC,
) -> tuple[np.ndarray, int]:
    """``(firsts, decisions)``: ``(len(seeds), 2)`` censored pictures to 99 % and energy to
    99 % (m) of ``bayes`` robots driven by :func:`agents.linear_chooser.chooser` ``(weights,
    rest, spec)``, and the robot-decisions (robots times pictures) the episodes took."""
    make = chooser(weights, rest, spec)
    results = play(scenario.config, scenario.condition, scenario.budget, make, seeds, pictures)
    decisions = sum(len(r.records) for r in results)
    return np.array([censored(r, pictures) for r in results], np.float64), decisions


def _play_job(
    job: tuple[Scenario, np.ndarray, Sequence[int], int, float | None, AgentSpec],
) -> tuple[np.ndarray, int]:
    return play_weights(*job)


def member_costs(ratios: np.ndarray, energy_weight: float, energy_cap: float | None) -> np.ndarray:
    """``(P,)`` each member's cost from its ``(P, S, 2)`` picture and energy ratios to the
    baseline on ``S`` scenarios: the mean over the scenarios of ``log(picture ratio) +
    energy_weight * e``, where ``e`` is ``log(energy ratio)``, or, with ``energy_cap``,
    ``max(0, log(energy ratio / energy_cap))``: energy at or under ``energy_cap`` times the
    baseline's then costs nothing, and only pictures are traded (the issue's first target asks
    for no more pictures than ``uniform`` at no more than 0.8x its energy).

    >>> r = np.array([[[1.0, 0.7], [1.1, 0.9]]])
    >>> round(float(member_costs(r, 1.0, 0.8)[0]), 4)  # (log 1.1 + log(0.9 / 0.8)) / 2
    0.1065
    """
    logs = np.log(ratios)
    energy = logs[..., 1]
    if energy_cap is not None:
        energy = np.maximum(energy - math.log(energy_cap), 0.0)
    out: np.ndarray = logs[..., 0].mean(axis=1) + energy_weight * energy.mean(axis=1)
    return out


def pooled_player(
    executor: Executor,
    weights: tuple[np.ndarray, np.ndarray],
    rest: float | None,
    spec: AgentSpec,
    chunk: int = 2,
) -> Player:
    """A player of validation episodes (``agents.evaluation.Player``) in ``executor``'s
    processes: ``weights[0]`` (the excitation) or ``weights[1]`` (its ablation) at ``rest``,
    ``chunk`` seeds a job; the same episodes as one process plays (every episode is seeded by
    its own seed alone)."""

    def player(scenario: Scenario, which: int, seeds: Sequence[int], pictures: int) -> np.ndarray:
        seeds = list(seeds)
        futures = [
            executor.submit(
                _play_job, (scenario, weights[which], seeds[i : i + chunk], pictures, rest, spec)
            )
            for i in range(0, len(seeds), chunk)
        ]
        return np.concatenate([f.result()[0] for f in futures])

    return player


def pool(workers: int) -> ProcessPoolExecutor | None:
    """A pool of ``workers`` spawned processes, or None for one process (``workers == 1``)."""
    if workers <= 1:
        return None
    return ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn"))


def costs(
    members: np.ndarray,
    scenarios: Sequence[tuple[Scenario, Sequence[int]]],
    costing: Costing,
    spec: AgentSpec,
    executor: Executor | None = None,
) -> tuple[np.ndarray, np.ndarray, int]:
    """``(cost (P,), ratios (P, 2), decisions)``: each member's cost (:func:`member_costs`), its
    geometric-mean picture and energy ratios to the baseline (zero weights at
    ``costing.baseline_rest``) over ``scenarios`` (each with its seeds), and the robot-decisions
    played (the baseline's included). ``executor`` runs the episodes (None: here)."""
    c = costing
    zeros = np.zeros(len(spec.terms))
    jobs = []
    for scenario, seeds in scenarios:
        jobs.append((scenario, zeros, seeds, c.pictures, c.baseline_rest, spec))
        jobs += [(scenario, w, seeds, c.pictures, c.rest, spec) for w in members]
    if executor is None:
        played = [_play_job(job) for job in jobs]
    else:
        # The largest scenarios first, so that no worker is left with one at the end.
        order = sorted(range(len(jobs)), key=lambda j: -jobs[j][0].config.n_robots)
        futures = {j: executor.submit(_play_job, jobs[j]) for j in order}
        played = [futures[j].result() for j in range(len(jobs))]
    ratios = np.zeros((len(members), len(scenarios), 2))
    per = len(members) + 1
    for s in range(len(scenarios)):
        base = np.maximum(played[s * per][0].mean(axis=0), 1e-9)
        for m in range(len(members)):
            ratios[m, s] = played[s * per + 1 + m][0].mean(axis=0) / base
    cost = member_costs(ratios, c.energy_weight, c.energy_cap)
    return cost, np.exp(np.log(ratios).mean(axis=1)), sum(d for _, d in played)
