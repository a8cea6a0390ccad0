"""The sweep dataset: its schema (variables, units), merging solved rows, NetCDF and CSV.

One labelled xarray dataset holds every qualifier of the proposed body per (hinge set, phi1,
phi2) cell and of the basis body per (hinge set, phi1), their ratios, the feasibility mask
and the reason for every infeasible cell, with the run's settings as attributes.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import xarray as xr

from geometry.params import design_to_dict
from sensor.design_space.spec import SweepSpec
from sensor.mechanics.qualifiers import Qualifiers

#: Qualifiers stored for both bodies (the fields of :class:`Qualifiers`), with units.
QUALIFIERS = {
    "amplification": "1",
    "k_out_N_per_mm": "N/mm",
    "sensitivity_mm_per_N": "mm/N",
    "strain_energy_mJ": "mJ",
    "hysteresis": "1 (fraction of full scale)",
    "quality_mm_per_N": "mm/N",
    "range_N": "N",
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

assert tuple(QUALIFIERS) == Qualifiers.names()


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
        "hysteresis_law": f"H = {spec.law.h_per_mJ:.6f} * SE (calibrated on the {spec.law.calibrated_on} specimen, Table 6)",
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


def write_csv(ds: xr.Dataset, path: Path) -> Path:
    """The tidy table: one row per (hinges, phi1, phi2) with every variable (atomically)."""
    from geometry.atomic import atomic_path

    proposed = [v for v in ds.data_vars if ds[v].dims == ("hinges", "phi1_deg", "phi2_deg")]
    df = ds[proposed].to_dataframe().reset_index()
    basis = ds[[v for v in ds.data_vars if ds[v].dims == ("hinges", "phi1_deg")]].to_dataframe().reset_index()
    df = df.merge(basis, on=["hinges", "phi1_deg"])
    with atomic_path(path) as tmp:
        df.to_csv(tmp, index=False, float_format="%.6g")
    return path
