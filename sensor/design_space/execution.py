"""Running a sweep: rows on the local cores or on a Dask distributed cluster, checkpointed
atomically so that an interrupted run finishes with ``resume`` and computes nothing twice.

A row's result does not depend on where it ran, so every scheduler gives the same dataset.

Faults end a sweep in order, never with a hang or an orphan: Ctrl-C or SIGTERM
(:class:`~sensor.errors.Terminated`) saves the checkpoint and raises
:class:`~sensor.errors.SweepInterrupted`; local worker processes are stopped with the sweep
and kill themselves if the sweep's process dies (even by SIGKILL); a Dask cluster that
loses every worker, or its scheduler, for ``cluster_timeout_s`` raises
:class:`~sensor.errors.ClusterLostError` after saving the checkpoint.
"""

from __future__ import annotations

import contextlib
import functools
import os
import re
import signal
import threading
import time
import warnings
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path

import xarray as xr

from geometry.atomic import remove_stale_temps
from sensor.design_space.dataset import (
    check_dataset,
    empty_dataset,
    load_dataset,
    merge_row,
    rows_to_do,
    save_dataset,
)
from sensor.design_space.rows import solve_row
from sensor.design_space.spec import SweepSpec
from sensor.errors import (
    ClusterLostError,
    ResourceNote,
    SweepError,
    SweepInterrupted,
    Terminated,
)
from sensor.validation import Number

#: Seconds without any Dask worker (or without the scheduler) before a sweep gives up;
#: with the 2 s the client takes to notice, a lost cluster ends the sweep within 20 s.
CLUSTER_TIMEOUT_S = 10.0
#: A Dask scheduler address: protocol://host[:port] or host:port.
_ADDRESS = re.compile(r"[a-z][a-z0-9+]*://[A-Za-z0-9._\-\[\]:/]+|[A-Za-z0-9._\-\[\]]+:\d+")
#: The variables that say which cells a checkpoint holds (named first when missing).
_BOOKKEEPING = ("computed", "feasible", "reason", "basis_reason")
_WORKERS = Number(0, 4096, integer=True)
_TIMEOUT = Number(0.1, 3600.0, unit="s")


def run_sweep(spec: SweepSpec, version: str, dataset_path: Path | None = None, resume: bool = False,
              workers: int = 0, scheduler: str | None = None, progress=None,
              checkpoint_s: float = 5.0, cluster_timeout_s: float = CLUSTER_TIMEOUT_S,
              ) -> tuple[xr.Dataset, int]:
    """Run (or finish) a sweep. Returns the dataset and the number of cells computed now.

    ``workers`` = 0 picks the number of local cores (more than the cores are capped, with a
    :class:`~sensor.errors.ResourceNote`); 1 runs serially in this process. ``scheduler`` is
    a Dask distributed scheduler address. With ``resume`` the cells of an existing dataset
    at ``dataset_path`` (same spec) are reused. The dataset is checkpointed (atomically)
    every ``checkpoint_s`` seconds, or 20 times as long as the last save took if that is
    longer, and when the sweep is stopped, so it can be resumed.
    """
    check_run_options(workers, scheduler, cluster_timeout_s)
    if dataset_path is not None:
        remove_stale_temps(dataset_path)
    ds = _checkpoint(spec, dataset_path) if resume and dataset_path is not None else None
    if ds is None:
        ds = empty_dataset(spec, version)
    todo = rows_to_do(ds)
    n_cells = int(sum(m.sum() for _, _, m in todo))
    done = 0
    if progress is not None:
        progress.start(n_cells)
    last, interval = time.monotonic(), checkpoint_s
    try:
        with contextlib.closing(_execute(spec, todo, workers, scheduler, cluster_timeout_s)) as rows:
            for row in rows:
                with _signals_held():    # a stop lands between rows: the count is the checkpoint's
                    merge_row(ds, row)
                    done += int(row["computed"].sum())
                if progress is not None:
                    progress.advance(int(row["computed"].sum()))
                if dataset_path is not None and time.monotonic() - last > interval:
                    start = time.monotonic()
                    save_dataset(ds, dataset_path)
                    last = time.monotonic()
                    # a save grows with the grid (about 40 s at 10^6 cells): at most 1/20 of the run
                    interval = max(checkpoint_s, 20 * (last - start))
    except (KeyboardInterrupt, ClusterLostError) as exc:
        where = _save_checkpoint(ds, dataset_path, done)
        what = (f"after {done} of {n_cells} cells{where}; finish with --resume" if done else
                f"before the first of {n_cells} cells was done (nothing to save)")
        if isinstance(exc, ClusterLostError):
            raise ClusterLostError(f"{exc}: stopped {what}") from None
        signum = signal.SIGTERM if isinstance(exc, Terminated) else signal.SIGINT
        raise SweepInterrupted(f"interrupted {what}", signum) from None
    finally:
        if progress is not None:
            progress.stop()
    return ds, n_cells


