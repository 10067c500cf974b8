"""``anonloc train`` and ``anonloc eval``: learned excitations through the same store and tables.

``train`` builds an :class:`agents.train.TrainConfig` from the scenario and options (validated
before any work) and runs it; ``eval`` runs a saved agent, and baseline excitations to compare
with, through ``anonloc bench``'s runner, store and tables (policy ``agent``, built by
``baselines.make_team("agent", env, path=...)``), adding the pictures until 99 % of the robots
present are identified.

Evaluation seeds are ``0..N-1``; training env copies are seeded by 64-bit draws of
``SeedSequence(seed)``, so an evaluation episode is never a training one.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from anonloc_cli.console import echo
from anonloc_cli.jobs import RunOptions
from anonloc_cli.scenarios import InputError, Scenario


def _rl_modules() -> Any:
    try:
        from agents import train
    except ImportError as error:
        raise InputError(
            "training needs the rl extra: pip install torch==2.13.0 && pip install 'anonloc[rl]' "
            f"({error})"
        ) from None
    return train


#: ``train``'s total robot-steps when none are given (a new run).
DEFAULT_TIMESTEPS = 200_000


def train(
    *,
    timesteps: int | None,
    out: Path,
    scenario: str,
    sets: Sequence[str],
    name: str | None,
    minutes: float | None,
    resume: Path | None,
    quiet: bool,
    config: dict[str, Any],
) -> int:
    """Train (or resume) a run; the exit status (130 when Ctrl-C or SIGTERM stopped it, after
    saving a checkpoint and the agent). ``config``: the other fields of
    :class:`agents.train.TrainConfig` (not used by a resume, which keeps the run's own)."""
    module = _rl_modules()
    from agents.run_folder import RunBusyError

    try:
        if resume is not None:
            result = module.resume(
                resume,
                timesteps,
                minutes,
                progress=not quiet,
                notify=lambda message: echo(f"Warning: {message}", err=True),
            )
        else:
            run = _new_config(
                module,
                scenario=scenario,
                sets=sets,
                timesteps=DEFAULT_TIMESTEPS if timesteps is None else timesteps,
                out=str(out),
                name=name,
                minutes=minutes,
                progress=not quiet,
                **config,
            )
            result = module.train(run)
    except module.Interrupted as stopped:
        echo(
            f"\nInterrupted at {stopped.timesteps} robot-steps; saved {stopped.checkpoint} and "
            f"{stopped.directory / 'agent.zip'}. Continue with: anonloc train --resume "
            f"{stopped.directory}",
            err=True,
        )
        return 130
    except (FileNotFoundError, FileExistsError, ValueError, RunBusyError) as error:
        raise InputError(str(error)) from None
    echo(
        f"trained {result.timesteps} robot-steps in {result.seconds:.0f} s; "
        f"agent: {result.agent}; logs: tensorboard --logdir {result.directory / 'tb'}"
    )
    total = timesteps
    if total is None:
        total = DEFAULT_TIMESTEPS if resume is None else _recorded_total(result.directory)
    if result.timesteps < total:
        echo(
            f"stopped at {100 * result.timesteps / total:.0f} % of the run's {total} robot-steps: "
            "the --minutes budget ran out. Continue with: anonloc train --resume "
            f"{result.directory}"
        )
    if result.comparison is not None:
        echo(comparison_text(*result.comparison))
    return 0


def search(
    *,
    out: Path,
    resume: bool,
    quiet: bool,
    config: dict[str, Any],
    given: set[str] | None = None,
) -> None:
    """Run (or resume) a search of a linear agent in ``out`` (:func:`agents.search.search`);
    ``config``: the fields of :class:`agents.search.SearchConfig`; ``given``: the names of those
    the command line gave (None: all). A resume continues with the saved config, the given
    fields replacing its own (the search refuses any but ``workers`` and ``minutes`` that
    differs)."""
    _rl_modules()
    from agents import search as module

    try:
        if resume:
            names = set(config) if given is None else given & set(config)
            settings = module.saved_config(out, **{name: config[name] for name in names})
        else:
            settings = module.SearchConfig(**config)
        module.search(settings, out, log=(lambda _: None) if quiet else echo, resume=resume)
    except (ValueError, TypeError, FileExistsError, FileNotFoundError) as error:
        raise InputError(str(error)) from None
    if not quiet:
        echo(f"agent: {out / 'agent.zip'} (anonloc eval --agent {out})")


def comparison_text(mine: float, random: float) -> str:
    """The closing line: the agent's pictures to 99 % against random motion's, in words."""
    text = (
        f"pictures to 99 % on the evaluation seeds: this agent {mine:.2f}, random motion "
        f"{random:.2f}"
    )
    if not random or abs(mine - random) < 0.005:
        return f"{text} (as many as random)"
    change = 100.0 * abs(random - mine) / random
    return f"{text} ({change:.0f} % {'fewer' if mine < random else 'more'} pictures than random)"


def _recorded_total(directory: Path) -> int:
    """The total robot-steps a run's ``config.json`` records."""
    from agents.run_folder import read_config

    return int(read_config(directory).get("timesteps", DEFAULT_TIMESTEPS))


def _new_config(module: Any, *, scenario: str, sets: Sequence[str], **options: Any) -> Any:
    """The :class:`agents.train.TrainConfig` of a new run (checked before any work)."""
    from anonloc_cli import scenarios

    resolved = scenarios.resolve(scenario, sets)
    spec = dict(resolved.spec)
    preset = spec.pop("preset", "default")
    try:
        return module.TrainConfig(preset=preset, overrides=spec, **options)
    except (ValueError, TypeError) as error:
        raise InputError(str(error)) from None


def agent_scenario(agent: Path) -> Scenario:
    """The scenario a saved agent was trained on (from its run's ``config.json``)."""
    from anonloc_cli import scenarios

    folder = agent if agent.is_dir() else agent.parent
    record = folder / "config.json"
    if not record.is_file():
        raise InputError(f"{record} not found: pass --scenario (the agent's own is not recorded)")
    try:
        train = json.loads(record.read_text())["train"]
        spec = {"preset": train["preset"], **train["overrides"]}
    except (ValueError, KeyError, TypeError) as error:  # empty, truncated or edited
        raise InputError(
            f"{record} is not a run's config ({type(error).__name__}: {error}); "
            "pass --scenario to evaluate the agent on a scenario of your choice"
        ) from None
    return scenarios.build(folder.name, spec)


def agent_file(agent: Path) -> Path:
    """The agent file of ``agent`` (an ``agent.zip`` or its run folder)."""
    return agent / "agent.zip" if agent.is_dir() else agent


def file_hash(path: Path) -> str:
    """SHA-256 of a file's bytes, first 20 hex digits: the agent's identity in stored keys."""
    digest = hashlib.sha256()
    with open(path, "rb") as file:
        for block in iter(lambda: file.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()[:20]


def agent_identity(agent: Path) -> str:
    """What the loaded agent depends on, for the stored episodes' keys: the hash of its file's
    bytes and the condition and budget its run's ``config.json`` records (the loader reads them).
    A retrained ``agent.zip``, or an edited ``config.json``, runs its episodes again."""
    from agents.saved_agent import run_settings

    file = agent_file(agent)
    try:
        settings = run_settings(file)
    except ValueError as error:
        raise InputError(f"--agent: {error}") from None
    return f"{file_hash(file)} {json.dumps(settings, sort_keys=True)}"


def evaluate(
    *,
    agent: Path,
    seeds: int,
    out: Path,
    scenario: str | None,
    sets: Sequence[str],
    against: Sequence[str],
    pictures: int | None,
    run: RunOptions,
) -> int:
    """Evaluate ``agent`` and the ``against`` excitations; the exit status."""
    from anonloc_cli import bench, scenarios, teams

    _rl_modules()  # an agent needs the rl extra: say which to install
    from agents.policy import BUNDLED, BUNDLED_NAME

    if str(agent) == BUNDLED_NAME:
        agent = BUNDLED
        scenario = "default" if scenario is None else scenario
    path = agent.resolve()
    if not (path.is_file() or (path / "agent.zip").is_file()):
        raise InputError(f"--agent: no saved agent at {agent} (an agent.zip or its run folder)")
    if scenario is None:
        resolved = agent_scenario(path)
        if sets:
            spec = scenarios.apply_sets(json.loads(json.dumps(resolved.spec)), sets)
            resolved = scenarios.build(resolved.name, spec)
    else:
        resolved = scenarios.resolve(scenario, sets)
    entries = [bench.Entry("agent", "agent", None, {"path": str(path)}, agent_identity(path))]
    for name in against:
        teams.check_excitation(name)
        entries.append(bench.Entry(name, "bayes", name))
    for entry in entries:
        teams.check_team(
            entry.policy,
            resolved.config,
            mode="corrected",
            excitation_spec=entry.excitation,
            **entry.kwargs,
        )
    return bench.main(
        [resolved],
        entries,
        seeds,
        out,
        mode="corrected",
        pictures=pictures,
        run=run,
        identification=True,
    )
