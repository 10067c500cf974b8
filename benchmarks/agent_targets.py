"""Issue 24's targets, judged from the rows of ``benchmarks/agent_eval.py`` (``docs/agents.md``,
*Results*).

For every condition with rows for ``agent`` and ``uniform`` it prints, paired on the seeds both
played (the first ``n`` of the same evaluation seeds):

* agent / ``uniform``, pictures to 99 % (censored) and energy to 99 %, with 95 % bootstrap
  intervals, and **target 1**: *met* where the agent needs no more pictures (point estimate at
  most 1) at no more than 0.8x the energy; *within the interval* where the pictures' point
  estimate is above 1 but its interval reaches 1, at no more than 0.8x the energy; else *missed*;
* agent / ``uniform-rest`` (the ablation at the same rest), where it was run;
* the better of ``distinct`` and ``greedy`` (the one with fewer pictures on those seeds), the
  agent's paired ratios to it (pictures, energy, 95 % intervals), and **target 2**: *met* where
  the agent's mean pictures and energy over the same seeds are both no more than its own;
  *within the interval* where a ratio above 1 has an interval that reaches 1; else *missed*;
* agent / ``code`` (the centralized reference), pictures.

Usage::

    python -m benchmarks.agent_targets results/a.json results/b.json results/c.json
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from baselines.statistics import Interval95, paired_ratio

#: Target 1's energy clause: no more than this share of ``uniform``'s energy to 99 %.
ENERGY_SHARE = 0.8

Row = Mapping[str, Any]


def paired(row: Row, other: Row, key: str) -> Interval95:
    """``row`` / ``other`` for ``key`` (``firsts`` or ``energies``) over the seeds both played."""
    n = min(len(row[key]), len(other[key]))
    return paired_ratio(row[key][:n], other[key][:n])


def target_one(pictures: Interval95, energy: Interval95) -> str:
    """Target 1's verdict for agent / ``uniform`` (see the module documentation)."""
    if energy.mean > ENERGY_SHARE:
        return "missed"
    if pictures.mean <= 1.0:
        return "met"
    return "within the interval" if pictures.low <= 1.0 else "missed"


def target_two(agent: Row, rivals: Sequence[Row]) -> tuple[str, str]:
    """``(the better rival's name, its pictures / energy and the agent's paired ratios to it,
    the verdict)`` of target 2, on the seeds the agent and that rival both played: *met* where
    the agent's mean pictures and energy are both no more than the rival's; *within the
    interval* where a ratio above 1 has a 95 % interval that reaches 1; else *missed*."""
    n = min(len(r["firsts"]) for r in rivals)
    better = min(rivals, key=lambda r: float(np.mean(r["firsts"][:n])))
    m = min(n, len(agent["firsts"]))
    mine = {k: np.asarray(agent[k][:m], np.float64) for k in ("firsts", "energies")}
    theirs = {k: np.asarray(better[k][:m], np.float64) for k in ("firsts", "energies")}
    ratios = [paired_ratio(mine[k], theirs[k]) for k in ("firsts", "energies")]
    if all(r.mean <= 1.0 for r in ratios):
        verdict = "met"
    elif all(r.mean <= 1.0 or r.low <= 1.0 for r in ratios):
        verdict = "within the interval"
    else:
        verdict = "missed"
    text = (
        f"`{better['excitation']}` {theirs['firsts'].mean():.2f} / "
        f"{theirs['energies'].mean():.2f} (agent {mine['firsts'].mean():.2f} / "
        f"{mine['energies'].mean():.2f}; ratios {ratios[0]}, {ratios[1]})"
    )
    return text, verdict


def table(rows: Sequence[Row]) -> list[str]:
    """The targets table's lines (Markdown)."""
    found = {(r["condition"], r["excitation"]): r for r in rows}
    conditions = list(dict.fromkeys(r["condition"] for r in rows))
    lines = [
        "| condition | agent / `uniform`: pictures [95 %] | energy [95 %] | target 1 "
        "| agent / `uniform-rest`: pictures [95 %] | energy [95 %] "
        "| better of `distinct`/`greedy`: pictures / energy | target 2 | agent / code, pictures |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for name in conditions:
        agent, chance = found.get((name, "agent")), found.get((name, "uniform"))
        if agent is None or chance is None:
            continue
        pictures, energy = paired(agent, chance, "firsts"), paired(agent, chance, "energies")
        rest = found.get((name, "uniform-rest"))
        rest_text = (
            f"{paired(agent, rest, 'firsts')} | {paired(agent, rest, 'energies')}"
            if rest
            else "not run | "
        )
        rivals = [found[(name, k)] for k in ("distinct", "greedy") if (name, k) in found]
        better, two = target_two(agent, rivals) if rivals else ("not run", "")
        code = found.get((name, "code"))
        code_text = str(paired(agent, code, "firsts")) if code else "not run"
        lines.append(
            f"| {name} | {pictures} | {energy} | {target_one(pictures, energy)} | {rest_text} "
            f"| {better} | {two} | {code_text} |"
        )
    return lines


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("rows", type=Path, nargs="+", help="agent_eval --json files")
    args = parser.parse_args(argv)
    rows = [row for path in args.rows for row in json.loads(path.read_text())]
    print("\n".join(table(rows)))


if __name__ == "__main__":
    main()