def check_run_options(workers: int = 0, scheduler: str | None = None,
                      cluster_timeout_s: float = CLUSTER_TIMEOUT_S) -> None:
    """Check where a sweep is to run before anything is made; raise :class:`SweepError`."""
    _WORKERS.check("--workers", workers, SweepError)
    _TIMEOUT.check("cluster_timeout_s", cluster_timeout_s, SweepError)
    if scheduler is not None and not (isinstance(scheduler, str) and _ADDRESS.fullmatch(scheduler)):
        raise SweepError(f"--scheduler = {scheduler!r}: must be a Dask scheduler address "
                         "protocol://host[:port] or host:port, e.g. tcp://10.0.0.5:8786")


@contextlib.contextmanager
def _signals_held():
    """Hold SIGINT and SIGTERM for the block (main thread only): one that arrives is raised
    when it ends, so a row is merged and counted whole (a stop between the two had the
    message count 200 cells fewer than the checkpoint held)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []
    handlers = {s: signal.signal(s, lambda signum, frame: caught.append(signum))
                for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for s, h in handlers.items():
            signal.signal(s, h)
        if caught:
            signal.raise_signal(caught[0])


def _save_checkpoint(ds: xr.Dataset, path: Path | None, done: int) -> str:
    """Save the finished cells of a stopped sweep; ' (saved in PATH)' or ''. A second
    Ctrl-C during the save is deferred so the checkpoint is never left half-written."""
    if path is None or not done:
        return ""
    handlers = {}
    if threading.current_thread() is threading.main_thread():
        handlers = {s: signal.signal(s, signal.SIG_IGN) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        save_dataset(ds, path)
    finally:
        for s, h in handlers.items():
            signal.signal(s, h)
    return f" (saved in {path})"


def _checkpoint(spec: SweepSpec, path: Path) -> xr.Dataset | None:
    """The dataset to resume from, or None if there is none yet; checks it is a sweep
    dataset of this spec (every variable present, same settings) and names the file if not."""
    if not path.exists():
        return None

    def unreadable(exc):
        reason = " ".join(str(exc).split())[:160] or type(exc).__name__
        return SweepError(f"--resume: {path} is not a readable sweep dataset ({reason}); "
                          "remove it or use another --out")

    try:  # h5py and xarray raise many kinds of error for a corrupt file
        with xr.open_dataset(path, engine="h5netcdf") as raw:
            names = set(raw.data_vars)
    except Exception as exc:
        raise unreadable(exc) from None
    reference = empty_dataset(spec, "")
    missing = sorted(set(reference.data_vars) - names, key=lambda v: (v not in _BOOKKEEPING, v))
    if missing:
        raise SweepError(f"--resume: {path} lacks {len(missing)} variable(s) of a sweep dataset "
                         f"({', '.join(missing[:4])}{', ...' if len(missing) > 4 else ''}): not written "
                         "by dacm sweep; remove it or use another --out")
    try:
        ds = load_dataset(path)
    except Exception as exc:
        raise unreadable(exc) from None
    if ds.attrs.get("spec") != spec.to_json():
        raise SweepError(f"--resume: {path} was made with other parameters; "
                         "use the same grid and settings, or another --out")
    if any(ds[v].shape != reference[v].shape for v in reference.data_vars):
        raise SweepError(f"--resume: {path}: variable shapes differ from the grid of its settings")
    check_dataset(ds, f"--resume: {path}")
    ds.attrs.pop("row_sha256", None)  # true of the file; the rows computed now change the data
    return ds


def local_workers(requested: int) -> int:
    """Worker processes for ``requested`` (0: one per core), capped at the cores this process
    may use, with a :class:`~sensor.errors.ResourceNote` when capped."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    if requested > cores:
        warnings.warn(f"workers = {requested}: more than the {cores} cores of this machine; "
                      f"using {cores}", ResourceNote, stacklevel=3)
    return min(requested or cores, cores)


