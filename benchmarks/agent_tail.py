"""Where a condition's pictures to 99 % are won or lost: the share of robots not right at each
early picture, for the bundled agent, edits of it and ``uniform``, paired on the same seeds
(issue 24, twelfth round).

Pictures to 99 % is a count that moves in whole pictures (4 or 5 at free N = 300), so a few per
cent between two excitations is a few episodes tipping over. The share of robots not right at
picture ``k`` (undecided, or decided on another row; the team's own ``bayes``) is a finer view
of the same thing: summed over the episodes, its ratio to the reference's says at which
picture an excitation falls behind. Each variant is the bundled agent with its weights edited
in memory (nothing saved), or ``uniform``, each with or without the rest once sure
(:class:`baselines.excitations.rest.RestWhenSure`):

- ``agent``: the bundled agent as its spec runs it (rest at 0.9999);
- ``agent-norest``: the same weights, never at rest;
- ``agent-nodecided``: the ``*decided`` weights zeroed (a decided robot chooses as an unsure
  one), at rest;
- ``agent-size-B``: the size terms times ``B`` (``B = 1.5``: at N = 300 an unsure robot's
  preference for cheap candidates is reversed to a quarter of the searched one), at rest;
  ``agent-size-B-norest`` never at rest;
- ``agent-crawl-F``: the bundled agent whose robots, once sure, drive ``F`` times its command
  instead of resting (:class:`Crawl`; ``F = 0`` is its rest);
- ``agent-delay-K``: the bundled agent whose robots rest only once sure at ``K`` pictures
  running (:class:`Delayed`; ``K = 1`` is its rest);
- ``agent-still``: the bundled agent whose resting robots, on swarm duty, deviate against the
  shared command as far as the budget allows instead of following it (:class:`StillOnDuty`: as
  still as the duty allows; in free motion its rest); ``agent-still-energy-E`` the same with
  ``E`` added to the ``energy*on_duty`` weight;
- ``agent-noprobe``: the bundled agent at rest without its probe (``probe=None``);
- ``agent+T=V,T=V`` / ``zero+T=V,...``: ``V`` added to term ``T`` of the bundled weights /
  of zero weights (``uniform``'s), at rest, played by the search's numpy chooser; ``T`` may be
  a term the bundled agent lacks, such as ``entropy_after*fair`` or ``contact_risk*always``
  (then the agent sees the crowd features) (fifteenth round);
- ``file:PATH``: the saved agent at ``PATH`` (an ``agent.zip`` or its folder), at rest;
- ``agent-reach-B``: ``B`` added to the ``reach*always`` weight (``B > 0``: every robot prefers
  candidates that carry it further, fourteenth round), at rest;
- the suffix ``-pinned`` (after ``agent``, ``agent-nodecided``, ``agent-size-B``,
  ``agent-reach-B`` or ``uniform-rest``): resting robots hold still through bumps, the rest
  before the fourteenth round (``RestWhenSure(yield_to_bumps=False)``);
- the suffix ``-noescape`` (after any other): pressed robots back off as after a first bump
  (0.3 m/s) instead of escaping at 0.08 m/s (fifteenth round);
- ``uniform``, ``uniform-rest`` (at 0.9999).

Usage::

    python -m benchmarks.agent_tail --condition "free N=300" --episodes 24 \\
        --first-seed 800100 --variants uniform agent agent-norest agent-nodecided agent-size-1.5

The first variant is the reference of the ratios (95 % paired bootstrap intervals over the
episodes, :func:`baselines.statistics.paired_ratio`).
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from agents.evaluation import censored, play
from baselines.excitations.base import Excitation
from baselines.excitations.candidates import GreedySettings
from baselines.excitations.rest import RestWhenSure
from baselines.registry import EXCITATIONS
from baselines.runner import EpisodeResult
from baselines.statistics import paired_ratio
from baselines.steps import BeliefView, Step
from benchmarks.agent_conditions import (
    beyond_conditions,
    crowded_conditions,
    evaluation_conditions,
)
from benchmarks.duty_energy import LeastTravel

#: The bundled agent's rest (its spec's ``rest``), and ``uniform-rest``'s here.
REST = 0.9999
#: The pictures whose share of robots not right is reported.
EARLY = (2, 3, 4, 5, 6)


class Crawl(RestWhenSure):
    """:class:`~baselines.excitations.rest.RestWhenSure` whose sure robots drive ``fraction``
    times ``inner``'s command instead of holding still (``fraction = 0``: the rest itself)."""

    def __init__(self, inner: Excitation, sure: float, fraction: float) -> None:
        super().__init__(inner, sure)
        if not 0.0 <= fraction <= 1.0:
            raise ValueError(f"fraction must be in [0, 1], got {fraction!r}")
        self.fraction = float(fraction)

    def commands(self, step: Step, dt: float) -> tuple[np.ndarray, np.ndarray]:
        v, w = self.inner.commands(step, dt)
        scale = np.where(self.resting, self.fraction, 1.0)
        return v * scale, w * scale


