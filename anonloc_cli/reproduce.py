"""``anonloc reproduce``: the paper's table, re-run on the simulator, next to the paper's figures.

Each run is :func:`baselines.paper.run` (method, seed) for seeds ``0..runs-1``: one episode of the
method's ``paper-*`` preset with two robots localizing at once, scored by the faithful and the
corrected version of the method and by the Bayesian identifier on the very same episode. Success
is counted per robot at its first decision, as in the paper (two robots per run).
"""

from __future__ import annotations

import dataclasses
import math
import time
from pathlib import Path
from typing import Any

from anonloc_cli import jobs, provenance, store, tables
from anonloc_cli.jobs import Unit
from baselines.paper import EXPERIMENTS, RunOutcome, summarise

#: Columns of the table, as the paper orders them.
METHODS = list(EXPERIMENTS)
#: Slowest first, so that the pool's last units are short ones.
_ORDER = ("motion", "angular", "linear")
TITLES = {"angular": "Angular (II.A)", "linear": "Linear (II.B)", "motion": "Motion (II.C)"}

CSV_COLUMNS = [
    "method",
    "preset",
    "seed",
    "robot",
    "faithful",
    "corrected",
    "faithful_picture",
    "corrected_picture",
    "bayes_first",
    "bayes_picture",
    "bayes_at_4th",
    "deviation",
    "deviation_label",
]


def units(runs: dict[str, int]) -> list[Unit]:
    """One unit per (method, seed), for ``runs[method]`` seeds of each."""
    return [
        Unit("paper", {"preset": EXPERIMENTS[m].preset}, m, seed, {})
        for m in _ORDER
        for seed in range(runs[m])
    ]


def run_unit(unit: Unit) -> dict[str, Any]:
    """One run of the paper's experiment ``unit.policy`` with seed ``unit.seed``."""
    from baselines.paper import run

    outcome = run(unit.policy, unit.seed)
    return {f.name: _plain(getattr(outcome, f.name)) for f in dataclasses.fields(RunOutcome)}


def _plain(value: Any) -> Any:
    if isinstance(value, (tuple, list)):
        return [_plain(v) for v in value]
    if hasattr(value, "item"):  # numpy scalars
        return value.item()
    return value


def outcome(result: dict[str, Any]) -> RunOutcome:
    """A stored result back as a :class:`RunOutcome`."""
    fields: dict[str, Any] = {k: tuple(v) if isinstance(v, list) else v for k, v in result.items()}
    return RunOutcome(**fields)


def table(outcomes: dict[str, list[RunOutcome]]) -> tuple[list[str], list[list[str]]]:
    """The comparison table: headers and rows (ours with 95 % Wilson intervals, the paper's)."""
    summaries: dict[str, dict[str, Any]] = {m: summarise(outcomes[m]) for m in METHODS}
    headers = ["", *(TITLES[m] for m in METHODS)]

    def row(label: str, cell: Any) -> list[str]:
        return [label, *(cell(m) for m in METHODS)]

    def ours(field: str) -> Any:
        return lambda m: str(summaries[m][field]) if summaries[m]["runs"] else "n/a"

    def unit(m: str) -> str:  # the degree sign of the angular measures, as the README prints
        return "°" if EXPERIMENTS[m].deviation_label.endswith("(deg)") else ""

    def deviation(m: str) -> str:
        mean, std = summaries[m]["deviation_mean"], summaries[m]["deviation_std"]
        return "n/a" if not math.isfinite(mean) else f"{_num(mean)} ± {_num(std)}{unit(m)}"

    rows = [
        row(
            "Runs (ours / paper)",
            lambda m: f"{summaries[m]['runs']} / {EXPERIMENTS[m].runs}",
        ),
        row("Success, faithful", ours("faithful")),
        row("Success, corrected", ours("corrected")),
        row("Success, Bayes (first decision)", ours("bayes_first")),
        row("Success, Bayes at 4th picture", ours("bayes_at_4th")),
        row("Success, paper", lambda m: f"{EXPERIMENTS[m].success:.1f} %"),
        row("Second row: measures", lambda m: EXPERIMENTS[m].deviation_label),
        row("Second row, ours (mean ± std)", deviation),
        row(
            "Second row, paper (mean ± std)",
            lambda m: "{} ± {}".format(*EXPERIMENTS[m].deviation) + unit(m),
        ),
    ]
    return headers, rows


def _num(x: float) -> str:
    return f"{x:.3g}" if abs(x) < 10 else f"{x:.1f}"


def csv_rows(outcomes: dict[str, list[RunOutcome]]) -> list[dict[str, Any]]:
    """One row per run and robot."""
    out = []
    for method in METHODS:
        for o in outcomes[method]:
            for robot in range(len(o.corrected)):
                row: dict[str, Any] = {
                    "method": method,
                    "preset": EXPERIMENTS[method].preset,
                    "seed": o.seed,
                    "robot": robot,
                    "deviation_label": EXPERIMENTS[method].deviation_label,
                }
                for name in CSV_COLUMNS[4:-1]:
                    row[name] = getattr(o, name)[robot]
                out.append(row)
    return out


def main(
    runs: dict[str, int],
    out: Path,
    run: jobs.RunOptions,
) -> int:
    """Run (or resume) the paper's experiments and write the table; the exit status."""
    import anonloc_env
    from anonloc_env.presets import config_to_dict

    start = time.perf_counter()
    work = units(runs)
    report, records = jobs.run_stored(work, out / "reproduce.jsonl", run, description="reproduce")
    outcomes: dict[str, list[RunOutcome]] = {m: [] for m in METHODS}
    for unit in work:
        if unit.key in records:
            outcomes[unit.policy].append(outcome(records[unit.key]["result"]))
    for runs_list in outcomes.values():
        runs_list.sort(key=lambda o: o.seed)
    wall = time.perf_counter() - start
    compute = sum(records[u.key].get("seconds", 0.0) for u in work if u.key in records)
    headers, rows = table(outcomes)
    configs = {
        EXPERIMENTS[m].preset: config_to_dict(anonloc_env.make_config(EXPERIMENTS[m].preset))
        for m in METHODS
    }
    record = provenance.provenance(
        configs,
        runs=runs,
        backend=run.backend,
        units_run=report.ran,
        units_reused=report.skipped,
        wall_time_s=round(wall, 1),
        compute_time_s=round(compute, 1),
    )
    title = "The paper's table, reproduced (success per robot at its first decision, 95 % CI)"
    tables.show(title, headers, rows)
    text = "\n".join(
        [
            "# The paper's table, reproduced",
            "",
            tables.markdown(headers, rows),
            "",
            "Success is counted per robot at its first decision (two robots per run); the "
            "intervals are 95 % Wilson intervals. The paper's runs are Player/Stage runs; ours "
            "are seeded episodes of the `paper-*` presets (seeds 0 to runs - 1).",
            "",
            f"Wall time: {wall:.1f} s ({report.ran} runs executed, {report.skipped} reused from "
            f"`{out / 'reproduce.jsonl'}`); the runs took {compute:.1f} s of worker time in all.",
            "",
            provenance.markdown(record),
        ]
    )
    store.write_text(out / "reproduce.md", text)
    store.write_csv(out / "reproduce.csv", csv_rows(outcomes), CSV_COLUMNS)
    store.write_json(store.meta_path(out / "reproduce.csv"), record)
    wrote = f"{out / 'reproduce.md'} and {out / 'reproduce.csv'}"
    return jobs.finish(report, wrote=wrote, what="runs", seconds=wall)
