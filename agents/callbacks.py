"""Training callbacks: what the logs show besides PPO's own figures, a wall-clock budget,
atomic checkpoints, a progress bar that shows the run's whole budget, and a CSV log that a
resumed run appends to."""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback, CheckpointCallback
from stable_baselines3.common.logger import CSVOutputFormat, Logger, make_output_format

from agents.checkpoints import save_atomic


class WallClockBudget(BaseCallback):
    """Stops training (after the current rollout) once ``minutes`` of wall time have passed."""

    def __init__(self, minutes: float) -> None:
        super().__init__()
        self.minutes = minutes
        self._start = time.monotonic()

    def _on_training_start(self) -> None:
        self._start = time.monotonic()

    def _on_step(self) -> bool:
        return time.monotonic() - self._start < 60.0 * self.minutes


class IdentificationLogger(BaseCallback):
    """Logs ``identify/correct_at_end``: the share of the robots present in the last picture of
    an episode that were correctly identified (decided at belief 0.99 on their true row), over
    the episodes that ended since the last log (ground truth from the infos, never observed)."""

    def _init_callback(self) -> None:
        self._correct: list[float] = []

    def _on_step(self) -> bool:
        dones = self.locals["dones"]
        if dones.any():
            infos = self.locals["infos"]
            ended = np.flatnonzero(dones)
            present = [infos[i]["present"] for i in ended]
            correct = [infos[i]["correct"] for i in ended]
            if any(present):
                self._correct.append(float(np.sum(correct)) / float(np.sum(present)))
        return True

    def _on_rollout_end(self) -> None:
        if self._correct:
            self.logger.record("identify/correct_at_end", float(np.mean(self._correct)))
            self._correct = []


class AtomicCheckpoint(CheckpointCallback):
    """:class:`CheckpointCallback` whose files appear whole: saved to a temporary file, then
    moved into place (a kill mid-save leaves the previous checkpoints intact)."""

    def _on_step(self) -> bool:
        if self.n_calls % self.save_freq == 0:
            path = Path(self._checkpoint_path(extension="zip"))
            save_atomic(self.model, path)
            if self.verbose >= 2:  # pragma: no cover - SB3's own messages
                print(f"Saving model checkpoint to {path}")
        return True


#: The training bar on a terminal: the figures before any cut, so that 80 columns hold them all.
BAR_FORMAT = "{desc} {percentage:3.0f}%|{bar}| {n_fmt}/{total_fmt} [{elapsed}<{remaining}]{postfix}"
#: Printed once above the bar: what its figures mean.
LEGEND = (
    "train: ret = mean return of the latest training episodes; id = robots identified\n"
    "at the end of the evaluation episodes; pic99 = pictures to 99 % (censored mean)"
)