class Delayed(RestWhenSure):
    """:class:`~baselines.excitations.rest.RestWhenSure` whose robots rest only once sure at
    ``after`` pictures running (``after = 1``: the rest itself; the probe as before)."""

    def __init__(self, inner: Excitation, sure: float, after: int) -> None:
        super().__init__(inner, sure)
        if not (isinstance(after, int) and after >= 1):
            raise ValueError(f"after must be an integer >= 1, got {after!r}")
        self.after = after

    def on_picture(self, step: Step, view: BeliefView) -> None:
        super().on_picture(step, view)
        self.resting = self.resting & (self.sure_for >= self.after)


class StillOnDuty(RestWhenSure):
    """:class:`~baselines.excitations.rest.RestWhenSure` whose resting robots, on swarm duty,
    drive :class:`benchmarks.duty_energy.LeastTravel`'s deviation within the candidates' box
    (``v`` within ``speed``, m/s, ``w`` within ``turn``, rad/s) instead of adding no deviation:
    they stand as still as the duty allows, and fall behind it. In free motion it is the rest
    itself."""

    def __init__(self, inner: Excitation, sure: float, speed: float, turn: float) -> None:
        super().__init__(inner, sure)
        self.least = LeastTravel(speed, turn)

    def reset(self, rngs: Sequence[np.random.Generator]) -> None:
        super().reset(rngs)
        self.least.reset(rngs)

    def follow(self, v: np.ndarray, w: np.ndarray, budget: float) -> None:
        super().follow(v, w, budget)
        self.least.follow(v, w, budget)

    def commands(self, step: Step, dt: float) -> tuple[np.ndarray, np.ndarray]:
        v, w = super().commands(step, dt)
        if not self.on_duty:
            return v, w
        still_v, still_w = self.least.commands(step, dt)
        return np.where(self.resting, still_v, v), np.where(self.resting, still_w, w)


def edited_agent(edit: Callable[[str, float], float]) -> Any:
    """The bundled agent's model with each weight ``w`` of term ``name`` replaced by
    ``edit(name, w)`` (in memory)."""
    import torch

    from agents.policy import load_model, model_spec

    model = load_model("bundled")
    spec = model_spec(model)
    assert spec is not None  # the bundled agent has a spec
    weights = model.policy.scorer.weights
    with torch.no_grad():
        for i, term in enumerate(spec.terms):
            weights[i] = edit(term.name, float(weights[i]))
    return model