def _execute(spec: SweepSpec, todo, workers: int, scheduler: str | None, cluster_timeout_s: float):
    """Yield solved rows, computed serially, on local processes or on a Dask cluster."""
    if not todo:
        return
    if scheduler:
        yield from _execute_dask(spec, todo, scheduler, lost_after_s=cluster_timeout_s)
        return
    n = local_workers(workers)
    if n <= 1 or len(todo) == 1:
        for hinges, i, mask in todo:
            yield solve_row(spec, hinges, i, mask)
        return
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    # fork: the workers are this process's own children, so they can watch it (a forkserver
    # or spawn start would make them children of a helper process)
    pool = ProcessPoolExecutor(max_workers=n, mp_context=multiprocessing.get_context("fork"),
                               initializer=_worker_setup, initargs=(os.getpid(),))
    try:
        # each finished row is merged and dropped: nothing here holds on to finished rows
        futures = {pool.submit(solve_row, spec, h, i, m) for h, i, m in todo}
        for f in as_completed(futures):
            futures.discard(f)
            yield f.result()
    finally:
        _stop_pool(pool)


def _stop_pool(pool) -> None:
    """Shut a process pool down now: cancel what has not started and end the workers that
    still run (a finished sweep's pool is idle; an interrupted one must not wait for rows)."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for p in processes:
        if p.is_alive():
            p.terminate()
    for p in processes:
        p.join(timeout=5)


def _worker_setup(parent_pid: int) -> None:
    """In each worker: leave Ctrl-C and SIGTERM to the sweep's process (which stops the
    workers), die with it whatever ends it, and keep BLAS to one thread."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    _die_with_parent(parent_pid)
    from threadpoolctl import threadpool_limits

    threadpool_limits(1)  # the worker processes share the cores already


def _die_with_parent(parent_pid: int) -> None:
    """Make this process end when ``parent_pid`` does: the kernel's parent-death signal
    (Linux prctl PR_SET_PDEATHSIG) where there is one, and a watcher thread that polls the
    parent id (every 0.5 s) everywhere."""
    with contextlib.suppress(OSError, AttributeError):
        import ctypes

        PR_SET_PDEATHSIG = 1
        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGKILL)
    if os.getppid() != parent_pid:  # the parent died before the line above
        os._exit(1)

    def watch():
        while os.getppid() == parent_pid:
            time.sleep(0.5)
        os._exit(1)

    threading.Thread(target=watch, name="dacm-parent-watch", daemon=True).start()


def _execute_dask(spec, todo, address: str, timeout_s: float = 5.0,
                  lost_after_s: float = CLUSTER_TIMEOUT_S):
    """Yield rows solved on a Dask cluster. Raises :class:`ClusterLostError` when the
    cluster has had no worker, or the client no scheduler, for ``lost_after_s`` seconds."""
    from distributed import as_completed

    client = connect_client(address, timeout_s)
    try:
        # only as_completed holds the futures: a row's result is released on the cluster
        # once it is merged, so the workers' memory does not grow with the grid
        pending = as_completed([client.submit(solve_row, spec, h, i, m, pure=False) for h, i, m in todo],
                               loop=client.loop)
        healthy = time.monotonic()
        while not pending.is_empty():
            batch = pending.next_batch(block=False)
            for f in batch:
                yield _dask_result(f, address, lost_after_s)
            fault = None if batch else _cluster_fault(client)
            if fault is None:
                healthy = time.monotonic()
            elif time.monotonic() - healthy > lost_after_s:
                raise ClusterLostError(f"--scheduler = {address!r}: {fault} for {lost_after_s:g} s")
            else:
                time.sleep(0.2)
    except (OSError, TimeoutError) as exc:  # distributed's CommClosedError is an OSError
        raise ClusterLostError(f"--scheduler = {address!r}: lost the scheduler "
                               f"({type(exc).__name__})") from None
    finally:
        _close_client(client)


