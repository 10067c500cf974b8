"""The ``anonloc`` command line (Typer): thin commands over :mod:`anonloc_cli`'s modules.

Only Typer is imported at start-up, so that ``anonloc --help`` answers at once; every command
imports what it needs when it runs.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated, Any, NoReturn

try:
    import typer
except ModuleNotFoundError as missing:  # the script is installed even without the extra
    if missing.name != "typer":
        raise
    sys.stderr.write("anonloc: the command line needs its extra: pip install 'anonloc[cli]'\n")
    raise SystemExit(1) from None

from anonloc_cli.config_options import config_fields, with_config_options  # ast, no import
from anonloc_cli.failures import failures_reported  # Typer alone at the top
from anonloc_cli.options import (  # Typer's aliases and their checks, nothing heavy
    SHOW_SETS,
    Address,
    Backend,
    BackendOption,
    EpisodeSeed,
    OutFolder,
    OutTable,
    Pictures,
    Quiet,
    Sets,
    ShownPolicy,
    ShownScenario,
    Verbose,
    Workers,
    check_out,
    run_options,
)
from anonloc_cli.sweeps import DEFAULT_SEEDS, MAX_SEEDS, SWEEPS  # plain data, nothing heavy
from baselines.catalog import excitation_names, policy_names  # the standard library alone

app = typer.Typer(
    name="anonloc",
    help=(
        "Self-localization of anonymous robots from aerial images: reproduce the paper, "
        "benchmark policies, study the open questions, render episodes."
    ),
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,  # help texts are plain: "[ray]" in them is not markup
)


#: ``eval``'s episodes when --seeds is not given.
EVAL_SEEDS = 20


def _version(value: bool) -> None:
    if value:
        import anonloc_env

        typer.echo(f"anonloc {anonloc_env.__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: Annotated[
        bool,
        typer.Option("--version", callback=_version, is_eager=True, help="Print the version."),
    ] = False,
) -> None:
    """Self-localization of anonymous robots from aerial images."""


@app.command()
def reproduce(
    runs: Annotated[
        int | None,
        typer.Option(min=1, help="Runs of each experiment (default: the paper's 65, 100 and 118)."),
    ] = None,
    out: OutFolder = Path("results"),
    backend: BackendOption = Backend.process,
    address: Address = None,
    workers: Workers = None,
    quiet: Quiet = False,
    verbose: Verbose = 0,
) -> None:
    """Re-run the paper's three experiments and print its table next to the paper's figures.

    Writes OUT/reproduce.md (the table, versions, command), OUT/reproduce.csv (one row per run
    and robot) and the resumable store OUT/reproduce.jsonl: run it again to resume.
    """
    with failures_reported(verbose):
        run = run_options(backend, address, workers, quiet)
        check_out(out, folder=True)
        from anonloc_cli import reproduce as command
        from baselines.paper import EXPERIMENTS

        counts = {m: (e.runs if runs is None else runs) for m, e in EXPERIMENTS.items()}
        status = command.main(counts, out, run)
    raise typer.Exit(status)


@app.command()
def bench(
    scenario: Annotated[
        list[str],
        typer.Option(
            help="A preset (default, paper-angular, paper-linear, paper-motion) or a TOML/YAML "
            "scenario file (repeatable)."
        ),
    ],
    policy: Annotated[
        list[str],
        typer.Option(
            help=f"A policy (repeatable): {', '.join(policy_names())}. 'agent' is the bundled "
            "learned agent."
        ),
    ],
    seeds: Annotated[
        int,
        typer.Option(min=1, max=MAX_SEEDS, help="Episodes per policy and scenario (seeds 0..N-1)."),
    ],
    out: OutTable,
    mode: Annotated[
        str, typer.Option(help="The paper's methods corrected, or faithful (as printed).")
    ] = "corrected",
    excitation: Annotated[
        str | None,
        typer.Option(
            help="Motion between pictures (default: the policy's own): "
            f"{', '.join(excitation_names())}."
        ),
    ] = None,
    pictures: Pictures = None,
    set_: Sets = None,
    backend: BackendOption = Backend.process,
    address: Address = None,
    workers: Workers = None,
    quiet: Quiet = False,
    verbose: Verbose = 0,
) -> None:
    """Any policies x scenarios x seeds: one row per robot and episode, plus a summary table.

    Writes OUT (CSV or Parquet), OUT's .md (summary and provenance), .meta.json, and the resumable
    store OUT's .units.jsonl: run it again to resume.
    """
    with failures_reported(verbose):
        run = run_options(backend, address, workers, quiet)
        check_out(out, folder=False)
        from anonloc_cli import bench as command
        from anonloc_cli import scenarios, teams

        resolved = scenarios.distinct(
            [scenarios.resolve(s, set_ or []) for s in scenario], scenario
        )
        names = [teams.check_policy(p) for p in policy]
        teams.check_mode(mode)
        teams.check_excitation(excitation)
        for s in resolved:
            for name in names:
                teams.check_team(name, s.config, mode=mode, excitation_spec=excitation)
        entries = [command.Entry(name, name, excitation) for name in names]
        status = command.main(
            resolved,
            entries,
            seeds,
            out,
            mode=mode,
            pictures=pictures,
            run=run,
        )
    raise typer.Exit(status)


@app.command()
def study(
    sweep: Annotated[
        list[str] | None,
        typer.Option(help=f"A sweep (repeatable; default: all): {', '.join(SWEEPS)}."),
    ] = None,
    out: OutFolder = Path("results/study"),
    seeds: Annotated[
        int | None,
        typer.Option(
            min=1, max=MAX_SEEDS, help=f"Episodes per point and policy (default: {DEFAULT_SEEDS})."
        ),
    ] = None,
    backend: BackendOption = Backend.process,
    address: Address = None,
    workers: Workers = None,
    quiet: Quiet = False,
    verbose: Verbose = 0,
) -> None:
    """Sweeps on the paper's open questions, as plots with 95 % bands and CSV.

    Success and pictures to decision of bayes (and of the corrected motion method) against the
    number of robots, picture interval, control step, pixel noise, camera tilt, misses, false
    detections, swarm-like motion, and a blackout (pictures until identified again).

    Writes OUT/NAME.png, .svg (95 % confidence bands), .csv and .meta.json per sweep, and the
    resumable store OUT/study.jsonl: run it again to resume (or with more --seeds to add episodes).
    """
    with failures_reported(verbose):
        run = run_options(backend, address, workers, quiet)
        check_out(out, folder=True)
        from anonloc_cli import study as command

        command.check_sweeps(sweep or [])
        status = command.main(
            sweep or [],
            out,
            seeds=seeds or DEFAULT_SEEDS,
            run=run,
        )
    raise typer.Exit(status)


def _shown(scenario: str | None, sets: list[str]) -> Any:
    """The scenario ``render``/``frame`` play (see :data:`anonloc_cli.options.SHOW_SETS`)."""
    from anonloc_cli import scenarios

    if scenario is None:
        return scenarios.resolve("default", [*SHOW_SETS, *sets])
    return scenarios.resolve(scenario, sets)


@app.command()
def render(
    out: Annotated[
        Path | None, typer.Option(help="A .gif (or .mp4 with an ffmpeg plugin).")
    ] = None,
    scenario: ShownScenario = None,
    policy: ShownPolicy = "bayes",
    seed: EpisodeSeed = 0,
    steps: Annotated[
        int,
        typer.Option(min=1, help="Control steps to play (at most the scenario's max_cycles)."),
    ] = 200,
    fps: Annotated[
        float, typer.Option(min=0.1, help="Frames per second of simulated time.")
    ] = 20.0,
    human: Annotated[
        bool, typer.Option("--human", help="Show a window instead of writing a file.")
    ] = False,
    set_: Sets = None,
    quiet: Quiet = False,
    verbose: Verbose = 0,
) -> None:
    """Play a scenario with a policy and write a GIF or MP4 showing each robot's current guess.

    Needs pygame-ce (in the cli extra); --human needs a display.
    """
    with failures_reported(verbose):
        from anonloc_cli import recording as command
        from anonloc_cli import teams

        command.check_output(out, human)
        resolved = _shown(scenario, set_ or [])
        command.check_steps(steps, resolved)
        name = teams.check_policy(policy)
        teams.check_team(name, resolved.config, mode="corrected")
        status = command.main(
            resolved, name, out=out, seed=seed, steps=steps, human=human, fps=fps, quiet=quiet
        )
    raise typer.Exit(status)


@app.command()
def detect(
    folder: Annotated[Path, typer.Argument(help="A folder of PNG/JPEG frames.")],
    camera: Annotated[
        str,
        typer.Option(
            help="A TOML/YAML scenario file (or a preset) whose camera section fixes the pixel "
            "grid: image_pixels_per_unit, image_size, principal_point."
        ),
    ],
    out: OutTable = Path("detections.csv"),
    skip_bad: Annotated[
        bool,
        typer.Option(
            "--skip-bad",
            help="Skip unreadable frames or frames of the wrong size (each is named) instead "
            "of stopping.",
        ),
    ] = False,
    quiet: Quiet = False,
    verbose: Verbose = 0,
) -> None:
    """Detect the robots' ArUco markers in every frame of FOLDER (name order) and write one row
    per detection: frame, u, v, theta, in the picture format the localizers read.

    Needs the images extra (OpenCV): pip install 'anonloc[images]'.
    """
    with failures_reported(verbose):
        from anonloc_cli import detect as command
        from anonloc_cli import scenarios

        command.check_output(out)
        resolved = scenarios.resolve(camera)
        status = command.main(folder, resolved, out, quiet=quiet, skip_bad=skip_bad)
    raise typer.Exit(status)


@app.command()
def frame(
    out: Annotated[Path, typer.Option(help="The PNG to write.")],
    scenario: ShownScenario = None,
    policy: ShownPolicy = "bayes",
    seed: EpisodeSeed = 0,
    steps: Annotated[
        int,
        typer.Option(
            min=0,
            help="Control steps before the frame (default: the moment the second picture is "
            "taken, while some robots are still undecided). At most the scenario's max_cycles.",
        ),
    ] = 20,
    set_: Sets = None,
    preset: Annotated[
        str | None, typer.Option(hidden=True, help="Deprecated: use --scenario.")
    ] = None,
    quiet: Quiet = False,
    verbose: Verbose = 0,
) -> None:
    """One rendered frame: a scenario played for --steps control steps, each robot's guess drawn.

    Needs pygame-ce (in the cli extra).
    """
    with failures_reported(verbose):
        from anonloc_cli import recording as command
        from anonloc_cli import teams

        if preset is not None:
            typer.echo("Warning: --preset is deprecated; use --scenario", err=True)
            scenario = preset
        command.check_png(out)
        resolved = _shown(scenario, set_ or [])
        command.check_steps(steps, resolved)
        name = teams.check_policy(policy)
        teams.check_team(name, resolved.config, mode="corrected")
        status = command.frame(resolved, name, out=out, seed=seed, steps=steps, quiet=quiet)
    raise typer.Exit(status)


#: ``TrainConfig``'s fields, read from its source (nothing imported): each becomes an option of
#: ``train`` but those the command handles itself.
TRAIN_FIELDS = config_fields("agents", "train.py", "TrainConfig")
#: Fields ``train`` sets from its own options (``--scenario``/``--set``, ``--quiet``, ...).
TRAIN_OWN = {"preset", "overrides", "out", "name", "minutes", "timesteps", "progress"}


@app.command()
@with_config_options(TRAIN_FIELDS, skip=TRAIN_OWN)
def train(
    timesteps: Annotated[
        int | None,
        typer.Option(
            min=1,
            help="Robot-steps of experience in all (slots x steps; default 200000). With "
            "--resume: a new total (default: the run's own).",
        ),
    ] = None,
    out: Annotated[Path, typer.Option(help="Folder of the runs.")] = Path("runs"),
    scenario: Annotated[
        str, typer.Option(help="A preset or a TOML/YAML scenario file.")
    ] = "default",
    name: Annotated[
        str | None, typer.Option(help="Run name (default: scenario-condition-ppo-...-time).")
    ] = None,
    minutes: Annotated[
        float | None,
        typer.Option(
            min=0.01,
            help="Wall-clock budget of this call: stop and save after this many minutes "
            "(with --resume, default: the run's own).",
        ),
    ] = None,
    resume: Annotated[
        Path | None,
        typer.Option(
            help="Continue this run folder from its newest good checkpoint, up to the run's "
            "own total robot-steps (or a new --timesteps); the run's recorded settings are kept."
        ),
    ] = None,
    set_: Sets = None,
    quiet: Quiet = False,
    verbose: Verbose = 0,
    config: dict[str, Any] | None = None,
) -> None:
    """Train one excitation policy shared by every robot (SB3 PPO); see docs/agents.md.

    Writes OUT/<run>/config.json, tb/ (TensorBoard), checkpoints/ and agent.zip. Ctrl-C or
    SIGTERM saves a checkpoint and agent.zip first; continue with --resume. Every field of
    agents.train.TrainConfig is an option (generated from it). Needs the rl extra:
    pip install torch==2.13.0 && pip install 'anonloc[rl]'.
    """
    with failures_reported(verbose):
        from anonloc_cli import learning

        status = learning.train(
            timesteps=timesteps,
            out=out,
            scenario=scenario,
            sets=set_ or [],
            name=name,
            minutes=minutes,
            resume=resume,
            quiet=quiet,
            config=config or {},
        )
    raise typer.Exit(status)


SEARCH_FIELDS = config_fields("agents", "search.py", "SearchConfig")


@app.command()
@with_config_options(SEARCH_FIELDS, skip=set())
def search(
    context: typer.Context,
    out: Annotated[
        Path, typer.Argument(help="The search's folder: search.json, progress.csv, agent.zip.")
    ],
    resume: Annotated[
        bool,
        typer.Option(
            help="Continue the search in OUT with its own settings (the options given here "
            "replace them; any but --workers and --minutes that differs is refused)."
        ),
    ] = False,
    quiet: Quiet = False,
    verbose: Verbose = 0,
    config: dict[str, Any] | None = None,
) -> None:
    """Search the weights of a linear agent against chance (an evolution strategy).

    Every generation plays `uniform` and each candidate weight vector on the same drawn training
    scenarios and seeds, and keeps the ones that need fewer pictures and less energy than
    `uniform`; see docs/agents.md. Writes OUT/search.json (resumable after a kill),
    progress.csv (the validation curve) and agent.zip (for anonloc eval --agent OUT). Every
    field of agents.search.SearchConfig is an option. Needs the rl extra.
    """
    with failures_reported(verbose):
        from anonloc_cli import learning

        learning.search(
            out=out, resume=resume, quiet=quiet, config=config or {}, given=given_options(context)
        )


def given_options(context: typer.Context) -> set[str]:
    """The names of the command's parameters that its command line (or the environment) gave,
    not their defaults."""
    sources = {name: context.get_parameter_source(name) for name in context.params}
    return {
        name
        for name, source in sources.items()
        if source is not None and source.name not in ("DEFAULT", "DEFAULT_MAP")
    }


@app.command(name="eval")
def evaluate(
    agent: Annotated[
        Path,
        typer.Option(
            help="A saved agent: agent.zip, its run folder, or 'bundled' (the agent shipped "
            "with anonloc; its scenario defaults to 'default')."
        ),
    ],
    seeds: Annotated[
        int,
        typer.Option(
            min=1, max=MAX_SEEDS, help="Episodes (seeds 0..N-1; training never uses them)."
        ),
    ] = EVAL_SEEDS,
    out: OutTable = Path("eval.csv"),
    scenario: Annotated[
        str | None,
        typer.Option(help="A preset or scenario file (default: the agent's own, as trained)."),
    ] = None,
    against: Annotated[
        list[str] | None,
        typer.Option(
            help="Excitations to compare with, each run by the bayes policy (repeatable): "
            f"{', '.join(excitation_names())}."
        ),
    ] = None,
    pictures: Pictures = None,
    set_: Sets = None,
    backend: BackendOption = Backend.process,
    address: Address = None,
    workers: Workers = None,
    quiet: Quiet = False,
    verbose: Verbose = 0,
) -> None:
    """Evaluate a saved agent (and baseline excitations) as anonloc bench does, plus the
    pictures until 99 % of the robots present are identified.

    Loading an agent unpickles parts of its file (SB3): only load files you trust.
    """
    with failures_reported(verbose):
        run = run_options(backend, address, workers, quiet)
        check_out(out, folder=False)
        from anonloc_cli import learning

        status = learning.evaluate(
            agent=agent,
            seeds=seeds,
            out=out,
            scenario=scenario,
            sets=set_ or [],
            against=against or [],
            pictures=pictures,
            run=run,
        )
    raise typer.Exit(status)


def main(argv: list[str] | None = None, prog_name: str = "anonloc") -> NoReturn:
    """Run the command line (``argv`` defaults to ``sys.argv[1:]``) and exit."""
    app(args=sys.argv[1:] if argv is None else argv, prog_name=prog_name)
    raise SystemExit(0)  # pragma: no cover - Typer always exits