def edited_chooser(base: str, rest: float | None, pinned: bool) -> Callable[[], Excitation]:
    """The variant ``agent+T=V,T=V`` (the bundled weights) or ``zero+T=V,...`` (zero weights:
    ``uniform``) with ``V`` added to term ``T``, played by the search's numpy chooser
    (:class:`agents.linear_chooser.LinearChooser`, float64) with the bundled spec's features;
    a term the spec lacks (any of :data:`agents.linear_terms.KNOWN_TERMS`) is appended, and a
    term of the crowd features (``contact_risk``, ``crowding``) gives the agent those features.

    Raises:
        ValueError: a term this anonloc does not know, or a value that is not a number.
    """
    import dataclasses

    from agents.linear_chooser import LinearChooser
    from agents.linear_terms import KNOWN_TERMS
    from agents.policy import load_model, model_spec

    head, _, edits = base.partition("+")
    model = load_model("bundled")  # once: its spec and its weights
    spec = model_spec(model)
    assert spec is not None  # the bundled agent has a spec
    bundled = model.policy.scorer.weights.detach().double().tolist()
    scale = 1.0 if head == "agent" else 0.0
    weights = {t.name: w * scale for t, w in zip(spec.terms, bundled, strict=True)}
    for edit in edits.split(","):
        term, _, value = edit.partition("=")
        if term not in KNOWN_TERMS:
            known = sorted(KNOWN_TERMS)
            raise ValueError(f"variant {base!r}: unknown term {term!r}, one of {known}")
        weights[term] = weights.get(term, 0.0) + float(value)
    extra = tuple(KNOWN_TERMS[t] for t in weights if t not in {s.name for s in spec.terms})
    if any(t.name.startswith("contact_risk*") or "*crowd" in t.name for t in extra):
        crowd = spec.with_crowd_features()  # the crowd features, the density among them
        spec = dataclasses.replace(
            spec,
            candidate_features=crowd.candidate_features,
            context_features=crowd.context_features,
        )
    spec = dataclasses.replace(spec, terms=spec.terms + extra)
    vector = np.array([weights[t.name] for t in spec.terms])
    sure = rest
    if sure is None:
        return lambda: LinearChooser(vector, spec)
    return lambda: RestWhenSure(LinearChooser(vector, spec), sure, yield_to_bumps=not pinned)


def without_escape(excitation: Excitation) -> Excitation:
    """``excitation`` (or the one its rest wraps) whose pressed robots back off as after a first
    bump (0.3 m/s for 0.5 to 1 s) instead of escaping slowly (``GreedySettings.escape = None``,
    :class:`baselines.excitations.reflex.BumpReflex`), before its first reset."""
    from baselines.excitations.reflex import BumpReflex

    held = excitation.inner if isinstance(excitation, RestWhenSure) else excitation
    settings = getattr(held, "settings", None)
    if not isinstance(held.backoff, BumpReflex) or settings is None:
        raise ValueError(f"-noescape needs a candidate excitation, got {type(held).__name__}")
    held.backoff = BumpReflex(settings.back, None)
    return excitation


def variant(name: str) -> Callable[[], Excitation]:
    """How to build the excitation a variant name says (see the module).

    Raises:
        ValueError: a name this script does not know.
    """
    if name.endswith("-noescape"):
        made = variant(name.removesuffix("-noescape"))
        return lambda: without_escape(made())
    rest: float | None = None if name.endswith("-norest") else REST
    pinned = name.endswith("-pinned")
    base = name.removesuffix("-norest").removesuffix("-pinned")
    if base.startswith(("agent+", "zero+")):
        return edited_chooser(base, rest, pinned)
    if base in ("uniform", "uniform-rest"):
        rest = REST if base == "uniform-rest" else None
        inner: Callable[[], Excitation] = EXCITATIONS["uniform"]
    else:
        from agents.policy import LearnedExcitation

        if base.startswith("file:"):
            from agents.policy import load_model

            model = load_model(base.removeprefix("file:"))
        elif base in ("agent", "agent-still", "agent-noprobe") or base.startswith(
            ("agent-crawl-", "agent-delay-")
        ):
            model = edited_agent(lambda term, w: w)
        elif base.startswith("agent-still-energy-"):
            add = float(base.removeprefix("agent-still-energy-"))
            model = edited_agent(lambda term, w: w + add if term == "energy*on_duty" else w)
        elif base.startswith("agent-reach-"):
            add = float(base.removeprefix("agent-reach-"))
            model = edited_agent(lambda term, w: w + add if term == "reach*always" else w)
        elif base == "agent-nodecided":
            model = edited_agent(lambda term, w: 0.0 if term.endswith("*decided") else w)
        elif base.startswith("agent-size-"):
            scale = float(base.removeprefix("agent-size-"))
            model = edited_agent(lambda term, w: w * scale if term.endswith("*rows_free") else w)
        else:
            raise ValueError(f"unknown variant {name!r} (see benchmarks.agent_tail)")

        def inner() -> Excitation:
            return LearnedExcitation(model)

    if rest is None:
        return inner
    sure = rest
    if base.startswith("agent-crawl-"):
        fraction = float(base.removeprefix("agent-crawl-"))
        Crawl(inner(), sure, fraction)  # a fraction outside [0, 1] fails here, before any episode
        return lambda: Crawl(inner(), sure, fraction)
    if base.startswith("agent-delay-"):
        after = int(base.removeprefix("agent-delay-"))
        Delayed(inner(), sure, after)  # an after below 1 fails here, before any episode
        return lambda: Delayed(inner(), sure, after)
    if base == "agent-noprobe":
        return lambda: RestWhenSure(inner(), sure, probe=None)
    if base.startswith("agent-still"):
        box = GreedySettings()
        return lambda: StillOnDuty(inner(), sure, box.speed[1], box.turn)
    if pinned:
        return lambda: RestWhenSure(inner(), sure, yield_to_bumps=False)
    return lambda: RestWhenSure(inner(), sure)