#: Seconds the scheduler has to answer the probe of :func:`probe_scheduler`.
PROBE_TIMEOUT_S = 4.0
#: The largest first message a Dask scheduler sends (its handshake is about 100 bytes).
_HANDSHAKE_MAX_BYTES = 1 << 20


def connect_client(address: str, timeout_s: float = 5.0):
    """A Dask ``Client`` of the scheduler at ``address``, or :class:`SweepError` naming the
    address within ``PROBE_TIMEOUT_S + timeout_s`` seconds: a TCP address is probed first
    (:func:`probe_scheduler`), since distributed itself waits forever on a port that accepts
    and never replies and reads a non-Dask answer as a frame length of exabytes. The client
    does not become dask's default scheduler: the sweep submits its rows to it by name, and
    as the default it made xarray take a cluster lock for the in-memory NetCDF of a
    checkpoint, which the scheduler refuses."""
    try:
        from distributed import Client
    except ImportError:
        raise SweepError("--scheduler needs the 'distributed' extra: pip install 'dacm[distributed]'") from None
    probe_scheduler(address)
    try:
        return Client(address, timeout=timeout_s, set_as_default=False)
    except (OSError, TimeoutError) as exc:
        raise SweepError(f"--scheduler = {address!r}: cannot reach the Dask scheduler within "
                         f"{timeout_s:g} s ({type(exc).__name__})") from None
    except (ValueError, TypeError, MemoryError) as exc:
        raise SweepError(f"--scheduler = {address!r}: not a Dask scheduler "
                         f"({' '.join(str(exc).split())[:120]})") from None


def probe_scheduler(address: str, timeout_s: float = PROBE_TIMEOUT_S) -> None:
    """Check that a ``tcp://`` (or ``host:port``) address answers as a Dask scheduler does:
    on connecting it sends its handshake, a message of a few hundred bytes framed as
    distributed's TCP comm frames it (an 8-byte little-endian length, then msgpack naming
    its ``pickle-protocol``). Raise :class:`SweepError` naming the address when it refuses,
    stays silent for ``timeout_s`` seconds, or answers anything else. Other protocols are
    left to distributed."""
    import socket
    import struct

    from distributed.comm.addressing import parse_address, parse_host_port

    try:
        scheme, location = parse_address(address if "://" in address else f"tcp://{address}")
        if scheme != "tcp":
            return
        host, port = parse_host_port(location)
    except (ValueError, TypeError) as exc:
        raise SweepError(f"--scheduler = {address!r}: not a Dask scheduler address "
                         f"({' '.join(str(exc).split())[:120]})") from None

    def fail(why: str):
        return SweepError(f"--scheduler = {address!r}: {why}")

    deadline = time.monotonic() + timeout_s

    def read(sock, n: int) -> bytes:
        data = b""
        while len(data) < n:
            sock.settimeout(max(0.01, deadline - time.monotonic()))
            chunk = sock.recv(n - len(data))
            if not chunk:
                raise fail("not a Dask scheduler (it closed the connection without its handshake)")
            data += chunk
        return data

    try:
        with socket.create_connection((host, port), timeout=timeout_s) as sock:
            (size,) = struct.unpack("<Q", read(sock, 8))
            if not 0 < size <= _HANDSHAKE_MAX_BYTES:
                raise fail("not a Dask scheduler (its first message is not a Dask handshake)")
            if b"pickle-protocol" not in read(sock, size):
                raise fail("not a Dask scheduler (its first message is not a Dask handshake)")
    except TimeoutError:
        raise fail(f"no Dask handshake within {timeout_s:g} s (not a Dask scheduler, or "
                   "it does not answer)") from None
    except OSError as exc:
        raise fail(f"cannot reach the Dask scheduler ({exc.strerror or type(exc).__name__})") from None


