"""Work units and where they run: a local process pool (default) or Ray tasks.

A :class:`Unit` is ``(kind, scenario, policy, seed, params)``: one episode (or one paper run) and
everything that decides its result. Its :attr:`Unit.key` is a hash of exactly those fields, so the
same command always makes the same keys and a re-run skips what its store already holds.

:func:`run_units` runs the units missing from a store, appending each result the moment it
arrives. On the process backend (``concurrent.futures.ProcessPoolExecutor``, one worker per core)
a worker that dies (killed, out of memory, a crash in native code) breaks the pool: the units it
held run again in a fresh pool, each at most ``retries`` more times. Workers are started with
``spawn``, never forked: the main process may already run threads (torch starts its own when a
command loads an agent), and a fork of a threaded process can deadlock in the child (a script
calling :func:`run_units` must therefore guard its work with ``if __name__ == "__main__":``,
as every spawn-based pool asks). On the Ray
backend (``--backend ray``) the same units run as Ray tasks with ``max_retries`` doing the
same. Nothing else differs between the two. An exception raised by a unit itself is a bug, not
bad luck: it stops the command (the units already finished stay in the store).
"""

from __future__ import annotations

import hashlib
import importlib
import json
import logging
import multiprocessing
import os
import signal
import socket
import sys
import time
from collections import Counter, deque
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from anonloc_cli.console import echo, progress
from anonloc_cli.store import Store

log = logging.getLogger(__name__)

BACKENDS = ("process", "ray")

#: How pool workers start: a fresh interpreter, so no lock held by a parent's thread (torch's
#: OpenMP pool, a logging handler) is copied into a worker locked forever. Spawned workers are
#: the main process's own children, so ``PR_SET_PDEATHSIG`` and the parent check still hold.
START_METHOD = "spawn"

#: kind -> module whose ``run_unit(unit) -> dict`` executes it (imported in the worker).
KINDS: dict[str, str] = {
    "paper": "anonloc_cli.reproduce",
    "bench": "anonloc_cli.bench",
    "study": "anonloc_cli.study",
}


