"""``anonloc study``: sweeps answering the paper's future-work questions (see :mod:`.sweeps`).

Each sweep writes, in the output folder, ``NAME.csv`` (one row per point and policy: the success
rate with its 95 % Wilson interval, the mean pictures with a 95 % normal interval),
``NAME.png`` and ``NAME.svg`` (the plot, with the intervals as bands), and ``NAME.meta.json``
(versions, command, and the resolved config of every point). The episodes go through the same
resumable store (``study.jsonl``) and backends as ``bench``.

Success rates count robots (several per episode); the robots of one episode are not independent,
so with few episodes of many robots the intervals are narrower than the truth.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from anonloc_cli import jobs, plots, provenance, store, sweeps, tables
from anonloc_cli.jobs import Unit
from anonloc_cli.scenarios import InputError
from baselines.paper import Rate

CSV_COLUMNS = [
    "sweep",
    "x",
    "variant",
    "policy",
    "episodes",
    "robots",
    "successes",
    "success",
    "success_low",
    "success_high",
    "decided",
    "pictures_count",
    "pictures_mean",
    "pictures_low",
    "pictures_high",
]


def check_sweeps(names: list[str]) -> list[sweeps.Sweep]:
    """The named sweeps (all when none is named); an unknown name is an :class:`InputError`."""
    valid = list(sweeps.SWEEPS)
    unknown = [n for n in names if n not in valid]
    if unknown:
        from anonloc_env._checks import did_you_mean

        hint = did_you_mean(unknown[0], valid)
        raise InputError(f"unknown sweep {unknown[0]!r}{hint}; valid: {valid}")
    return [sweeps.SWEEPS[n] for n in (names or valid)]


def points(sweep: sweeps.Sweep) -> list[tuple[float, dict[str, Any]]]:
    """Each point's x and scenario spec, resolved (and so checked) through the env's config."""
    from anonloc_cli.scenarios import build

    out = []
    for x in sweep.xs:
        spec = {"preset": "default", **sweeps.overrides(sweep, x)}
        out.append((x, build(f"{sweep.name}={x}", spec).spec))
    return out


def units(sweep: sweeps.Sweep, seeds: int) -> list[Unit]:
    """One unit per point, policy variant and seed."""
    return [
        Unit(
            "study",
            spec,
            variant.policy,
            seed,
            {
                "sweep": sweep.name,
                "x": x,
                "variant": variant.label,
                "kwargs": variant.kwargs,
                "excitation": sweeps.excitation(sweep, x),
                "pictures": sweeps.pictures(sweep),
                "measure": sweep.measure,
                "after": sweeps.after(sweep, x),
            },
        )
        for x, spec in points(sweep)
        for variant in sweep.variants
        for seed in range(seeds)
    ]


def run_unit(unit: Unit) -> dict[str, Any]:
    """One episode; per robot: pictures to its first decision and whether it was right, or (for
    ``reid``) pictures after the blackout until its true row's belief is high again."""
    from anonloc_cli.teams import play

    p = unit.params
    result = play(unit)
    if p["measure"] == "reid":
        return {"reid": _reid(result, p["after"])}
    decisions = result.decisions()
    return {
        "pictures": [d.picture + 1 if d.picture >= 0 else None for d in decisions],
        "correct": [d.correct for d in decisions],
    }


def _reid(result: Any, after: float) -> list[int | None]:
    """Per robot, the 1-based count of pictures at or after ``after`` (s) up to the first whose
    belief in the robot's true row reaches :data:`~.sweeps.REID_BELIEF` (None: never)."""
    out: list[int | None] = []
    for robot in range(result.n_robots):
        later = [
            r
            for r in result.records
            if r.localizer == "" and r.robot == robot and r.time >= after - 1e-6
        ][: sweeps.REID_PICTURES]
        hit = next(
            (
                k
                for k, r in enumerate(later, 1)
                if r.true_index >= 0 and r.belief_true >= sweeps.REID_BELIEF
            ),
            None,
        )
        out.append(hit)
    return out