class StepProgress(BaseCallback):
    """A progress bar over the run's whole budget: ``done/total`` robot-steps (a resumed run
    starts at its earlier steps) and the wall-clock budget of this call, if any."""

    def __init__(self, total: int, already: int, minutes: float | None) -> None:
        super().__init__()
        self.total, self.already, self.minutes = total, already, minutes
        self._bar: Any = None
        self._figures: dict[str, str] = {}

    def _on_training_start(self) -> None:
        import sys

        from anonloc_env._progress import progress_bar

        print(LEGEND, file=sys.stderr, flush=True)
        if self.minutes is not None:
            print(f"train: this call stops after {self.minutes:g} min", file=sys.stderr)
        self._bar = progress_bar(
            self.total,
            "train",
            initial=min(self.already, self.total),
            unit="step",
            unit_scale=True,
            bar_format=BAR_FORMAT,
        )

    def _on_step(self) -> bool:
        if self._bar is not None:
            self._bar.n = min(int(self.model.num_timesteps), self.total)
            self._bar.refresh()
        return True

    def show(self, **figures: str) -> None:
        """Show ``figures`` (name -> text; they replace the ones of that name) beside the bar."""
        self._figures.update(figures)
        if self._bar is not None:
            text = " ".join(f"{name}={value}" for name, value in self._figures.items())
            self._bar.set_postfix_str(text, refresh=True)

    def _on_training_end(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None


class ProgressEvaluation(BaseCallback):
    """At every ``every`` steps: plays the current policy on fixed evaluation seeds and logs
    ``eval/pictures_to_99`` (censored mean), ``eval/identified_at_end`` (share of the robots
    identified at the episodes' last picture) and, with ``progress``, shows them beside the bar
    with the mean training return. :meth:`against_random` ends a run with the same measure for
    random motion.

    Args:
        scenario: ``(config, condition, budget)`` evaluated on.
        seeds: the evaluation seeds.
        every: vectorized steps between two evaluations.
        progress: the progress bar to show the figures on, or None.
    """

    def __init__(
        self,
        scenario: tuple[Any, str, float],
        seeds: range,
        every: int,
        progress: StepProgress | None = None,
    ) -> None:
        super().__init__()
        self.scenario = scenario
        self.seeds = seeds
        self.every = every
        self.progress = progress
        config = scenario[0]
        self.pictures = int(config.max_cycles * config.dt / config.schedule.picture_interval)
        self._evaluated = False

    def _on_step(self) -> bool:
        if self.n_calls % self.every == 0:
            self.evaluate()
        return True

    def _on_rollout_end(self) -> None:
        """The training return at every rollout, and a first evaluation after the first one
        (figures from the start, not only after ``every`` steps)."""
        if self.progress is None:
            return
        if not self._evaluated:
            self.evaluate()
            return
        self.progress.show(ret=self._mean_return())

    def _mean_return(self) -> str:
        returns = [info["r"] for info in self.model.ep_info_buffer or []]
        return f"{np.mean(returns):.2f}" if returns else "-"

    def evaluate(self) -> float:
        """Play the current policy; log and show the figures; returns pictures to 99 %."""
        from agents.evaluation import censored_pictures, play
        from agents.policy import as_saved

        config, condition, budget = self.scenario
        results = play(
            config, condition, budget, lambda: as_saved(self.model), self.seeds,
            self.pictures,
        )  # fmt: skip
        pictures = censored_pictures(results, self.pictures)
        last = [max(rec.picture for rec in r.records) for r in results]
        end = [
            rec.correct for r, k in zip(results, last, strict=True) for rec in r.records
            if rec.picture == k
        ]  # fmt: skip
        identified = float(np.mean(end)) if end else 0.0
        self.logger.record("eval/pictures_to_99", pictures)
        self.logger.record("eval/identified_at_end", identified)
        self._evaluated = True
        if self.progress is not None:
            self.progress.show(
                ret=self._mean_return(), id=f"{100 * identified:.0f}%", pic99=f"{pictures:.2f}"
            )
        return pictures

    def against_random(self, model: Any) -> tuple[float, float]:
        """Pictures to 99 % of ``model`` and of random motion on the evaluation seeds."""
        from agents.evaluation import censored_pictures, play
        from baselines.registry import make_excitation

        self.model = model
        mine = self.evaluate()
        config, condition, budget = self.scenario
        results = play(
            config, condition, budget, lambda: make_excitation("random"), self.seeds,
            self.pictures,
        )  # fmt: skip
        return mine, censored_pictures(results, self.pictures)


class _AppendingCSV(CSVOutputFormat):
    """SB3's CSV log, continuing an existing file: its header and rows are kept (an incomplete
    last line, from a kill mid-write, is dropped)."""

    def __init__(self, filename: str) -> None:
        path = Path(filename)
        text = path.read_text() if path.exists() else ""
        complete = text[: text.rfind("\n") + 1]
        if complete != text:  # replace, never truncate in place: a kill now loses nothing
            tmp = path.with_name(f".{path.name}.tmp")
            tmp.write_text(complete)
            os.replace(tmp, path)
        path.touch()
        self.file = open(path, "r+")  # noqa: SIM115 - SB3 rewrites the header in place
        self.file.seek(0, os.SEEK_END)
        header = complete.split("\n", 1)[0]
        self.keys = header.split(",") if header else []
        self.separator = ","
        self.quotechar = '"'


def resumable_logger(folder: Path, *, keep: bool) -> Logger:
    """TensorBoard and CSV logs in ``folder``; ``keep``: a resumed run keeps the earlier rows
    of ``progress.csv`` (SB3's own CSV log opens it afresh)."""
    folder.mkdir(parents=True, exist_ok=True)
    csv_path = folder / "progress.csv"
    formats = [
        make_output_format("tensorboard", str(folder)),
        _AppendingCSV(str(csv_path)) if keep else CSVOutputFormat(str(csv_path)),
    ]
    return Logger(folder=str(folder), output_formats=formats)
