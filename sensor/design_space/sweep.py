"""Design-space sweeps over phi1 x phi2 (thesis section 6.2.3, Figure 49).

For each hinge set, every (phi1, phi2) cell of the proposed body is checked for feasibility
and solved to the target output travel; the basis body with the same phi1 is the reference.
The qualifiers (amplification, output stiffness k_out, strain energy, predicted hysteresis
and quality) and their ratios proposed / basis go into one labelled xarray dataset.

Work is split into rows (one hinge set, one phi1): a row's feasible cells share one
topology and are solved together as a batch. Rows run serially, on local processes, or on
a Dask distributed cluster; a row's result does not depend on where it ran.
"""

from __future__ import annotations

import dataclasses
import json
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import xarray as xr

from geometry.checks import check_design
from geometry.params import (
    HINGE_SETS,
    Design,
    design_from_dict,
    design_to_dict,
    hinge_set_thicknesses,
)
from geometry.topology import build_beam_model
from sensor.errors import SweepError
from sensor.mechanics.hysteresis import DEFAULT_LAW
from sensor.mechanics.solver import SolverOptions, solve_batch

#: Qualifiers stored for both bodies, with units.
QUALIFIERS = {
    "amplification": "1",
    "k_out_N_per_mm": "N/mm",
    "sensitivity_mm_per_N": "mm/N",
    "strain_energy_mJ": "mJ",
    "hysteresis": "1 (fraction of full scale)",
    "quality_mm_per_N": "mm/N",
    "input_force_N": "N",
}
#: Ratios proposed / basis (Figure 49 and beyond): name -> qualifier.
RATIOS = {
    "ratio_amplification": "amplification",
    "ratio_k_out": "k_out_N_per_mm",
    "ratio_strain_energy": "strain_energy_mJ",
    "ratio_hysteresis": "hysteresis",
    "ratio_quality": "quality_mm_per_N",
}
#: Monte-Carlo statistics kept for these qualifiers.
MC_QUALIFIERS = ("amplification", "sensitivity_mm_per_N", "strain_energy_mJ", "hysteresis", "quality_mm_per_N")


@dataclass(frozen=True)
class Grid:
    """An inclusive grid START:STOP:N of angles in degrees."""

    start: float
    stop: float
    n: int

    @classmethod
    def parse(cls, text: str, name: str) -> "Grid":
        parts = str(text).split(":")
        try:
            start, stop, n = float(parts[0]), float(parts[1]), int(parts[2])
        except (IndexError, ValueError):
            raise SweepError(f"{name} = {text!r}: must be START:STOP:N (degrees, degrees, count)") from None
        if len(parts) != 3:
            raise SweepError(f"{name} = {text!r}: must be START:STOP:N (degrees, degrees, count)")
        return cls(start, stop, n).validated(name)

    def validated(self, name: str) -> "Grid":
        if self.n < 1:
            raise SweepError(f"{name} = {self}: the grid is empty (N = {self.n}; need N >= 1)")
        if not (0 < self.start < 90 and 0 < self.stop < 90):
            raise SweepError(f"{name} = {self}: angles must lie strictly between 0 and 90 degrees")
        if self.n > 1 and self.stop <= self.start:
            raise SweepError(f"{name} = {self}: STOP must exceed START")
        return self

    @property
    def values(self) -> np.ndarray:
        return np.linspace(self.start, self.stop, self.n)

    def __str__(self):
        return f"{self.start:g}:{self.stop:g}:{self.n}"


