"""Running a sweep: rows on the local cores or on a Dask distributed cluster, checkpointed
atomically so that an interrupted run finishes with ``resume`` and computes nothing twice.

A row's result does not depend on where it ran, so every scheduler gives the same dataset.
"""

from __future__ import annotations

import time
from pathlib import Path

import xarray as xr

from sensor.design_space.dataset import (
    empty_dataset,
    load_dataset,
    merge_row,
    rows_to_do,
    save_dataset,
)
from sensor.design_space.rows import solve_row
from sensor.design_space.spec import SweepSpec
from sensor.errors import SweepError


def run_sweep(spec: SweepSpec, version: str, dataset_path: Path | None = None, resume: bool = False,
              workers: int = 0, scheduler: str | None = None, progress=None,
              checkpoint_s: float = 5.0) -> tuple[xr.Dataset, int]:
    """Run (or finish) a sweep. Returns the dataset and the number of cells computed now.

    ``workers`` = 0 picks the number of local cores; 1 runs serially in this process.
    ``scheduler`` is a Dask distributed scheduler address. With ``resume`` the cells of an
    existing dataset at ``dataset_path`` (same spec) are reused. The dataset is checkpointed
    (atomically) every ``checkpoint_s`` seconds, so an interrupted run can be resumed.
    """
    ds = None
    if resume and dataset_path is not None and dataset_path.exists():
        ds = load_dataset(dataset_path)
        if ds.attrs.get("spec") != spec.to_json():
            raise SweepError(f"--resume: {dataset_path} was made with other parameters; "
                             "use the same grid and settings, or another --out")
    if ds is None:
        ds = empty_dataset(spec, version)
    todo = rows_to_do(ds)
    n_cells = int(sum(m.sum() for _, _, m in todo))
    if progress is not None:
        progress.start(n_cells)
    last = time.monotonic()
    for row in _execute(spec, todo, workers, scheduler):
        merge_row(ds, row)
        if progress is not None:
            progress.advance(int(row["computed"].sum()))
        if dataset_path is not None and time.monotonic() - last > checkpoint_s:
            save_dataset(ds, dataset_path)
            last = time.monotonic()
    if progress is not None:
        progress.stop()
    return ds, n_cells


def _execute(spec: SweepSpec, todo, workers: int, scheduler: str | None):
    """Yield solved rows, computed serially, on local processes or on a Dask cluster."""
    if not todo:
        return
    if scheduler:
        yield from _execute_dask(spec, todo, scheduler)
        return
    import os
    n = workers or os.cpu_count() or 1
    if n <= 1 or len(todo) == 1:
        for hinges, i, mask in todo:
            yield solve_row(spec, hinges, i, mask)
        return
    from concurrent.futures import ProcessPoolExecutor, as_completed
    with ProcessPoolExecutor(max_workers=n, initializer=_single_thread_blas) as pool:
        futures = [pool.submit(solve_row, spec, h, i, m) for h, i, m in todo]
        try:
            for f in as_completed(futures):
                yield f.result()
        finally:
            for f in futures:
                f.cancel()


def _single_thread_blas():
    """Worker processes share the cores already: keep BLAS to one thread each."""
    from threadpoolctl import threadpool_limits

    threadpool_limits(1)


def _execute_dask(spec, todo, address: str, timeout_s: float = 5.0):
    try:
        from distributed import Client, as_completed
    except ImportError:
        raise SweepError("--scheduler needs the 'distributed' extra: pip install 'dacm[distributed]'") from None
    try:
        client = Client(address, timeout=timeout_s)
    except (OSError, TimeoutError) as exc:
        raise SweepError(f"--scheduler = {address!r}: cannot reach the Dask scheduler within "
                         f"{timeout_s:g} s ({type(exc).__name__})") from None
    with client:
        futures = [client.submit(solve_row, spec, h, i, m, pure=False) for h, i, m in todo]
        for f in as_completed(futures):
            yield f.result()
