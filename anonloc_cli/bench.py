"""``anonloc bench``: policies x scenarios x seeds, one row per robot and episode.

Each unit plays one episode: ``env = anonloc_env.parallel_env(**scenario,
reward_fn=EnergyCost())`` (rewards are never read), a team of all its robots running the policy,
``baselines.runner.run_episode(env, team, seed, max_pictures=K)``.

Columns of the output (CSV, or Parquet when the path ends in ``.parquet``):

| column | meaning |
|---|---|
| `policy`, `scenario`, `mode`, `excitation` | what ran (`excitation` empty: the policy's own) |
| `n_robots`, `seed`, `robot` | which episode and robot |
| `pictures_to_decision` | pictures seen at the robot's first decision (empty: never decided) |
| `decision_time` | when that picture was taken (s) |
| `correct` | that first decision was the robot's true row |
| `energy` | wheel travel until that decision (m; empty: never decided) |
| `energy_total` | wheel travel until the last scored picture (m) |
| `belief_true` | the belief the robot gave its true row at each picture (a list; JSON in CSV) |
| `correct_by_picture` | at each picture: decided on its true row (a list) |
| `present_by_picture` | at each picture: in it (a list) |
| `energy_by_picture` | at each picture: wheel travel since reset (m; a list) |

The last three give each episode's pictures until 99 % of the robots present are identified
(:func:`identified_at`), the measure of ``anonloc eval``.

Next to ``PATH``: ``PATH.md`` (summary table and provenance), ``PATH.meta.json`` (provenance) and
the resumable store ``PATH.units.jsonl``.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from anonloc_cli import jobs, provenance, store, tables
from anonloc_cli.jobs import Unit
from anonloc_cli.scenarios import Scenario
from baselines.paper import Rate

#: Columns and their types (for Parquet).
TYPES = {
    "policy": "string",
    "scenario": "string",
    "mode": "string",
    "excitation": "string",
    "n_robots": "int64",
    "seed": "int64",
    "robot": "int64",
    "pictures_to_decision": "int64",
    "decision_time": "float64",
    "correct": "bool",
    "energy": "float64",
    "energy_total": "float64",
    "belief_true": "list<float64>",
    "correct_by_picture": "list<bool>",
    "present_by_picture": "list<bool>",
    "energy_by_picture": "list<float64>",
}
COLUMNS = list(TYPES)


def store_path(out: Path) -> Path:
    """The resumable store of output ``out``."""
    return out.with_name(f"{out.stem}.units.jsonl")


@dataclass(frozen=True)
class Entry:
    """One contender: a policy with its excitation and arguments, under a label.

    Attributes:
        label: the ``policy`` column of its rows.
        policy: a policy name (see ``baselines.policy_names()``).
        excitation: the motion between pictures (None: the policy's own).
        kwargs: more arguments of the policy (``agent``: ``path``); plain JSON values.
        identity: what else decides the results and is not in ``kwargs`` (``agent``: a hash
            of the agent file, so a rewritten file at the same path runs again); None: nothing.
    """

    label: str
    policy: str
    excitation: str | None = None
    kwargs: dict[str, Any] = field(default_factory=dict)
    identity: str | None = None


def units(
    scenarios: Sequence[Scenario],
    entries: Sequence[Entry],
    seeds: int,
    *,
    mode: str,
    pictures: int | None,
) -> list[Unit]:
    """One unit per (entry, scenario, seed)."""
    return [
        Unit(
            "bench",
            scenario.spec,
            entry.policy,
            seed,
            {
                "scenario": scenario.name,
                "mode": mode,
                "excitation": entry.excitation,
                "pictures": pictures,
                "label": entry.label,
                "kwargs": entry.kwargs,
                **({} if entry.identity is None else {"identity": entry.identity}),
            },
        )
        for entry in entries
        for scenario in scenarios
        for seed in range(seeds)
    ]


def run_unit(unit: Unit) -> list[dict[str, Any]]:
    """Play one episode; one row per robot (see the module's table)."""
    from anonloc_cli.teams import play

    p = unit.params
    result = play(unit)
    own = [r for r in result.records if r.localizer == ""]
    rows = []
    for d in result.decisions():
        mine = sorted((r for r in own if r.robot == d.robot), key=lambda r: r.picture)
        decided = d.picture >= 0
        rows.append(
            {
                "policy": p.get("label", unit.policy),
                "scenario": p["scenario"],
                "mode": p["mode"],
                "excitation": p["excitation"],
                "n_robots": result.n_robots,
                "seed": unit.seed,
                "robot": d.robot,
                "pictures_to_decision": d.picture + 1 if decided else None,
                "decision_time": d.time if decided else None,
                "correct": bool(d.correct),
                "energy": d.energy if decided else None,
                "energy_total": mine[-1].energy if mine else 0.0,
                "belief_true": [round(r.belief_true, 6) for r in mine],
                "correct_by_picture": [bool(r.correct) for r in mine],
                "present_by_picture": [r.true_index >= 0 for r in mine],
                "energy_by_picture": [round(r.energy, 6) for r in mine],
            }
        )
    return rows


def summary(rows: Sequence[dict[str, Any]]) -> tuple[list[str], list[list[str]]]:
    """Per (policy, scenario): success with its Wilson interval, pictures and energy."""
    groups: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for row in rows:
        groups.setdefault((row["policy"], row["scenario"]), []).append(row)
    headers = [
        "policy",
        "scenario",
        "robots",
        "success (95 % CI)",
        "decided",
        "pictures to decision (95 % CI)",
        "energy at decision, m (95 % CI)",
    ]
    out = []
    for (policy, scenario), mine in groups.items():
        rate = Rate(sum(bool(r["correct"]) for r in mine), len(mine))
        decided = [r for r in mine if r["pictures_to_decision"] is not None]
        out.append(
            [
                policy,
                scenario,
                str(len(mine)),
                tables.rate_text(rate),
                f"{100 * len(decided) / len(mine):.1f} %",
                str(tables.mean_interval([r["pictures_to_decision"] for r in decided])),
                str(tables.mean_interval([r["energy"] for r in decided])),
            ]
        )
    return headers, out


def identified_at(
    rows: Sequence[dict[str, Any]], fraction: float = 0.99
) -> tuple[int | None, float]:
    """One episode's rows (one per robot): :func:`baselines.scoring.first_identified`, the
    picture (0: the one at reset) at which ``fraction`` of the robots present are decided on
    their true row, and the mean wheel travel per robot until then (m)."""
    from baselines.scoring import first_identified

    if not rows:
        return None, float("nan")
    return first_identified(
        np.array([r["correct_by_picture"] for r in rows], bool),
        np.array([r["present_by_picture"] for r in rows], bool),
        np.array([r["energy_by_picture"] for r in rows], float),
        fraction,
    )


def episode_summary(
    rows: Sequence[dict[str, Any]], fraction: float = 0.99
) -> tuple[list[str], list[list[str]]]:
    """Per (policy, scenario): pictures seen until ``fraction`` of the robots present are
    identified (the one at reset counted as 1, as ``pictures_to_decision`` counts) over every
    episode (one that never got there counts at its last picture: the censored mean,
    with a 95 % bootstrap interval; and the Kaplan-Meier median, that episode censored there,
    with its 95 % interval), and the energy per robot until then over the episodes that got
    there (95 % normal interval)."""
    from baselines.statistics import bootstrap_mean, km_median

    episodes: dict[tuple[str, str], dict[int, list[dict[str, Any]]]] = {}
    for row in rows:
        key = (row["policy"], row["scenario"])
        episodes.setdefault(key, {}).setdefault(row["seed"], []).append(row)
    percent = f"{100 * fraction:g} %"
    headers = [
        "policy",
        "scenario",
        "episodes",
        f"reached {percent}",
        f"pictures to {percent}, censored mean (95 % CI)",
        "Kaplan-Meier median (95 % CI)",
        "energy per robot, m (95 % CI)",
    ]
    out = []
    for (policy, scenario), by_seed in episodes.items():
        results = [identified_at(mine, fraction) for mine in by_seed.values()]
        last = [max(len(r["correct_by_picture"]) for r in mine) - 1 for mine in by_seed.values()]
        # pictures seen (the one at reset is 1), as "pictures to decision" counts them
        times = [1 + (end if p is None else p) for (p, _), end in zip(results, last, strict=True)]
        reached = [p is not None for p, _ in results]
        out.append(
            [
                policy,
                scenario,
                str(len(results)),
                f"{100 * sum(reached) / len(results):.1f} %",
                str(bootstrap_mean(times)),
                str(km_median(times, reached)),
                str(tables.mean_interval([e for p, e in results if p is not None])),
            ]
        )
    return headers, out


def main(
    scenarios: Sequence[Scenario],
    entries: Sequence[Entry],
    seeds: int,
    out: Path,
    *,
    mode: str,
    pictures: int | None,
    run: jobs.RunOptions,
    identification: bool = False,
) -> int:
    """Run (or resume) the bench and write its rows and summary; the exit status.

    Both tables are shown: success at the first decision (:func:`summary`) and the pictures until
    99 % are identified (:func:`episode_summary`); ``identification`` (``anonloc eval``) titles
    the second as the command's own measure.
    """
    from anonloc_env.presets import config_to_dict

    start = time.perf_counter()
    work = units(scenarios, entries, seeds, mode=mode, pictures=pictures)
    policies = [e.label for e in entries]
    excitations = sorted({e.excitation or "" for e in entries})
    excitation = excitations[0] or None if len(excitations) == 1 else ", ".join(excitations)
    command = "eval" if identification else "bench"
    report, records = jobs.run_stored(work, store_path(out), run, description=command)
    rows = [row for u in work if u.key in records for row in records[u.key]["result"]]
    record = provenance.provenance(
        {s.name: config_to_dict(s.config) for s in scenarios},
        policies=list(policies),
        seeds=seeds,
        mode=mode,
        excitation=excitation,
        pictures=pictures,
        backend=run.backend,
    )
    if out.suffix.lower() == ".parquet":
        store.write_parquet(out, rows, TYPES, record)
    else:
        store.write_csv(out, rows, COLUMNS)
    store.write_json(store.meta_path(out), record)
    headers, table = summary(rows)
    wall = time.perf_counter() - start
    tables.show(f"{command}: success at each robot's first decision", headers, table)
    lines = [
        f"# Bench: {', '.join(policies)} on {', '.join(s.name for s in scenarios)}",
        "",
        tables.markdown(headers, table),
        "",
        f"{len(rows)} rows in `{out.name}`. Success: the robot's first decision was its true "
        "row (95 % Wilson interval); pictures and energy: mean over the robots that decided "
        "(95 % normal interval).",
        "",
    ]
    headers, table = episode_summary(rows)
    tables.show(
        f"{command}: pictures until 99 % of the robots present are identified", headers, table
    )
    lines += [
        "## Pictures until 99 % of the robots present are identified",
        "",
        tables.markdown(headers, table),
        "",
        "Per episode: the pictures seen (the one at reset counted as 1, as in pictures to "
        "decision) until at least 99 % of the robots in a picture are decided (belief >= 0.99) "
        "on their true row; `baselines.scoring.pictures_to_identify` and the tables of "
        "docs/agents.md count the pictures after the first, one less. Over every episode: an "
        "episode that never got there counts at its last picture in the censored mean (a lower "
        "bound; 95 % bootstrap interval) and is censored there in the Kaplan-Meier median (95 % "
        "interval; `inf`: too few episodes got there to bound it). Energy: the mean wheel "
        "travel per robot until then, over the episodes that got there (95 % normal interval).",
        "",
    ]
    text = "\n".join([*lines, provenance.markdown(record)])
    store.write_text(out.with_suffix(".md"), text)
    wrote = f"{out} ({len(rows)} rows) and {out.with_suffix('.md')}"
    return jobs.finish(report, wrote=wrote, what="episodes", seconds=wall)