@dataclass(frozen=True)
class Unit:
    """One piece of work.

    Attributes:
        kind: which module runs it: a key of :data:`KINDS`, or the dotted name of any module
            with a ``run_unit(unit) -> dict`` function.
        scenario: the arguments of :func:`anonloc_env.parallel_env`,
            ``{"preset": name, **overrides}``.
        policy: the policy's name.
        seed: the episode seed.
        params: anything else that changes the result (mode, excitation, pictures, ...); plain
            JSON values only.
    """

    kind: str
    scenario: Mapping[str, Any]
    policy: str
    seed: int
    params: Mapping[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """The unit as plain JSON values (what the store and the workers get)."""
        return json.loads(self.canonical())

    def canonical(self) -> str:
        """The unit as canonical JSON (sorted keys, tuples as lists): the input of the key."""
        fields = {
            "kind": self.kind,
            "scenario": self.scenario,
            "policy": self.policy,
            "seed": self.seed,
            "params": self.params,
        }
        return json.dumps(fields, sort_keys=True, separators=(",", ":"))

    @property
    def key(self) -> str:
        """A stable 20-hex-digit key: the same unit, the same key, in any run on any machine."""
        return hashlib.sha256(self.canonical().encode()).hexdigest()[:20]

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Unit:
        return cls(data["kind"], data["scenario"], data["policy"], data["seed"], data["params"])


def execute(unit: dict[str, Any]) -> dict[str, Any]:
    """Run one unit (in a worker): ``{"result": ..., "seconds": ..., "worker": ...}``."""
    start = time.perf_counter()
    module = importlib.import_module(KINDS.get(unit["kind"], unit["kind"]))
    result = module.run_unit(Unit.from_dict(unit))
    return {
        "result": result,
        "seconds": round(time.perf_counter() - start, 4),
        "worker": f"{socket.gethostname()}:{os.getpid()}",
    }


class BackendError(RuntimeError):
    """The backend cannot run (e.g. Ray is not installed)."""


class UnitError(RuntimeError):
    """A unit raised an exception (a bug or a bad input that validation missed)."""


@dataclass
class Report:
    """What :func:`run_units` did.

    Attributes:
        total: units asked for.
        skipped: already in the store.
        ran: finished in this call.
        failed: keys of units whose worker died more often than allowed.
        seconds: wall time of the execution.
    """

    total: int
    skipped: int
    ran: int = 0
    failed: list[str] = field(default_factory=list)
    seconds: float = 0.0


def failed_message(keys: list[str], what: str = "units") -> str:
    """What to tell the user about units whose workers kept dying."""
    return (
        f"{len(keys)} {what} failed (their workers kept dying): {keys}; "
        "run the same command again to retry them"
    )


def default_workers() -> int:
    """The cores this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not on Linux
        return os.cpu_count() or 1


def run_units(
    units: Sequence[Unit],
    store: Store,
    *,
    backend: str = "process",
    workers: int | None = None,
    address: str | None = None,
    retries: int = 2,
    quiet: bool = False,
    description: str = "units",
) -> Report:
    """Run the units whose keys are not in ``store`` yet, appending each result as it comes.

    Args:
        units: the work, in the order results are wanted (duplicates run once).
        store: an open :class:`~anonloc_cli.store.Store`.
        backend: ``"process"`` or ``"ray"``.
        workers: parallel workers (default: the cores); on an existing Ray cluster the cluster
            decides.
        address: the Ray cluster to join (``ray.init(address=...)``); None starts a local one.
        retries: how many more times a unit whose worker died is tried.
        quiet: no progress bar.
        description: the progress bar's label.
    """
    if backend not in BACKENDS:
        raise BackendError(f"unknown backend {backend!r}; valid: {list(BACKENDS)}")
    done = set(store.load())
    unique = {u.key: u for u in units}
    todo = [u for key, u in unique.items() if key not in done]
    report = Report(total=len(unique), skipped=len(unique) - len(todo))
    log.info(
        "units",
        extra={"total": report.total, "skipped": report.skipped, "store": str(store.path)},
    )
    if not todo:
        return report
    count = max(1, workers or default_workers())
    start = time.perf_counter()
    with progress(report.total, description, quiet=quiet, initial=report.skipped) as bar:

        def finished(unit: Unit, output: dict[str, Any]) -> None:
            store.append({"key": unit.key, "unit": unit.to_dict(), **output})
            report.ran += 1
            bar.update()
            log.debug(
                "unit finished",
                extra={"key": unit.key, "seconds": output["seconds"], "worker": output["worker"]},
            )

        if backend == "ray":
            report.failed = _run_ray(
                todo, count if address is None else None, address, retries, finished
            )
        else:
            report.failed = _run_pool(todo, count, retries, finished)
    report.seconds = time.perf_counter() - start
    log.info("run finished", extra={"ran": report.ran, "seconds": round(report.seconds, 3)})
    return report


Finished = Callable[[Unit, dict[str, Any]], None]


def _worker_init(parent: int) -> None:
    """Workers leave Ctrl-C to the main process, which stops them, and die with it.

    A worker that outlived a ``kill -9`` of the main process would keep running (and, forked,
    keep the store's file and lock open) until killed by hand. On Linux the kernel
    sends it SIGKILL when its parent dies (``PR_SET_PDEATHSIG``); a parent that died before this
    ran is caught by its pid.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if sys.platform.startswith("linux"):
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGKILL, 0, 0, 0)  # 1 = PR_SET_PDEATHSIG
    if os.getppid() != parent:
        os._exit(1)


def _run_pool(todo: list[Unit], workers: int, retries: int, finished: Finished) -> list[str]:
    """Run ``todo`` on process pools; return the keys of the units given up on.

    When a worker dies the pool breaks and every unit in flight is a suspect: each is charged one
    try and runs again alone (one unit in flight), so that a unit that kills its worker is told
    apart from the innocent ones that happened to run beside it.
    """
    queue, suspects = deque(todo), deque[Unit]()
    attempts: Counter[str] = Counter()
    failed: list[str] = []
    while queue or suspects:
        source, window = (suspects, 1) if suspects else (queue, workers)
        pool = ProcessPoolExecutor(
            max_workers=min(window, len(source)),
            mp_context=multiprocessing.get_context(START_METHOD),
            initializer=_worker_init,
            initargs=(os.getpid(),),
        )
        running: dict[Future[dict[str, Any]], Unit] = {}
        broken = False
        try:
            while (source or running) and not broken:
                while source and len(running) < window:
                    try:
                        future = pool.submit(execute, source[0].to_dict())
                    except BrokenProcessPool:  # it broke before wait() told us
                        broken = True
                        break
                    running[future] = source.popleft()
                if broken:
                    break
                ready, _ = wait(running, return_when=FIRST_COMPLETED)
                for future in ready:
                    try:
                        output = future.result()
                    except BrokenProcessPool:
                        broken = True
                        continue
                    except Exception as error:
                        unit = running[future]
                        raise UnitError(
                            f"unit {unit.key} {unit.to_dict()} failed: {error}"
                        ) from error
                    finished(running.pop(future), output)
        except BaseException:
            _stop(pool)
            raise
        pool.shutdown(wait=True, cancel_futures=True)
        for unit in running.values():  # left in flight: only after a worker died
            attempts[unit.key] += 1
            if attempts[unit.key] > retries:
                failed.append(unit.key)
                log.error(
                    "unit given up: its worker died",
                    extra={"key": unit.key, "tries": attempts[unit.key]},
                )
            else:
                suspects.append(unit)
                log.warning(
                    "a worker died; its unit will run again",
                    extra={"key": unit.key, "tries": attempts[unit.key]},
                )
    return failed


def _stop(pool: ProcessPoolExecutor) -> None:
    """Cancel what is queued and end the workers now (Ctrl-C or an error)."""
    # The executor has no public way to stop running work; its workers ignore SIGINT. Read
    # them before shutdown() forgets them, end them, and only then let the executor wind down
    # (a worker stuck in native code must not keep the main process waiting at exit).
    processes = list((getattr(pool, "_processes", None) or {}).values())
    manager = getattr(pool, "_executor_manager_thread", None)
    for process in processes:
        if process.is_alive():
            process.terminate()
    for process in processes:
        process.join(timeout=2.0)
        if process.is_alive():
            process.kill()
            process.join(timeout=2.0)
    pool.shutdown(wait=False, cancel_futures=True)
    # Let the executor's manager thread finish with its workers gone (bounded): otherwise the
    # interpreter's exit hook for executors can wake it through a pipe the thread is closing,
    # and Python 3.11 prints "Bad file descriptor" with a traceback after "Interrupted" (seen in
    # CI on the Ctrl-C test of anonloc eval).
    if manager is not None:
        manager.join(timeout=5.0)


def _run_ray(
    todo: list[Unit], workers: int | None, address: str | None, retries: int, finished: Finished
) -> list[str]:
    try:
        import ray
        from ray.exceptions import RayTaskError, WorkerCrashedError
    except ImportError as error:
        raise BackendError("the ray backend needs Ray: pip install 'anonloc[ray]'") from error
    started = False
    if not ray.is_initialized():
        start = time.perf_counter()
        if address is None:
            ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False)
        else:
            ray.init(address=address, log_to_driver=False)
        started = True
        log.info(
            "ray ready",
            extra={"address": address, "seconds": round(time.perf_counter() - start, 3)},
        )
    failed: list[str] = []
    task = ray.remote(num_cpus=1, max_retries=retries)(execute)
    pending = {task.remote(unit.to_dict()): unit for unit in todo}
    try:
        while pending:
            ready, _ = ray.wait(list(pending), num_returns=1)
            more, _ = (
                ray.wait(
                    [r for r in pending if r not in ready], num_returns=len(pending) - 1, timeout=0
                )
                if len(pending) > 1
                else ([], [])
            )
            for ref in [*ready, *more]:
                unit = pending.pop(ref)
                try:
                    output = ray.get(ref)
                except WorkerCrashedError:
                    failed.append(unit.key)
                    log.error(
                        "unit failed: its worker died",
                        extra={"key": unit.key, "tries": retries + 1},
                    )
                    continue
                except RayTaskError as error:
                    raise UnitError(
                        f"unit {unit.key} ({unit.to_dict()}) failed: {error}"
                    ) from error
                finished(unit, output)
    except BaseException:
        for ref in pending:
            ray.cancel(ref, force=True)
        raise
    finally:
        if started:
            ray.shutdown()
    return failed