def _dask_result(future, address: str, lost_after_s: float) -> dict:
    """A row from a finished future; a row the cluster lost (its workers kept dying, or its
    result never arrives within ``lost_after_s``) is a lost cluster, any other error is the
    row's own."""
    try:
        return future.result(timeout=lost_after_s)
    except TimeoutError:
        raise ClusterLostError(f"--scheduler = {address!r}: a finished row did not arrive within "
                               f"{lost_after_s:g} s") from None
    except Exception as exc:
        if type(exc).__module__.split(".")[0] == "distributed" or isinstance(exc, OSError):
            what = ("lost the scheduler" if "connection-lost" in str(exc) or isinstance(exc, OSError)
                    else "the workers running a row kept dying")
            raise ClusterLostError(f"--scheduler = {address!r}: {what} ({type(exc).__name__})") from None
        raise


def _cluster_fault(client) -> str | None:
    """What is wrong with the cluster now (None if it can run tasks)."""
    if client.status != "running":
        return "lost the scheduler"
    try:
        n = len(client.scheduler_info(n_workers=-1)["workers"])
    except Exception:  # a scheduler going down fails the call in several ways
        return "lost the scheduler"
    return None if n else "no worker left"


def _close_client(client) -> None:
    """Close the client without waiting long on a scheduler that is gone, and without the
    tracebacks distributed logs while it gives up reconnecting (its loggers are quiet
    while the client closes)."""
    import logging

    loggers = [logging.getLogger(n) for n in list(logging.root.manager.loggerDict)
               if n == "distributed" or n.startswith("distributed.")]
    levels = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(logging.CRITICAL + 1)
    try:
        with contextlib.suppress(Exception), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            client.close(timeout=2)
    finally:
        for lg, level in zip(loggers, levels):
            lg.setLevel(level)


@dataclass(frozen=True)
class TaskPool:
    """``size`` parallel workers. ``start(fn, items)`` hands the work out and returns a
    function that waits for the results (a list, in order; asked again, the same list), so
    this process can do other work meanwhile; ``map(fn, items)`` is the two at once.
    In-process (size 1) the work is done when the results are first asked for."""

    start: Callable[[Callable, Iterable], Callable[[], list]]
    size: int

    def map(self, fn: Callable, items: Iterable) -> list:
        return self.start(fn, items)()


@contextlib.contextmanager
def task_pool(workers: int = 0, scheduler: str | None = None):
    """Where a sweep's rows would run, for other work (the optimiser's candidates and Monte
    Carlo draws): yields a :class:`TaskPool` on the local processes (``workers`` as for
    :func:`run_sweep`; 1 = in this process) or on the Dask scheduler at ``scheduler``. The
    pool is stopped when the block ends, however it ends."""
    check_run_options(workers, scheduler)
    if scheduler:
        client = connect_client(scheduler)
        try:
            size = max(1, len(client.scheduler_info(n_workers=-1)["workers"]))
            def start(fn, items):
                futures = client.map(fn, list(items), pure=False)
                return functools.cache(lambda: client.gather(futures))

            yield TaskPool(start, size)
        finally:
            _close_client(client)
        return
    n = local_workers(workers)
    if n <= 1:
        yield TaskPool(lambda fn, items: functools.cache(lambda: [fn(x) for x in items]), 1)
        return
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    pool = ProcessPoolExecutor(max_workers=n, mp_context=multiprocessing.get_context("fork"),
                               initializer=_worker_setup, initargs=(os.getpid(),))
    try:
        def start(fn, items):
            results = pool.map(fn, items)  # every item is submitted now
            return functools.cache(lambda: list(results))

        yield TaskPool(start, n)
    finally:
        _stop_pool(pool)
