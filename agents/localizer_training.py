"""Training the learned localizer ``mlp`` (``baselines.mlp``) on the env's ground truth.

Supervised: robots drive in seeded episodes of several scenarios (:func:`conditions`), every
robot's ``baselines.mlp.MLPLocalizer`` records what its MLP reads at every picture, and the
env's ``true_index`` (from ``infos``, never shown to the robots) is the label: the MLP learns to
give its true row the highest score (cross-entropy over the rows and "not in this picture").

The MLP also reads the robot's belief at the previous picture, so training runs in rounds: the
first with beliefs uniform (weights all zero score every row alike), each next one on episodes
replayed with the weights of the round before, so the beliefs it reads are its own.

The shipped weights (``baselines/data/mlp.npz``) were made by::

    python -m agents.localizer_training --out baselines/data/mlp.npz --workers 4

(two rounds of 11,040 samples; 14 minutes on the shared 2-core machine; the held-out top row
was right for 47.4 % of the samples after the first round and 55.8 % after the second: one
picture pair of a crowd without headings is often ambiguous). ``--workers`` only spreads the
episodes over processes: the weights do not depend on it.

Training seeds start at :data:`FIRST_SEED`, far from every evaluation's (``anonloc reproduce``
and ``bench`` use 0 upward, ``benchmarks/agent_eval.py`` 100000 upward). torch (the ``rl`` extra)
is needed here only; the localizer itself runs on numpy.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

import anonloc_env
from anonloc_env.config import EnvConfig
from anonloc_env.odometry import Interval
from baselines.mlp import FEATURES, MLPLocalizer, MLPWeights
from baselines.policies import Team
from baselines.registry import make_excitation
from baselines.runner import run_episode

#: The first training seed (evaluations use seeds below 200,000).
FIRST_SEED = 10_000_000


@dataclass(frozen=True)
class Condition:
    """A scenario to learn from.

    Attributes:
        name: a label.
        config: the scenario.
        excitation: the robots' motion (a name from ``baselines.registry.EXCITATIONS``).
        episodes: episodes per round.
        pictures: pictures per episode.
        robots: robots recorded per picture (at most; drawn at random).
    """

    name: str
    config: EnvConfig
    excitation: str
    episodes: int
    pictures: int
    robots: int


def crowd(n: int, headings: bool, **camera: float) -> EnvConfig:
    """N robots, one per square metre, 1 px of noise, as ``benchmarks/agent_conditions.py``."""
    side = math.sqrt(n)
    return anonloc_env.make_config(
        n_robots=n,
        arena_size=(side, side),
        camera={"pixel_noise": 1.0, "orientation": headings, **camera},
        max_cycles=1000,
    )


def conditions(scale: float = 1.0) -> list[Condition]:
    """What the shipped weights learned from: the paper presets with their methods' motions,
    and crowds of 10 and 50 robots in random motion, with and without headings, one with
    misses and false positives. ``scale`` multiplies the episode counts."""

    def count(k: int) -> int:
        return max(1, round(k * scale))

    out = [
        Condition(p, anonloc_env.make_config(p), e, count(10), 6, 2)
        for p, e in (
            ("paper-angular", "angular"),
            ("paper-linear", "linear"),
            ("paper-motion", "random"),
        )
    ]
    for n in (10, 50):
        for headings in (False, True):
            out.append(
                Condition(f"crowd {n} {headings}", crowd(n, headings), "random", count(24), 16, 6)
            )
    clutter = crowd(20, False, p_miss=0.1, false_positives=3.0)
    out.append(Condition("clutter 20", clutter, "random", count(24), 16, 6))
    return out


class _Recorder(MLPLocalizer):
    """An ``baselines.mlp.MLPLocalizer`` that keeps what its MLP read at each picture."""

    def reset(self) -> None:
        super().reset()
        self.seen = 0
        self.records: list[tuple[int, np.ndarray]] = []
        self._chunks: list[np.ndarray] = []

    def on_picture(self, rows: np.ndarray, interval: Interval | None, duration: float) -> None:
        self.seen += 1
        super().on_picture(rows, interval, duration)

    def decide(self) -> None:
        self._chunks = []
        super().decide()
        if self._chunks:
            self.records.append((self.seen - 1, np.concatenate(self._chunks)))

    def _inputs(self, x: np.ndarray) -> np.ndarray:
        self._chunks.append(x.astype(np.float32))
        return x


def zero_weights(hidden: int = 64) -> MLPWeights:
    """Weights that score every row alike (uniform beliefs): the first round's."""
    f = len(FEATURES)
    layers = ((np.zeros((f, hidden)), np.zeros(hidden)), (np.zeros((hidden, 1)), np.zeros(1)))
    return MLPWeights(layers, 0.0, np.zeros(f), np.ones(f))