@dataclass(frozen=True)
class SweepSpec:
    """Everything a sweep's numbers depend on (stored with the dataset)."""

    hinge_sets: tuple[str, ...] = ("05-03", "03-03")
    phi1: Grid = Grid(6.0, 31.0, 41)
    phi2: Grid = Grid(4.0, 56.0, 41)
    target_output_mm: float = 1.0
    base: dict = field(default_factory=dict)   # Design fields other than angles and hinges
    monte_carlo: int = 0
    hinge_sd_mm: float = 0.0
    seed: int = 0

    def __post_init__(self):
        for h in self.hinge_sets:
            if h not in HINGE_SETS:
                raise SweepError(f"hinge set {h!r}: must be one of {', '.join(HINGE_SETS)}")
        if not self.hinge_sets:
            raise SweepError("no hinge set to sweep")
        self.phi1.validated("--phi1")
        self.phi2.validated("--phi2")
        if not (np.isfinite(self.target_output_mm) and self.target_output_mm > 0):
            raise SweepError(f"--target-output = {self.target_output_mm!r}: must be a positive number of mm")
        if self.monte_carlo < 0:
            raise SweepError(f"--monte-carlo = {self.monte_carlo}: must be >= 0")
        if self.monte_carlo and not self.hinge_sd_mm > 0:
            raise SweepError(f"--hinge-sd = {self.hinge_sd_mm!r}: must be > 0 mm with --monte-carlo")
        self.design("05-03", 20.0, None)  # the base fields must make a valid design

    def design(self, hinges: str, phi1: float, phi2: float | None) -> Design:
        base = {k: v for k, v in self.base.items() if k not in ("phi1_deg", "phi2_deg", "hinge_set", "hinge_thickness_mm", "name")}
        return design_from_dict({**base, "phi1_deg": float(phi1), "phi2_deg": None if phi2 is None else float(phi2),
                                 "hinge_set": hinges, "hinge_thickness_mm": hinge_set_thicknesses(hinges),
                                 "name": f"{hinges}-{phi1:g}-{phi2}"}, source="sweep design")

    def to_json(self) -> str:
        d = dataclasses.asdict(self)
        return json.dumps(d, sort_keys=True, default=str)


# --- one row of cells ------------------------------------------------------------------------

def _cell_seed(seed: int, hinges: str, i: int, j: int) -> np.random.Generator:
    """A generator that depends only on the cell, not on how rows were scheduled."""
    return np.random.default_rng([seed, list(HINGE_SETS).index(hinges), i, j])


def _qualifiers(results) -> dict[str, np.ndarray]:
    out = {k: np.full(len(results), np.nan) for k in QUALIFIERS}
    for n, r in enumerate(results):
        if r is None:
            continue
        h = float(DEFAULT_LAW.predict(r.strain_energy_mJ))
        out["amplification"][n] = r.amplification
        out["k_out_N_per_mm"][n] = r.k_out_N_per_mm
        out["sensitivity_mm_per_N"][n] = r.sensitivity_mm_per_N
        out["strain_energy_mJ"][n] = r.strain_energy_mJ
        out["hysteresis"][n] = h
        out["quality_mm_per_N"][n] = r.sensitivity_mm_per_N / h
        out["input_force_N"][n] = r.input_force_N
    return out


def solve_row(spec: SweepSpec, hinges: str, i: int, todo: np.ndarray | None = None) -> dict:
    """Solve row i (one phi1) of a hinge set: the basis body and the cells ``todo`` (bool
    mask over phi2; default all). Pure: depends only on its arguments."""
    phi1 = float(spec.phi1.values[i])
    phi2s = spec.phi2.values
    todo = np.ones(len(phi2s), bool) if todo is None else np.asarray(todo, bool)
    opts = SolverOptions()
    row = {"hinges": hinges, "i": i, "computed": todo.copy(),
           "reason": np.array([""] * len(phi2s), dtype=object)}
    # the reference: the basis body with this phi1
    basis = spec.design(hinges, phi1, None)
    fail = check_design(basis).first_failure
    if fail is None:
        res, err = solve_batch([build_beam_model(basis)], target_output_mm=spec.target_output_mm, options=opts)
        row["basis"] = {k: float(v[0]) for k, v in _qualifiers(res).items()}
        basis_reason = "" if err[0] is None else f"basis: {err[0]}"
    else:
        row["basis"] = {k: np.nan for k in QUALIFIERS}
        basis_reason = f"basis infeasible: {fail.rule}: {fail.message}"
    row["basis_reason"] = basis_reason
    # the proposed body at each phi2
    designs, cells = [], []
    for j in np.flatnonzero(todo):
        d = spec.design(hinges, phi1, phi2s[j])
        fail = check_design(d).first_failure
        if fail is not None:
            row["reason"][j] = f"{fail.rule}: {fail.message}"
        else:
            designs.append(d)
            cells.append(j)
    q = {k: np.full(len(phi2s), np.nan) for k in QUALIFIERS}
    if designs:
        res, errs = solve_batch([build_beam_model(d) for d in designs],
                                target_output_mm=spec.target_output_mm, options=opts)
        vals = _qualifiers(res)
        for n, j in enumerate(cells):
            if errs[n] is not None:
                row["reason"][j] = f"solver: {errs[n]}"
            for k in QUALIFIERS:
                q[k][j] = vals[k][n]
    row["proposed"] = q
    if spec.monte_carlo:
        row["mc"] = _monte_carlo_row(spec, hinges, i, designs, cells, len(phi2s), opts)
    return row