def not_right(result: EpisodeResult, pictures: Sequence[int] = EARLY) -> np.ndarray:
    """The share of robots whose own ``bayes`` is not right at each of ``pictures``."""
    out = np.zeros(len(pictures))
    for j, k in enumerate(pictures):
        correct = [r.correct for r in result.records if r.picture == k and r.localizer == ""]
        out[j] = 1.0 - float(np.mean(correct)) if correct else 0.0
    return out


#: The bins of a robot's belief in its own row at the picture before it is counted not right
#: (``--origins``): below 0.5, up to ``bayes``'s decision (0.99), up to the rest, and resting.
ORIGIN_EDGES = (0.5, 0.99, REST)
ORIGIN_NAMES = ("< 0.5", "0.5 to 0.99", f"0.99 to {REST}", f">= {REST}")


def origins(result: EpisodeResult, picture: int) -> np.ndarray:
    """``(4,)`` the robots not right at ``picture`` (the team's own records), counted by the
    belief they gave their own row at the picture before (bins :data:`ORIGIN_NAMES`); a robot
    with no record there counts in the first bin."""
    before = {
        r.robot: r.belief_true
        for r in result.records
        if r.picture == picture - 1 and r.localizer == ""
    }
    out = np.zeros(len(ORIGIN_NAMES), np.int64)
    for r in result.records:
        if r.picture == picture and r.localizer == "" and not r.correct:
            out[int(np.searchsorted(ORIGIN_EDGES, before.get(r.robot, 0.0), side="right"))] += 1
    return out


#: A robot's own displacement over an interval below this (m) is a short one (``--why``): about
#: five times the pixel noise at the evaluation's scale, too short to tell the robot from a row
#: that stayed still.
SHORT = 0.05
#: The columns of ``--why``: the robots not right at ``K`` whose belief in their own row was 0.5
#: to 0.99 at ``K - 1``, all, then those whose own displacement over the interval between was
#: short, and of those the ones that began the interval reversing out of a bump.
WHY_NAMES = ("fairly sure at K - 1", "moved < 5 cm", "of which reversing at its start")