def aggregate(
    sweep: sweeps.Sweep, work: list[Unit], records: dict[str, Any]
) -> list[dict[str, Any]]:
    """One row per point and variant (see :data:`CSV_COLUMNS`)."""
    groups: dict[tuple[float, str], list[dict[str, Any]]] = {}
    policies: dict[str, str] = {}
    for unit in work:
        key = (unit.params["x"], unit.params["variant"])
        policies[unit.params["variant"]] = unit.policy
        groups.setdefault(key, [])
        if unit.key in records:
            groups[key].append(records[unit.key]["result"])
    rows = []
    for (x, variant), results in groups.items():
        if sweep.measure == "reid":
            reached = [r for res in results for r in res["reid"]]
            success = [r is not None for r in reached]
            counts = [r for r in reached if r is not None]
        else:
            success = [c for res in results for c in res["correct"]]
            counts = [p for res in results for p in res["pictures"] if p is not None]
        rate = Rate(sum(success), len(success))
        low, high = rate.interval
        mean = tables.mean_interval(counts)
        rows.append(
            {
                "sweep": sweep.name,
                "x": x,
                "variant": variant,
                "policy": policies[variant],
                "episodes": len(results),
                "robots": len(success),
                "successes": rate.successes,
                "success": rate.value,
                "success_low": low,
                "success_high": high,
                "decided": len(counts) / len(success) if success else float("nan"),
                "pictures_count": mean.count,
                "pictures_mean": mean.value,
                "pictures_low": mean.low,
                "pictures_high": mean.high,
            }
        )
    return rows


def labels(sweep: sweeps.Sweep) -> tuple[str, str]:
    """The y labels of the two panels."""
    if sweep.measure == "reid":
        return (
            f"identified again within {sweeps.REID_PICTURES} pictures (%)",
            f"pictures after it until belief >= {sweeps.REID_BELIEF:g} (count)",
        )
    return ("success at first decision (%)", "pictures to first decision (count)")


def main(
    names: list[str],
    out: Path,
    *,
    seeds: int,
    run: jobs.RunOptions,
) -> int:
    """Run (or resume) the sweeps and write their plots and data; the exit status."""
    start = time.perf_counter()
    chosen = check_sweeps(names)
    work = {s.name: units(s, seeds) for s in chosen}  # every config is checked here
    everything = [u for s in chosen for u in work[s.name]]
    report, records = jobs.run_stored(everything, out / "study.jsonl", run, description="study")
    for sweep in chosen:
        _write(sweep, work[sweep.name], records, out, seeds=seeds, backend=run.backend)
    files = ", ".join(f"{s.name}.{{png,svg,csv,meta.json}}" for s in chosen)
    wrote = f"{len(chosen)} sweep{'s' if len(chosen) > 1 else ''} to {out}: {files}"
    return jobs.finish(report, wrote=wrote, what="episodes", seconds=time.perf_counter() - start)


def _write(
    sweep: sweeps.Sweep,
    work: list[Unit],
    records: dict[str, Any],
    out: Path,
    *,
    seeds: int,
    backend: str,
) -> None:
    import anonloc_env
    from anonloc_env.presets import config_to_dict

    rows = aggregate(sweep, work, records)
    configs = {
        f"{sweep.name}={x}": config_to_dict(anonloc_env.make_config(**spec))
        for x, spec in points(sweep)
    }
    record = provenance.provenance(
        configs,
        sweep=sweep.name,
        seeds=seeds,
        variants={v.label: {"policy": v.policy, **v.kwargs} for v in sweep.variants},
        measure=sweep.measure,
        backend=backend,
    )
    store.write_csv(out / f"{sweep.name}.csv", rows, CSV_COLUMNS)
    store.write_json(store.meta_path(out / f"{sweep.name}.csv"), record)
    plots.sweep(sweep, rows, labels(sweep), out / sweep.name, record)
    headers = ["x", "policy", "robots", "success (95 % CI)", "pictures (95 % CI)"]
    table = [
        [
            f"{r['x']:g}",
            r["variant"],
            str(r["robots"]),
            tables.rate_text(Rate(r["successes"], r["robots"])),
            str(
                tables.Mean(
                    r["pictures_mean"], r["pictures_low"], r["pictures_high"], r["pictures_count"]
                )
            ),
        ]
        for r in rows
    ]
    tables.show(f"{sweep.name}: {sweep.title}", headers, table)
