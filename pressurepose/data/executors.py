"""Where work units run: this process, a pool of local processes, or a Ray cluster.

:func:`run_units` hands each finished unit to ``on_result`` in the calling process, retries a failed
unit up to ``retries`` more times (a crashed worker process counts as a failure of the units it was
running), and raises :class:`GenerationError` naming the unit when it keeps failing. Nothing is ever
dropped silently.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import queue as queue_module
import threading
import time
from collections import deque
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Callable, Sequence

import numpy as np

from pressurepose.data.pipeline import (
    AttemptsExhausted,
    GenerationError,
    PartResult,
    Progress,
    WorkUnit,
    format_failure,
    run_unit,
)
from pressurepose.data.producers import PRODUCERS
from pressurepose.errors import BadInput

OnResult = Callable[[PartResult], None]
OnFailure = Callable[[WorkUnit, str], None]


def run_units(units: Sequence[WorkUnit], *, workers: int | str = 1, ray_address: str | None = None,
              retries: int = 2, on_result: OnResult, on_progress: Progress | None = None,
              on_failure: OnFailure | None = None) -> int:
    """Run ``units`` (``workers``: local processes, at most one per unit; see :func:`resolve_workers`);
    returns how many retries were needed."""
    check_executor(workers, ray_address, retries)
    if not units:
        return 0
    if ray_address:
        return _run_ray(units, ray_address, retries, on_result, on_failure)
    workers = resolve_workers(workers, len(units))
    if workers == 1:
        return _run_here(units, retries, on_result, on_progress, on_failure)
    return _run_pool(units, workers, retries, on_result, on_progress, on_failure)


AUTO = "auto"  # as many workers as this process may use cores, and no more than there is work for
# "auto" starts a worker only for this many samples to make: a worker's start-up (interpreter, imports,
# body model, bed: about 1.5 CPU-seconds) is then under a fifth of its work at about 1 sample per
# CPU-second, so a small run is not slower on many cores than in this process
AUTO_SAMPLES_PER_WORKER = 8


def _whole(value) -> bool:
    return isinstance(value, (int, np.integer)) and not isinstance(value, bool)


def check_executor(workers: int | str, ray_address: str | None, retries: int) -> None:
    """BadInput for settings that cannot run (checked before anything is written). ``workers``: a
    whole number of at least 1, or ``"auto"``."""
    if workers != AUTO and (not _whole(workers) or workers < 1):
        raise BadInput(f"workers = {workers!r}; expected at least 1, or {AUTO!r}")
    if not _whole(retries) or retries < 0:
        raise BadInput(f"retries = {retries!r}; expected 0 or more")
    if ray_address:
        _import_ray()


def available_cores() -> int:
    """CPU cores this process may run on: its affinity set where the system keeps one (Linux), else
    the machine's count."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # no affinity sets (macOS, Windows)
        return os.cpu_count() or 1