def why(result: EpisodeResult, picture: int) -> np.ndarray:
    """``(3,)`` counts :data:`WHY_NAMES` at ``picture`` (the team's own records; the interval is
    the robots' own odometry between ``picture - 1`` and ``picture``, its command the one set
    just after ``picture - 1``: a negative speed is a back-off)."""
    before = {
        r.robot: r.belief_true
        for r in result.records
        if r.picture == picture - 1 and r.localizer == ""
    }
    interval = result.intervals[picture - 1]
    out = np.zeros(len(WHY_NAMES), np.int64)
    for r in result.records:
        if r.picture != picture or r.localizer != "" or r.correct:
            continue
        if not 0.5 <= before.get(r.robot, 0.0) < 0.99:
            continue
        out[0] += 1
        if float(np.hypot(*interval.d[r.robot])) < SHORT:
            out[1] += 1
            command = interval.command
            out[2] += int(command is not None and command[r.robot, 0] < 0.0)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--condition", default="free N=300")
    parser.add_argument("--episodes", type=int, default=24)
    parser.add_argument("--first-seed", type=int, default=800_100)
    parser.add_argument("--pictures", type=int, default=30)
    parser.add_argument("--variants", nargs="+", default=["uniform", "agent", "agent-norest"])
    parser.add_argument(
        "--origins",
        type=int,
        default=None,
        help="also count the robots not right at this picture by their belief the picture before",
    )
    parser.add_argument(
        "--why",
        type=int,
        default=None,
        help="also count the fairly sure robots not right at this picture by how far they moved",
    )
    args = parser.parse_args()
    makers = {name: variant(name) for name in args.variants}  # unknown names fail first
    conditions = evaluation_conditions() | crowded_conditions() | beyond_conditions()
    config, condition, budget = conditions[args.condition]
    seeds = range(args.first_seed, args.first_seed + args.episodes)
    firsts, shares, origin, whys = {}, {}, {}, {}
    header = " | ".join(f"not right at {k}" for k in EARLY)
    print(f"| variant | pictures | energy (m) | {header} |\n" + "|---" * (3 + len(EARLY)) + "|")
    for name, make in makers.items():
        start = time.perf_counter()
        results = play(config, condition, budget, make, seeds, args.pictures)
        firsts[name] = np.array([censored(r, args.pictures) for r in results], np.float64)
        shares[name] = np.stack([not_right(r) for r in results])
        if args.origins is not None:
            origin[name] = sum(origins(r, args.origins) for r in results)
        if args.why is not None:
            whys[name] = sum(why(r, args.why) for r in results)
        cells = " | ".join(f"{100 * s:.3f} %" for s in shares[name].mean(axis=0))
        mean = firsts[name].mean(axis=0)
        seconds = time.perf_counter() - start
        print(f"| {name} | {mean[0]:.3f} | {mean[1]:.3f} | {cells} |  ({seconds:.0f} s)")
    ref = args.variants[0]
    rule = "|---" * (3 + len(EARLY)) + "|"
    print(f"\n| variant / {ref} | pictures | energy | {header} |\n{rule}")
    for name in args.variants[1:]:
        ratios = [paired_ratio(firsts[name][:, i], firsts[ref][:, i]) for i in (0, 1)]
        texts = [f"{r.mean:.3f} [{r.low:.3f}, {r.high:.3f}]" for r in ratios]
        for j in range(len(EARLY)):
            if shares[ref][:, j].sum() > 0:
                r = paired_ratio(shares[name][:, j], shares[ref][:, j])
                texts.append(f"{r.mean:.3f} [{r.low:.3f}, {r.high:.3f}]")
            else:  # the reference has every robot right there: no ratio
                texts.append("n/a")
        print(f"| {name} | {' | '.join(texts)} |")
    if origin:
        k = args.origins
        print(
            f"\n| variant | not right at {k}, by belief in own row at {k - 1}: "
            + " | ".join(ORIGIN_NAMES)
            + " |"
        )
        print("|---" * (1 + len(ORIGIN_NAMES)) + "|")
        for name, counts in origin.items():
            print(f"| {name} | " + " | ".join(str(int(c)) for c in counts) + " |")
    if whys:
        print(f"\n| variant | not right at {args.why}: " + " | ".join(WHY_NAMES) + " |")
        print("|---" * (1 + len(WHY_NAMES)) + "|")
        for name, counts in whys.items():
            print(f"| {name} | " + " | ".join(str(int(c)) for c in counts) + " |")


if __name__ == "__main__":
    main()