def _monte_carlo_row(spec, hinges, i, designs, cells, n_phi2, opts) -> dict:
    """Each feasible cell repeated with hinge thicknesses drawn around the nominal.

    A draw with a hinge thinner than the process can hold (``min_feature_mm``) is a part
    that could not be made, and a draw the solver cannot take to the target travel is one
    that would not work: both count against the cell's yield and stay out of the statistics.
    """
    stats = {f"{k}_{s}": np.full(n_phi2, np.nan) for k in MC_QUALIFIERS for s in ("mean", "std", "p10")}
    stats["yield"] = np.full(n_phi2, np.nan)
    for d, j in zip(designs, cells):
        rng = _cell_seed(spec.seed, hinges, i, j)
        nominal = np.array(d.hinge_thickness_mm)
        draws = nominal + spec.hinge_sd_mm * rng.standard_normal((spec.monte_carlo, len(nominal)))
        used = slice(None, 8) if d.is_basis else slice(None)
        makeable = draws[:, used].min(axis=1) >= d.min_feature_mm
        models = [build_beam_model(d.replace(hinge_thickness_mm=tuple(t))) for t in draws[makeable]]
        res, _ = solve_batch(models, target_output_mm=spec.target_output_mm, options=opts) if models else ([], [])
        stats["yield"][j] = sum(r is not None for r in res) / spec.monte_carlo
        vals = _qualifiers(res)
        for k in MC_QUALIFIERS:
            v = vals[k][np.isfinite(vals[k])]
            if len(v):
                stats[f"{k}_mean"][j] = v.mean()
                stats[f"{k}_std"][j] = v.std(ddof=1) if len(v) > 1 else 0.0
                # robust value: the worse tail (10th percentile of goods, 90th of hysteresis)
                stats[f"{k}_p10"][j] = np.percentile(v, 90 if k == "hysteresis" else 10)
    return stats


# --- the whole sweep ---------------------------------------------------------------------------

def empty_dataset(spec: SweepSpec, version: str) -> xr.Dataset:
    """A dataset with every variable present and nothing computed."""
    H, P1, P2 = list(spec.hinge_sets), spec.phi1.values, spec.phi2.values
    shape3, shape2 = (len(H), len(P1), len(P2)), (len(H), len(P1))
    coords = {"hinges": H, "phi1_deg": P1, "phi2_deg": P2}
    dv = {}
    for k, unit in QUALIFIERS.items():
        dv[k] = (("hinges", "phi1_deg", "phi2_deg"), np.full(shape3, np.nan), {"units": unit, "body": "proposed"})
        dv[f"basis_{k}"] = (("hinges", "phi1_deg"), np.full(shape2, np.nan), {"units": unit, "body": "basis"})
    for k, q in RATIOS.items():
        dv[k] = (("hinges", "phi1_deg", "phi2_deg"), np.full(shape3, np.nan),
                 {"units": "1", "long_name": f"{q}: proposed / basis at the same phi1"})
    dv["computed"] = (("hinges", "phi1_deg", "phi2_deg"), np.zeros(shape3, bool), {})
    dv["feasible"] = (("hinges", "phi1_deg", "phi2_deg"), np.zeros(shape3, bool),
                      {"long_name": "cell passes every feasibility rule and solved"})
    dv["reason"] = (("hinges", "phi1_deg", "phi2_deg"), np.full(shape3, "", dtype=object),
                    {"long_name": "why the cell is infeasible (empty if feasible)"})
    dv["basis_reason"] = (("hinges", "phi1_deg"), np.full(shape2, "", dtype=object), {})
    if spec.monte_carlo:
        for k in MC_QUALIFIERS:
            for s in ("mean", "std", "p10"):
                dv[f"mc_{k}_{s}"] = (("hinges", "phi1_deg", "phi2_deg"), np.full(shape3, np.nan),
                                     {"units": QUALIFIERS[k], "monte_carlo": s})
        dv["mc_yield"] = (("hinges", "phi1_deg", "phi2_deg"), np.full(shape3, np.nan),
                          {"units": "1", "long_name": "fraction of draws that can be cut "
                           "(every hinge >= min_feature_mm) and reach the target travel"})
    ds = xr.Dataset(dv, coords=coords)
    ds["phi1_deg"].attrs["units"] = ds["phi2_deg"].attrs["units"] = "degree"
    ds.attrs.update({
        "title": "dacm phi1/phi2 sweep of the proposed DACM against the basis body",
        "software": f"dacm {version}",
        "spec": spec.to_json(),
        "target_output_mm": spec.target_output_mm,
        "hysteresis_law": f"H = {DEFAULT_LAW.h_per_mJ:.6f} * SE (calibrated on the {DEFAULT_LAW.calibrated_on} specimen, Table 6)",
        "design": json.dumps(design_to_dict(spec.design("05-03", 20.0, None)), default=str),
    })
    return ds


