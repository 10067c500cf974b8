"""Variants of the bundled linear agent, made by named edits of its weights (issue 24, seventh
round): how much of its preference for cheap candidates it keeps as the team grows, and on duty.

The bundled agent prefers the cheaper and shorter of its candidates, even while unsure
(``energy*always`` -1.32, ``reach*always`` -1.26, ``speed*always`` -0.77, ``speed_sq*always``
+0.37). On free N = 100 and 300 that preference costs 13 to 21 % in pictures against
``uniform``. The variants scale it with the number of robots in the picture through the size
terms (:data:`agents.linear_terms.SIZE_TERMS`): ``size BETA`` sets ``base*rows_free`` to
``-BETA`` times ``base*always`` for those four bases, so the preference of an unsure robot in
free motion is ``w * (1 - BETA * rows)`` (``rows`` is 0.35 at N = 10, 0.67 at N = 100, 0.83 at
N = 300, 1 at N = 1000), and on duty it is unchanged; ``duty D`` adds ``D`` to
``energy*on_duty`` (-1.5, -5, -20: ever cheaper deviations on duty); ``flat`` zeroes the four
``always``
weights. ``crowded K`` (eighth round) adds, on top of its base, ``greedy``'s trade only in a
crowd: the agent sees the crowd features and ``entropy_after*crowded`` is ``-K``,
``energy*crowded`` ``-K / 2`` (:data:`agents.linear_terms.CROWDED_TERMS`: 0 unless the crowding
around the robot reaches ``agents.linear_terms.CROWDED``), so that where robots touch it
drives nearly the candidate of least expected entropy plus half a nat per unit of energy, and
elsewhere it is its base bit for bit. ``dense K`` (ninth round) is the same trade gated by the
whole arena instead: the agent sees only the ``density`` crowd feature (rows per m² of the
picture) and ``entropy_after*dense`` is ``-K``, ``energy*dense`` ``-K / 2``
(:data:`agents.linear_terms.DENSE_TERMS`: 0 below ``agents.linear_terms.DENSE`` rows per m²,
so that in every open-space condition it is its base bit for bit). ``missing E`` (ninth round)
adds, on top of ``dense 100``, ``energy*missing`` ``-E``: a stronger preference for cheap
candidates on a camera that misses robots (``missing`` is ``1 - p_detect``, 0 on a clean camera,
:data:`agents.linear_terms.MISSING_TERMS`). The variants are saved as
ordinary linear agents (``agents.linear_agent``).

Usage::

    python -m benchmarks.agent_variants OUT_DIR --base BASE.zip  # OUT_DIR/NAME.zip for each

The seventh round's variants were made from the agent bundled until then (``--base``: ``git show
ec78ad0:agents/data/agent.zip > base.zip``); ``size-1.0`` is the agent bundled since. The
eighth round's ``crowded`` and the ninth round's ``dense`` and ``missing`` variants were made
from that one (``--base base.zip`` with ``git show cc24abb:agents/data/agent.zip > base.zip``);
``missing-20`` is the agent bundled since the ninth round.
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import numpy as np

from agents.candidate_features import CONTEXT_SPEC, Feature
from agents.crowd_features import CROWD_CONTEXT_SPEC
from agents.linear_agent import linear_weights, save_linear_agent
from agents.linear_terms import (
    CROWDED_TERMS,
    DENSE_TERMS,
    LINEAR_TERMS,
    MISSING_TERMS,
    SIZE_TERMS,
)
from agents.policy import agent_file
from agents.spec import saved_spec

#: The bases whose unsure (``always``) preference the variants scale.
CHEAP_BASES = ("energy", "reach", "speed", "speed_sq")
#: Every variant: name -> (BETA of the size terms, D added on duty, flat).
VARIANTS = {
    "size-0.5": (0.5, 0.0, False),
    "size-1.0": (1.0, 0.0, False),
    "size-1.0-duty": (1.0, -1.5, False),
    "size-1.0-duty-5": (1.0, -5.0, False),
    "size-1.0-duty-20": (1.0, -20.0, False),
    "flat": (0.0, 0.0, True),
}
#: The crowded variants: name -> K.
CROWDED_VARIANTS = {"crowded-30": 30.0, "crowded-100": 100.0}
#: The terms of a crowded variant.
CROWDED_VARIANT_TERMS = LINEAR_TERMS + SIZE_TERMS + CROWDED_TERMS
#: The dense variants: name -> K.
DENSE_VARIANTS = {"dense-10": 10.0, "dense-30": 30.0, "dense-100": 100.0, "dense-300": 300.0}
#: The missing variants: name -> E.
MISSING_VARIANTS = {"missing-10": 10.0, "missing-20": 20.0, "missing-40": 40.0}
#: The terms of a dense variant.
DENSE_VARIANT_TERMS = LINEAR_TERMS + SIZE_TERMS + DENSE_TERMS


def edited_weights(
    base: dict[str, float], terms: tuple[Feature, ...], edits: dict[str, float]
) -> np.ndarray:
    """The weights over ``terms`` of ``base`` (0 for a term it lacks), with ``edits`` (term name
    -> weight) in place."""
    out = {t.name: base.get(t.name, 0.0) for t in terms} | edits
    return np.array([out[t.name] for t in terms])


def gated_weights(
    base: dict[str, float], k: float, gate: str, terms: tuple[Feature, ...]
) -> np.ndarray:
    """``base``'s weights over ``terms`` with ``greedy``'s trade behind ``gate`` (``crowded`` or
    ``dense``, see the module): ``entropy_after*GATE`` ``-k``, ``energy*GATE`` ``-k / 2``."""
    return edited_weights(base, terms, {f"entropy_after*{gate}": -k, f"energy*{gate}": -k / 2})


def variant_weights(bundled: dict[str, float], beta: float, duty: float, flat: bool) -> np.ndarray:
    """The weights of one variant over ``LINEAR_TERMS + SIZE_TERMS`` (see the module)."""
    out = {t.name: bundled.get(t.name, 0.0) for t in LINEAR_TERMS + SIZE_TERMS}
    for base in CHEAP_BASES:
        out[f"{base}*rows_free"] = -beta * bundled[f"{base}*always"]
        if flat:
            out[f"{base}*always"] = 0.0
    out["energy*on_duty"] += duty
    return np.array([out[t.name] for t in LINEAR_TERMS + SIZE_TERMS])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path, help="folder for the variants' agent.zip files")
    parser.add_argument("--base", default="bundled", help="the linear agent the edits start from")
    args = parser.parse_args()
    bundled = linear_weights(args.base)
    spec = saved_spec(agent_file(args.base))
    assert spec is not None  # the bundled agent has a spec
    spec = dataclasses.replace(spec, context_features=CONTEXT_SPEC, terms=LINEAR_TERMS + SIZE_TERMS)
    args.out.mkdir(parents=True, exist_ok=True)
    for name, (beta, duty, flat) in VARIANTS.items():
        path = save_linear_agent(
            variant_weights(bundled, beta, duty, flat), args.out / f"{name}.zip", spec
        )
        print(f"{name}: {path}")
    crowd = dataclasses.replace(spec.with_crowd_features(), terms=CROWDED_VARIANT_TERMS)
    for name, k in CROWDED_VARIANTS.items():
        weights = gated_weights(bundled, k, "crowded", CROWDED_VARIANT_TERMS)
        path = save_linear_agent(weights, args.out / f"{name}.zip", crowd)
        print(f"{name}: {path}")
    density = next(f for f in CROWD_CONTEXT_SPEC if f.name == "density")
    dense = dataclasses.replace(
        spec, context_features=(*CONTEXT_SPEC, density), terms=DENSE_VARIANT_TERMS
    )
    for name, k in DENSE_VARIANTS.items():
        weights = gated_weights(bundled, k, "dense", DENSE_VARIANT_TERMS)
        path = save_linear_agent(weights, args.out / f"{name}.zip", dense)
        print(f"{name}: {path}")
    # The missing variants start from dense-100 (the agent bundled since the ninth round).
    dense_100 = dict(
        zip(
            (t.name for t in dense.terms),
            gated_weights(bundled, 100.0, "dense", dense.terms),
            strict=True,
        )
    )
    missing = dataclasses.replace(dense, terms=DENSE_VARIANT_TERMS + MISSING_TERMS)
    for name, e in MISSING_VARIANTS.items():
        weights = edited_weights(dense_100, missing.terms, {"energy*missing": -e})
        path = save_linear_agent(weights, args.out / f"{name}.zip", missing)
        print(f"{name}: {path}")


if __name__ == "__main__":
    main()