@dataclass(frozen=True)
class RunOptions:
    """How a command runs its work units: the options ``reproduce``, ``bench``, ``study`` and
    ``eval`` share (checked by the command line before any work)."""

    backend: str = "process"
    """``"process"`` (a local process pool) or ``"ray"`` (Ray tasks)."""
    address: str | None = None
    """With ``ray``: the cluster to join; None starts a local Ray instance."""
    workers: int | None = None
    """Parallel workers; None: one per core."""
    quiet: bool = False
    """No progress bar."""


def run_stored(
    units: Sequence[Unit], path: Path, options: RunOptions, *, description: str
) -> tuple[Report, dict[str, Any]]:
    """Run (or resume) ``units`` into the store at ``path``; the report and every stored
    record by key (the ones of earlier runs included)."""
    with Store(path) as results:
        report = run_units(
            units,
            results,
            backend=options.backend,
            address=options.address,
            workers=options.workers,
            quiet=options.quiet,
            description=description,
        )
        return report, results.load()


def finish(report: Report, *, wrote: str, what: str, seconds: float) -> int:
    """The common end of a stored run: say what was written and how long it took, report the
    units that failed; the exit status (1 if any failed, else 0)."""
    echo(f"wrote {wrote}")
    echo(f"wall time: {seconds:.1f} s ({report.ran} {what} executed, {report.skipped} reused)")
    if report.failed:
        echo(failed_message(report.failed, what), err=True)
        return 1
    return 0