def merge_row(ds: xr.Dataset, row: dict) -> None:
    """Write one solved row into the dataset (in place)."""
    h = list(ds["hinges"].values).index(row["hinges"])
    i = row["i"]
    todo = row["computed"]
    for k in QUALIFIERS:
        ds[f"basis_{k}"].values[h, i] = row["basis"][k]
        ds[k].values[h, i, todo] = row["proposed"][k][todo]
    ds["basis_reason"].values[h, i] = row["basis_reason"]
    ds["reason"].values[h, i, todo] = row["reason"][todo]
    for k, q in RATIOS.items():
        ds[k].values[h, i, todo] = ds[q].values[h, i, todo] / ds[f"basis_{q}"].values[h, i]
    for k, v in row.get("mc", {}).items():
        ds[f"mc_{k}"].values[h, i, todo] = v[todo]
    ds["computed"].values[h, i, todo] = True
    ok = np.isfinite(ds["amplification"].values[h, i]) & (ds["reason"].values[h, i] == "")
    ds["feasible"].values[h, i] = ok & ds["computed"].values[h, i]
    if row["basis_reason"]:
        # without a reference, ratios are undefined: say so in every cell of the row
        for j in np.flatnonzero(todo):
            if not ds["reason"].values[h, i, j]:
                ds["reason"].values[h, i, j] = row["basis_reason"]
        ds["feasible"].values[h, i] = False


def save_dataset(ds: xr.Dataset, path: Path) -> None:
    """Write the dataset as NetCDF (atomically: an interrupted write leaves the old file)."""
    from geometry.atomic import atomic_path

    out = ds.copy()
    for k in ("reason", "basis_reason"):
        out[k] = out[k].astype(str)
    out["computed"] = out["computed"].astype("i1")
    out["feasible"] = out["feasible"].astype("i1")
    with atomic_path(path) as tmp:
        out.to_netcdf(tmp, engine="h5netcdf")


def load_dataset(path: Path) -> xr.Dataset:
    """Read a sweep dataset written by :func:`save_dataset` (fully into memory)."""
    with xr.open_dataset(path, engine="h5netcdf") as f:
        ds = f.load()
    for k in ("reason", "basis_reason"):
        ds[k] = ds[k].astype(object)
    ds["computed"] = ds["computed"].astype(bool)
    ds["feasible"] = ds["feasible"].astype(bool)
    return ds


def rows_to_do(ds: xr.Dataset) -> list[tuple[str, int, np.ndarray]]:
    """(hinge set, phi1 index, phi2 mask) of every row with cells still to compute."""
    out = []
    comp = ds["computed"].values
    for h, hs in enumerate(ds["hinges"].values):
        for i in range(comp.shape[1]):
            if not comp[h, i].all():
                out.append((str(hs), i, ~comp[h, i]))
    return out


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