def resolve_workers(workers: int | str, samples: int) -> int:
    """Local worker processes to make ``samples`` samples with (1: in this process). ``workers``: a
    number, capped at ``samples``, since a sample is the smallest part of a shard a worker is handed
    (:func:`~pressurepose.data.pipeline.plan_units`), so further workers would have nothing to do; or
    ``"auto"``: :func:`available_cores`, at most one per :data:`AUTO_SAMPLES_PER_WORKER` samples."""
    check_executor(workers, None, 0)
    if workers == AUTO:
        return max(1, min(available_cores(), -(-samples // AUTO_SAMPLES_PER_WORKER)))
    return max(1, min(int(workers), samples))


class _Retries:
    def __init__(self, retries: int, on_failure: OnFailure | None):
        self.retries, self.on_failure, self.used = retries, on_failure, {}

    def failed(self, unit: WorkUnit, exc: BaseException) -> None:
        """Record a failure; raise GenerationError when the unit has no retries left."""
        message = format_failure(unit, exc)
        if isinstance(exc, AttemptsExhausted):
            raise GenerationError(f"{unit} cannot be made: {exc}") from exc
        n = self.used.get(unit, 0) + 1
        self.used[unit] = n
        if n > self.retries:
            hint = (f"\n(a worker process ended abruptly: killed for memory, or it could not start; {SCRIPT_GUARD})"
                    if isinstance(exc, BrokenProcessPool) else "")
            raise GenerationError(f"{unit} failed {n} times; giving up. Last error:\n{message}{hint}") from exc
        if self.on_failure:
            self.on_failure(unit, message)

    @property
    def total(self) -> int:
        return sum(self.used.values())


# --------------------------------------------------------------------------- in this process


def _run_here(units, retries, on_result, on_progress, on_failure) -> int:
    tracker = _Retries(retries, on_failure)
    todo = deque(units)
    while todo:
        unit = todo.popleft()
        try:
            result = run_unit(unit, on_progress)
        except Exception as exc:  # noqa: BLE001 - any producer error is a unit failure to retry
            tracker.failed(unit, exc)
            todo.appendleft(unit)
            continue
        on_result(result)
    return tracker.total


# --------------------------------------------------------------------------- local processes

_EVENTS = None  # the worker's progress queue (set by _init_worker)


def _init_worker(events, coordinator: int) -> None:
    """Worker set-up: the progress queue, and a watchdog that ends this worker when the coordinating
    process is gone (killed with -9, say), so no orphan keeps running or waiting."""
    global _EVENTS
    _EVENTS = events

    def watch() -> None:
        while True:
            time.sleep(1.0)
            try:
                os.kill(coordinator, 0)
            except ProcessLookupError:
                os._exit(1)

    threading.Thread(target=watch, daemon=True, name="coordinator-watchdog").start()


def _run_unit_in_worker(unit: WorkUnit) -> PartResult:
    pending = [0, 0]
    last = [time.monotonic()]

    def report(shard: int, accepted: int, rejected: int) -> None:
        pending[0] += accepted
        pending[1] += rejected
        now = time.monotonic()
        if now - last[0] > 0.2:
            _EVENTS.put((shard, pending[0], pending[1]))
            pending[0] = pending[1] = 0
            last[0] = now

    result = run_unit(unit, report)
    if pending[0] or pending[1]:
        _EVENTS.put((unit.shard, pending[0], pending[1]))
    return result


def _context(producer: str):
    """'forkserver' where available: workers fork from a clean server process that has imported the
    pipeline and the producer's module once (fast start, and safe with threads such as torch's or
    MuJoCo's in this process); 'spawn' elsewhere."""
    if "forkserver" in mp.get_all_start_methods():
        ctx = mp.get_context("forkserver")
        module = PRODUCERS.get(producer, producer).partition(":")[0]
        ctx.set_forkserver_preload(["pressurepose.data.pipeline", "pressurepose.data.executors", module])
        return ctx
    return mp.get_context("spawn")


def _abandon(pool: ProcessPoolExecutor) -> None:
    """Shut a pool down without waiting, and terminate its workers. A broken pool's manager thread
    terminates the workers it knows of and then joins them all; a worker started by a ``submit`` in
    the same moment escapes the termination and waits for work forever, and the manager's join with
    it, which hangs the interpreter at exit. Terminating every worker here closes that race."""
    workers = list((getattr(pool, "_processes", None) or {}).values())  # no public handle on them
    pool.shutdown(wait=False, cancel_futures=True)
    for proc in workers:
        if proc.is_alive():
            proc.terminate()


# Python starts each worker process by importing the script that started the run again (the
# forkserver and spawn start methods): a script whose top level runs generate would start it anew
SCRIPT_GUARD = ("each worker process imports the script that started it again, so a script that runs generate "
                "with several workers must keep its top-level code under `if __name__ == \"__main__\":`; or run "
                "with one worker (--workers 1, workers=1)")


def _run_pool(units, workers, retries, on_result, on_progress, on_failure) -> int:
    if getattr(mp.current_process(), "_inheriting", False):
        # this is a worker starting up, importing an unguarded script: end it before the rest of the
        # script runs here too; the run that started it reports SCRIPT_GUARD when it gives up
        raise SystemExit(f"pressurepose: {SCRIPT_GUARD}")
    tracker = _Retries(retries, on_failure)
    ctx = _context(units[0].config.producer)
    events = ctx.Queue()
    todo = deque(units)

    def drain() -> None:
        while True:
            try:
                shard, accepted, rejected = events.get_nowait()
            except queue_module.Empty:
                return
            if on_progress:
                on_progress(shard, accepted, rejected)

    def new_pool() -> ProcessPoolExecutor:
        return ProcessPoolExecutor(workers, mp_context=ctx, initializer=_init_worker,
                                   initargs=(events, os.getpid()))

    pool = new_pool()
    running: dict = {}
    try:
        while todo or running:
            broken = False
            while todo and len(running) < workers:  # only running units are in flight
                unit = todo[0]
                try:
                    fut = pool.submit(_run_unit_in_worker, unit)
                except BrokenProcessPool:  # a worker died since the last wait: the unit never started
                    broken = True
                    break
                running[fut] = todo.popleft()
            if broken:  # keep what finished before the pool broke
                done = {fut for fut in running if fut.done()}
            else:
                done, _ = wait(running, timeout=0.2, return_when=FIRST_COMPLETED)
            drain()
            for fut in done:
                unit = running.pop(fut)
                try:
                    result = fut.result()
                except BrokenProcessPool as exc:
                    broken = True
                    tracker.failed(unit, exc)
                    todo.appendleft(unit)
                except Exception as exc:  # noqa: BLE001 - any worker error is a unit failure to retry
                    tracker.failed(unit, exc)
                    todo.appendleft(unit)
                else:
                    on_result(result)
            if broken:  # a worker process died: every unit still in flight died with it
                for fut, unit in list(running.items()):
                    tracker.failed(unit, BrokenProcessPool("a worker process died"))
                    todo.appendleft(unit)
                running.clear()
                _abandon(pool)
                pool = new_pool()
        drain()
    except BaseException:
        _abandon(pool)
        raise
    pool.shutdown(wait=True)
    return tracker.total


# --------------------------------------------------------------------------- Ray


def _import_ray():
    try:
        import ray
    except ImportError:
        raise BadInput("--ray needs the optional Ray package: pip install 'pressurepose[ray]'") from None
    return ray


def _run_ray(units, address, retries, on_result, on_failure) -> int:
    """Run units as Ray tasks (one CPU each). ``address`` 'local' starts a private local instance;
    otherwise it is passed to ``ray.init`` (e.g. 'auto' or 'ray://head:10001'). Every node needs
    pressurepose installed; results come back to this process, so no shared disk is needed."""
    ray = _import_ray()
    started = not ray.is_initialized()
    if started:
        ray.init(address=None if address == "local" else address, include_dashboard=False,
                 log_to_driver=False, configure_logging=False)
    tracker = _Retries(retries, on_failure)
    task = ray.remote(num_cpus=1, max_retries=0)(run_unit)
    refs = {task.remote(unit): unit for unit in units}
    try:
        while refs:
            ready, _ = ray.wait(list(refs), num_returns=1, timeout=1.0)
            for ref in ready:
                unit = refs.pop(ref)
                try:
                    result = ray.get(ref)
                except Exception as exc:  # noqa: BLE001 - task errors and lost workers alike
                    cause = getattr(exc, "cause", None)
                    tracker.failed(unit, cause if isinstance(cause, AttemptsExhausted) else exc)
                    refs[task.remote(unit)] = unit
                else:
                    on_result(result)
    finally:
        for ref in refs:
            ray.cancel(ref, force=True)
        if started:
            ray.shutdown()
    return tracker.total