def collect(
    condition: Condition, weights: MLPWeights, first_seed: int
) -> list[tuple[np.ndarray, int]]:
    """``(inputs (m, F), label)`` samples from ``condition``'s episodes (seeds from
    ``first_seed``); the label is the true row, or ``m`` where the robot is not in the picture."""
    config = condition.config
    env = anonloc_env.AnonLocEnv(config, reward_fn=anonloc_env.EnergyCost())
    n = config.n_robots
    recorder = _Recorder(config, n, weights=weights)
    samples = []
    for seed in range(first_seed, first_seed + condition.episodes):
        team = Team(config, recorder, make_excitation(condition.excitation))
        result = run_episode(env, team, seed, max_pictures=condition.pictures)
        rng = np.random.default_rng(seed)
        for picture, x in recorder.records:
            truth = result.true_rows[picture]
            for robot in rng.permutation(n)[: condition.robots]:
                label = int(truth[robot])
                samples.append((x[robot].copy(), label if label >= 0 else x.shape[1]))
    env.close()
    return samples


def _pad(samples: Sequence[tuple[np.ndarray, int]]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Inputs ``(S, M, F)`` padded with zeros, a mask ``(S, M)`` of real rows, labels ``(S,)``
    (``M`` for "not in this picture")."""
    widest = max(len(x) for x, _ in samples)
    X = np.zeros((len(samples), widest, len(FEATURES)), np.float32)
    mask = np.zeros((len(samples), widest), bool)
    y = np.empty(len(samples), np.int64)
    for i, (x, label) in enumerate(samples):
        X[i, : len(x)], mask[i, : len(x)] = x, True
        y[i] = label if label < len(x) else widest
    return X, mask, y


def fit(
    samples: Sequence[tuple[np.ndarray, int]],
    start: MLPWeights | None = None,
    *,
    hidden: int = 64,
    epochs: int = 30,
    seed: int = 0,
) -> MLPWeights:
    """Weights that minimise the cross-entropy of the labels over ``samples`` (AdamW, weight
    decay 1e-3, batches of 256, learning rate 3e-3 halved every 10 epochs), from ``start`` (its
    layers must be ``hidden`` wide) or from a seeded random start."""
    import torch

    torch.manual_seed(seed)
    threads = torch.get_num_threads()
    torch.set_num_threads(1)  # small batches: one thread is as fast, and reproducible
    try:
        return _fit(torch, samples, start, hidden, epochs, seed)
    finally:
        torch.set_num_threads(threads)


def _fit(
    torch: Any,
    samples: Sequence[tuple[np.ndarray, int]],
    start: MLPWeights | None,
    hidden: int,
    epochs: int,
    seed: int,
) -> MLPWeights:
    X, mask, y = _pad(samples)
    rows = X[mask]
    # Centred, and scaled where the spread exceeds 1 (the inputs are already log-compressed; an
    # input constant in one round, the prior in the first, must not be blown up in the next).
    mean = rows.mean(axis=0).astype(np.float64)
    scale = np.maximum(rows.std(axis=0), 1.0).astype(np.float64)
    f = len(FEATURES)
    linears = [
        torch.nn.Linear(f, hidden),
        torch.nn.Linear(hidden, hidden),
        torch.nn.Linear(hidden, 1),
    ]
    net = torch.nn.Sequential(linears[0], torch.nn.ReLU(), linears[1], torch.nn.ReLU(), linears[2])
    absent = torch.nn.Parameter(torch.zeros(()))
    if start is not None and any(np.any(W != 0) for W, _ in start.layers):
        # The same function of the raw inputs under the new normalisation.
        (W0, b0), *rest = start.layers
        first = (W0 * (scale / start.scale)[:, None], b0 + ((mean - start.mean) / start.scale) @ W0)
        with torch.no_grad():
            for layer, (W, b) in zip(linears, [first, *rest], strict=True):
                layer.weight.copy_(torch.from_numpy(W.T.copy()))
                layer.bias.copy_(torch.from_numpy(b.copy()))
            absent.fill_(start.absent)
    Xt = torch.from_numpy((X - mean.astype(np.float32)) / scale.astype(np.float32))
    Mt, yt = torch.from_numpy(mask), torch.from_numpy(y)
    optimiser = torch.optim.AdamW([*net.parameters(), absent], lr=3e-3, weight_decay=1e-3)
    schedule = torch.optim.lr_scheduler.StepLR(optimiser, step_size=10, gamma=0.5)
    generator = torch.Generator().manual_seed(seed)
    for _ in range(epochs):
        for batch in torch.randperm(len(yt), generator=generator).split(256):
            scores = net(Xt[batch]).squeeze(-1).masked_fill(~Mt[batch], -1e9)
            logits = torch.cat([scores, absent.expand(len(batch), 1)], dim=1)
            loss = torch.nn.functional.cross_entropy(logits, yt[batch])
            optimiser.zero_grad()
            loss.backward()
            optimiser.step()
        schedule.step()
    layers = tuple(
        (
            layer.weight.detach().numpy().T.astype(np.float64),
            layer.bias.detach().numpy().astype(np.float64),
        )
        for layer in linears
    )
    return MLPWeights(layers, float(absent.detach()), mean, scale)


def accuracy(weights: MLPWeights, samples: Sequence[tuple[np.ndarray, int]]) -> tuple[float, float]:
    """Share of ``samples`` whose label scores highest, and the mean negative log-likelihood."""
    right, nll = 0, 0.0
    for x, label in samples:
        logits = np.append(weights.scores(x.astype(np.float64)), weights.absent)
        logits -= logits.max()
        log_p = logits - math.log(np.exp(logits).sum())
        right += int(np.argmax(logits) == label)
        nll -= float(log_p[label])
    return right / max(len(samples), 1), nll / max(len(samples), 1)


def _collect_job(job: tuple[Condition, MLPWeights, int]) -> list[tuple[np.ndarray, int]]:
    return collect(*job)


def train(
    scale: float = 1.0,
    rounds: int = 2,
    epochs: int = 30,
    seed: int = 0,
    workers: int = 1,
    log: bool = True,
) -> MLPWeights:
    """The whole training run (see the module): ``rounds`` rounds over :func:`conditions`
    (``scale`` times the episodes), each checked on held-out episodes (seeds past the training
    ones) with the accuracy of the top score and the log-loss. ``workers`` processes play the
    episodes (the result does not depend on it)."""
    from concurrent.futures import ProcessPoolExecutor

    weights = zero_weights()
    for round_ in range(rounds):
        start = time.perf_counter()
        jobs, checks = [], []
        for k, condition in enumerate(conditions(scale)):
            first = FIRST_SEED + 1_000_000 * round_ + 10_000 * k
            jobs.append((condition, weights, first))
            few = dataclasses.replace(condition, episodes=max(1, condition.episodes // 4))
            checks.append((few, weights, first + 5_000))
        if workers > 1:
            with ProcessPoolExecutor(workers) as pool:
                parts = list(pool.map(_collect_job, jobs + checks))
        else:
            parts = [_collect_job(job) for job in jobs + checks]
        train_set = [s for part in parts[: len(jobs)] for s in part]
        held_out = [s for part in parts[len(jobs) :] for s in part]
        weights = fit(train_set, weights, epochs=epochs, seed=seed + round_)
        if log:
            right, nll = accuracy(weights, held_out)
            print(
                f"round {round_ + 1}: {len(train_set)} samples, held out {len(held_out)}: top "
                f"row right {100 * right:.1f} %, log-loss {nll:.3f} "
                f"({time.perf_counter() - start:.0f} s)",
                flush=True,
            )
    return weights


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("mlp.npz"), help="weights file to write")
    parser.add_argument("--scale", type=float, default=1.0, help="times the default episodes")
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--epochs", type=int, default=30)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--workers", type=int, default=1, help="processes playing episodes")
    args = parser.parse_args(argv)
    weights = train(args.scale, args.rounds, args.epochs, args.seed, args.workers)
    weights.save(args.out)
    print(f"wrote {args.out} ({args.out.stat().st_size / 1024:.0f} KB)")


if __name__ == "__main__":
    main()
