"""Where the runs execute: a local process pool (default) or a Ray cluster (`planicp[cluster]`).

Both take the runs still to do and hand every record to `on_result` in the calling process as soon
as its run finishes (in completion order; the table is sorted later). Scheduling is the pool's or
Ray's: runs are submitted, and finished ones collected.
"""

from __future__ import annotations

import concurrent.futures
import importlib
import multiprocessing
import os
from collections.abc import Callable, Sequence
from concurrent.futures.process import BrokenProcessPool
from typing import Any

from .runs import RunSpec, execute_run, failed_record

__all__ = ["RAY_MISSING", "RunFunction", "import_ray", "run_local", "run_ray"]

RunFunction = Callable[[RunSpec], dict[str, Any]]
"""Parameters in, record out (`execute_run`); must be importable by name in a worker process."""

RAY_MISSING = "running a study on Ray needs the cluster extra: pip install 'planicp[cluster]'"


def run_local(
    runs: Sequence[RunSpec],
    on_result: Callable[[dict[str, Any]], None],
    workers: int | None = None,
    run: RunFunction = execute_run,
) -> None:
    """Runs `runs` in a pool of `workers` processes (default: one per CPU; spawned, not forked, so
    that a worker starts clean on every platform).

    On an interruption (Ctrl-C) or an error in `on_result`, runs not started are cancelled and the
    exception propagates; records already handed to `on_result` are kept by the caller.

    Raises:
        RuntimeError: a worker process died (a crash in native code, or killed): the runs that had
            not reported are not recorded, so a rerun of the study does them.
    """
    if not runs:
        return
    count = workers if workers is not None else (os.cpu_count() or 1)
    if isinstance(count, bool) or not isinstance(count, int) or count < 1:
        raise ValueError(f"workers must be a positive integer, got {workers!r}")
    pool = concurrent.futures.ProcessPoolExecutor(
        max_workers=min(count, len(runs)), mp_context=multiprocessing.get_context("spawn")
    )
    try:
        futures = [pool.submit(run, spec) for spec in runs]
        for future in concurrent.futures.as_completed(futures):
            try:
                record = future.result()
            except BrokenProcessPool as exc:
                raise RuntimeError(
                    f"a worker process died ({exc}); finished runs are kept, rerun the study to do the others"
                ) from None
            on_result(record)
    except BaseException:
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown(wait=True)


def import_ray() -> Any:
    """The `ray` module (typed Any: Ray is optional).

    Raises:
        ImportError: Ray is not installed; the message names `pip install 'planicp[cluster]'`.
    """
    try:
        return importlib.import_module("ray")
    except ImportError as exc:
        raise ImportError(f"{RAY_MISSING} ({exc})") from None


def run_ray(
    runs: Sequence[RunSpec],
    on_result: Callable[[dict[str, Any]], None],
    address: str | None = None,
    run: RunFunction = execute_run,
) -> None:
    """Runs `runs` as Ray tasks (one CPU each) and collects them as they finish.

    Connects with `ray.init(address=address)` unless Ray is already initialised in this process
    (then that instance is used and left running). None is Ray's default: the cluster in
    `RAY_ADDRESS`, else one started on this machine with `ray start`, else a new local instance;
    "local" always starts a new local instance, "auto" joins the cluster this machine belongs to,
    "ray://host:10001" a remote one through Ray Client. Every node needs planicp installed and the
    plan files at the same paths (a shared folder), or only the shipped `default` plan.

    A task that fails in Ray itself (its worker died after Ray's retries) is recorded as a failed
    run with Ray's error. On an interruption, the tasks not finished are cancelled.
    """
    if not runs:
        return
    ray = import_ray()
    started_here = not ray.is_initialized()
    if started_here:
        # No dashboard for an instance started here; a cluster joined keeps its own settings.
        options = {"include_dashboard": False} if address in (None, "local") else {}
        ray.init(address=address, log_to_driver=False, **options)
    try:
        task = ray.remote(num_cpus=1)(run)
        pending = {task.remote(spec): spec for spec in runs}
        try:
            while pending:
                done, _ = ray.wait(list(pending), num_returns=1)
                for ref in done:
                    spec = pending.pop(ref)
                    try:
                        record = ray.get(ref)
                    except Exception as exc:  # noqa: BLE001 - RayTaskError, WorkerCrashedError, ...
                        record = failed_record(spec, f"{type(exc).__name__}: {exc}")
                    on_result(record)
        except BaseException:
            for ref in pending:
                ray.cancel(ref, force=True)
            raise
    finally:
        if started_here:
            ray.shutdown()
