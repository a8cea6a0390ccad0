"""The sweep dataset: its schema (variables, units), merging solved rows, NetCDF and CSV.

One labelled xarray dataset holds every qualifier of the proposed body per (hinge set, phi1,
phi2) cell and of the basis body per (hinge set, phi1), their ratios, the feasibility mask
and the reason for every infeasible cell, with the run's settings as attributes.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
from pathlib import Path

import numpy as np
import xarray as xr

from geometry.params import design_to_dict
from sensor.design_space.equal_range import fill_equal_range
from sensor.design_space.spec import SweepSpec
from sensor.errors import SweepError
from sensor.mechanics.qualifiers import Qualifiers

#: Qualifiers stored for both bodies (the fields of :class:`Qualifiers`): (units, long name).
QUALIFIERS = {
    "amplification": ("1", "amplification A: output travel / input travel"),
    "k_out_N_per_mm": ("N/mm", "output stiffness k_out: input force / output travel"),
    "sensitivity_mm_per_N": ("mm/N", "sensitivity: output travel / input force (1 / k_out)"),
    "strain_energy_mJ": ("mJ", "strain energy SE at the target output travel"),
    "hysteresis": ("1", "predicted hysteresis H, fraction of full scale (strain-energy law, eq 87)"),
    "quality_mm_per_N": ("mm/N", "quality: sensitivity / H (thesis Table 6 SNR)"),
    "range_N": ("N", "range: input force at the target output travel (full scale)"),
}
#: Every variable stored per body: the qualifiers, the datasheet resolution (sensor model
#: defaults) and the stress utilisation at full scale.
BODY = {
    **QUALIFIERS,
    "resolution_N": ("N", "RMS force resolution, worst over the range (datasheet, sensor model defaults)"),
    "stress_utilisation": ("1", "largest hinge peak stress at full scale / the material's allowable stress"),
}
#: Variables of the basis family (the basis body with hinges 1-8 of every thickness).
FAMILY = tuple(BODY)
#: Ratios proposed / basis at the same phi1 (Figure 49): name -> qualifier. H is SE times a
#: constant (the strain-energy law), so the hysteresis ratio is the strain-energy ratio and
#: is not stored twice.
RATIOS = {
    "ratio_amplification": "amplification",
    "ratio_k_out": "k_out_N_per_mm",
    "ratio_strain_energy": "strain_energy_mJ",
    "ratio_quality": "quality_mm_per_N",
}
#: Per-cell comparison with the best basis body of the cell's own range (DESIGN section 13,
#: :mod:`sensor.design_space.equal_range`): name -> (units, long name).
EQUAL_RANGE = {
    "equal_range_basis_hysteresis": ("1", "H of the basis body of the same range with the lowest H "
                                     "(any phi1, within the allowable stress)"),
    "equal_range_basis_resolution_N": ("N", "RMS resolution of that basis body"),
    "equal_range_basis_phi1_deg": ("degree", "phi1 of that basis body"),
    "equal_range_basis_hinge_mm": ("mm", "hinge 1-8 thickness of that basis body"),
    "equal_range_ratio_hysteresis": ("1", "H / H of the best basis body of the same range"),
    "equal_range_ratio_resolution": ("1", "resolution / resolution of the best basis body of the same range"),
}
#: Monte-Carlo statistics kept for these qualifiers.
MC_QUALIFIERS = ("amplification", "sensitivity_mm_per_N", "strain_energy_mJ", "hysteresis", "quality_mm_per_N")
MC_STATISTICS = {"mean": "mean over the cuttable draws that solve",
                 "std": "standard deviation over the cuttable draws that solve",
                 "tail": "worse tail over the cuttable draws that solve"}

assert tuple(QUALIFIERS) == Qualifiers.names()

#: The flag variables and their meanings (CF flag_values / flag_meanings).
FLAGS = {"feasible": ("infeasible feasible", "cell passes every feasibility rule and solved"),
         "computed": ("pending computed", "cell has been computed")}
CELL = ("hinges", "phi1_deg", "phi2_deg")


def mc_statistic(qualifier: str, stat: str) -> str:
    """The dataset name of a Monte-Carlo statistic; the worse tail is the 90th percentile of
    hysteresis and the 10th of the others."""
    if stat == "tail":
        stat = "p90" if qualifier == "hysteresis" else "p10"
    return f"mc_{qualifier}_{stat}"


def empty_dataset(spec: SweepSpec, version: str) -> xr.Dataset:
    """A dataset with every variable present and nothing computed (CF-1.10 attributes)."""
    H, P1, P2 = list(spec.hinge_sets), spec.phi1.values, spec.phi2.values
    T = spec.family_thickness_mm()
    shape3, shape2 = (len(H), len(P1), len(P2)), (len(H), len(P1))
    coords = {"hinges": ("hinges", H, {"long_name": "hinge set (hinges 1-8 and 9-12 thickness, 0.1 mm)"}),
              "phi1_deg": ("phi1_deg", P1, {"units": "degree", "long_name": "phi1: side-link lean from the vertical"}),
              "phi2_deg": ("phi2_deg", P2, {"units": "degree", "long_name": "phi2: middle-link rise above the horizontal"}),
              "family_hinge_mm": ("family_hinge_mm", T, {"units": "mm", "long_name": "hinge 1-8 thickness of the basis family"})}
    dv = {}
    for k, (unit, name) in BODY.items():
        dv[k] = (CELL, np.full(shape3, np.nan), {"units": unit, "long_name": f"proposed body: {name}"})
        dv[f"basis_{k}"] = (("hinges", "phi1_deg"), np.full(shape2, np.nan),
                            {"units": unit, "long_name": f"basis body of the hinge set: {name}"})
        dv[f"family_{k}"] = (("phi1_deg", "family_hinge_mm"), np.full((len(P1), len(T)), np.nan),
                             {"units": unit, "long_name": f"basis family body: {name}"})
    for k, q in RATIOS.items():
        dv[k] = (CELL, np.full(shape3, np.nan), {"units": "1", "long_name": f"{q}: proposed / basis at the same phi1"})
    for k, (unit, name) in EQUAL_RANGE.items():
        dv[k] = (CELL, np.full(shape3, np.nan), {"units": unit, "long_name": name})
    for k, (meanings, name) in FLAGS.items():
        dv[k] = (CELL, np.zeros(shape3, bool), {"units": "1", "long_name": name, "flag_values": np.array([0, 1], "i1"),
                                                "flag_meanings": meanings})
    # text variables carry no units (CF 1.10 section 3.1: units belong to numbers)
    dv["reason"] = (CELL, np.full(shape3, "", dtype=object),
                    {"long_name": "why the cell is infeasible (empty if feasible)"})
    dv["basis_reason"] = (("hinges", "phi1_deg"), np.full(shape2, "", dtype=object),
                          {"long_name": "why the basis body failed (empty if it solved)"})
    if spec.monte_carlo:
        for k in MC_QUALIFIERS:
            for s, what in MC_STATISTICS.items():
                name = mc_statistic(k, s)
                dv[name] = (CELL, np.full(shape3, np.nan),
                            {"units": BODY[k][0], "long_name": f"{BODY[k][1]}: {what} ({name.rsplit('_', 1)[1]})"})
        dv["mc_yield"] = (CELL, np.full(shape3, np.nan),
                          {"units": "1", "long_name": "fraction of draws that can be cut "
                           "(every hinge >= min_feature_mm) and reach the target travel"})
    ds = xr.Dataset(dv, coords=coords)
    ds.attrs.update({
        "Conventions": "CF-1.10",
        "title": "dacm phi1/phi2 sweep of the proposed DACM against the basis body",
        "institution": "dacm",
        "source": f"dacm {version}: nonlinear Castigliano chain-algorithm beam model",
        "software": f"dacm {version}",
        "spec": spec.to_json(),
        "target_output_mm": spec.target_output_mm,
        "hysteresis_law": f"H = {spec.law.h_per_mJ:.6f} * SE (calibrated on the {spec.law.calibrated_on} specimen, Table 6)",
        "design": json.dumps(design_to_dict(spec.design("05-03", 20.0, None)), default=str),
    })
    return ds


def merge_row(ds: xr.Dataset, row: dict) -> None:
    """Write one solved row into the dataset (in place); once every cell is computed, the
    equal-range comparison of every cell (:func:`fill_equal_range`)."""
    h = list(ds["hinges"].values).index(row["hinges"])
    i = row["i"]
    todo = row["computed"]
    for k in BODY:
        ds[f"basis_{k}"].values[h, i] = row["basis"][k]
        ds[k].values[h, i, todo] = row["proposed"][k][todo]
    for k, v in row.get("family", {}).items():
        ds[f"family_{k}"].values[i] = v
    ds["basis_reason"].values[h, i] = row["basis_reason"]
    ds["reason"].values[h, i, todo] = row["reason"][todo]
    for k, q in RATIOS.items():
        ds[k].values[h, i, todo] = ds[q].values[h, i, todo] / ds[f"basis_{q}"].values[h, i]
    for k, v in row.get("mc", {}).items():
        ds[k].values[h, i, todo] = v[todo]
    ds["computed"].values[h, i, todo] = True
    ok = np.isfinite(ds["amplification"].values[h, i]) & (ds["reason"].values[h, i] == "")
    ds["feasible"].values[h, i] = ok & ds["computed"].values[h, i]
    if row["basis_reason"]:
        # without a reference, ratios are undefined: say so in every cell of the row
        for j in np.flatnonzero(todo):
            if not ds["reason"].values[h, i, j]:
                ds["reason"].values[h, i, j] = row["basis_reason"]
        ds["feasible"].values[h, i] = False
    if ds["computed"].values.all():
        fill_equal_range(ds)


#: In the file the hinge-set names are a label variable (CF 1.10 section 6.1.1) along the
#: ``hinges`` dimension, named in each variable's ``coordinates``: a coordinate variable
#: must be numeric and monotonic.
HINGE_LABEL = "hinge_set"


def save_dataset(ds: xr.Dataset, path: Path) -> None:
    """Write the dataset as NetCDF, CF-1.10: coordinates without ``_FillValue``, the hinge
    sets as a label variable, flags as bytes, the command that wrote it appended to
    ``history``, and the SHA-256 of every row in the attribute ``row_sha256``
    (:func:`row_checksums`), after :func:`check_dataset`. The file is made in memory and
    written with Python's own I/O, atomically (an interrupted or failed write leaves the old
    file; HDF5 writing to a full disk itself would crash the process)."""
    from geometry.atomic import write_bytes

    check_dataset(ds, str(path), stored_checksums=False)  # they are replaced now
    out = ds.copy()
    out.attrs["row_sha256"] = json.dumps(row_checksums(ds))
    for k in ("reason", "basis_reason"):
        out[k] = out[k].astype(str)
    for k in FLAGS:
        out[k] = out[k].astype("i1")
    out = out.rename_vars({"hinges": HINGE_LABEL}).drop_indexes(HINGE_LABEL)
    out[HINGE_LABEL] = out[HINGE_LABEL].astype(str)
    out.attrs["history"] = _history(ds.attrs.get("history", ""))
    encoding = {k: {"_FillValue": None} for k in out.coords}
    with _local_dask():
        write_bytes(path, out.to_netcdf(engine="h5netcdf", encoding=encoding))


def _local_dask():
    """A context in which xarray writes with dask's local scheduler: beside a user's default
    distributed Client it would take a cluster lock named by the in-memory target, which the
    scheduler refuses."""
    try:
        import dask
    except ImportError:
        return contextlib.nullcontext()
    return dask.config.set(scheduler="synchronous")


def _history(history: str) -> str:
    """``history`` with a line ``TIME: COMMAND`` for the running command, unless its last
    line is that command already (a checkpoint saved again)."""
    from datetime import datetime, timezone

    from geometry.provenance import command, version

    line = f"{command()} (dacm {version()})"
    lines = history.splitlines()
    if lines and lines[-1].split(": ", 1)[-1] == line:
        return history
    return "\n".join([*lines, f"{datetime.now(timezone.utc):%Y-%m-%dT%H:%M:%SZ}: {line}"])


def row_checksums(ds: xr.Dataset) -> dict[str, str]:
    """SHA-256 of each (hinge set, phi1) row: every variable's values in that row (the
    proposed cells, the basis body, the basis family at that phi1), keyed ``"HINGES/I"``."""
    arrays = [(k.encode(), ds[k].values, ds[k].dims) for k in sorted(map(str, ds.data_vars))]
    out = {}
    for h, hs in enumerate(ds["hinges"].values):
        for i in range(ds.sizes["phi1_deg"]):
            digest = hashlib.sha256()
            for name, values, dims in arrays:
                index = tuple(h if d == "hinges" else i if d == "phi1_deg" else slice(None) for d in dims)
                digest.update(name + _canonical(values[index]))
            out[f"{hs}/{i}"] = digest.hexdigest()
    return out


def _canonical(values: np.ndarray) -> bytes:
    """Bytes of an array as stored and read back: floats with one NaN, flags as bytes,
    text NUL-separated."""
    a = np.asarray(values)
    if a.dtype.kind == "f":
        return np.where(np.isnan(a), np.nan, a).astype("<f8").tobytes()
    if a.dtype.kind in "biu":
        return a.astype("<i8").tobytes()
    return "\0".join(str(x) for x in a.ravel()).encode()


#: The most a cell's amplification may exceed the rigid-link value A_kin (DESIGN section 3):
#: the beam model's largest excess on an 8 x 8 grid of both hinge sets is 17 % (finite hinge
#: length and large rotation at 1 mm travel); a value beyond is not a result of the model.
AMPLIFICATION_OVER_KINEMATIC = 1.5


def check_dataset(ds: xr.Dataset, where: str, stored_checksums: bool = True) -> None:
    """Raise :class:`SweepError` (naming ``where`` and the first bad cell) when the dataset
    contradicts itself: a row that does not match its stored checksum (unless
    ``stored_checksums`` is False: the data was changed since it was read), a cell flagged
    feasible that is not computed or whose values are not finite, a ratio that is not the
    quotient it names, or an amplification outside (0, 1.5 A_kin]."""
    from geometry.layout import kinematic_amplification

    def bad(what, h, i, j=None):
        cell = f"hinges {ds['hinges'].values[h]}, phi1 {ds['phi1_deg'].values[i]:g}" + (
            "" if j is None else f", phi2 {ds['phi2_deg'].values[j]:g}")
        return SweepError(f"{where}: {what} at {cell}: the dataset is corrupt; remove it "
                          "(or use another --out) and run the sweep again")

    stored = ds.attrs.get("row_sha256") if stored_checksums else None
    if stored is not None:
        try:
            stored = json.loads(stored)
        except (TypeError, ValueError):
            raise SweepError(f"{where}: its row checksums (attribute row_sha256) are not "
                             "readable: the dataset is corrupt") from None
        for key, digest in row_checksums(ds).items():
            if stored.get(key) != digest:
                hs, i = key.rsplit("/", 1)
                h = list(map(str, ds["hinges"].values)).index(hs)
                raise bad("the values do not match the checksum written with them", h, int(i))
    feasible, computed = ds["feasible"].values.astype(bool), ds["computed"].values.astype(bool)
    if (feasible & ~computed).any():
        h, i, j = np.argwhere(feasible & ~computed)[0]
        raise bad("a cell flagged feasible but not computed", h, i, j)
    for k in [*BODY, *RATIOS]:
        v = ds[k].values
        wrong = feasible & ~np.isfinite(v)
        if wrong.any():
            h, i, j = np.argwhere(wrong)[0]
            raise bad(f"{k} = {v[h, i, j]} in a cell flagged computed and feasible", h, i, j)
    for k, q in RATIOS.items():
        expected = ds[q].values / ds[f"basis_{q}"].values[:, :, None]
        wrong = feasible & ~np.isclose(ds[k].values, expected, rtol=1e-9, atol=0.0)
        if wrong.any():
            h, i, j = np.argwhere(wrong)[0]
            raise bad(f"{k} = {ds[k].values[h, i, j]:g} is not {q} / basis_{q} = "
                      f"{expected[h, i, j]:g}", h, i, j)
    a = ds["amplification"].values
    for h, i, j in np.argwhere(feasible):
        limit = AMPLIFICATION_OVER_KINEMATIC * kinematic_amplification(
            float(ds["phi1_deg"].values[i]), float(ds["phi2_deg"].values[j]))
        if not 0.0 < a[h, i, j] <= limit:
            raise bad(f"amplification = {a[h, i, j]:g} outside (0, {limit:.3g}] "
                      "(1.5 x the rigid-link value)", h, i, j)
    basis = ds["basis_amplification"].values
    ok = np.isfinite(basis)
    if (ok & ~((basis > 0) & (basis <= AMPLIFICATION_OVER_KINEMATIC))).any():
        h, i = np.argwhere(ok & ~((basis > 0) & (basis <= AMPLIFICATION_OVER_KINEMATIC)))[0]
        raise bad(f"basis_amplification = {basis[h, i]:g} outside (0, 1.5]", h, i)


def load_dataset(path: Path) -> xr.Dataset:
    """Read a sweep dataset written by :func:`save_dataset` (fully into memory)."""
    with xr.open_dataset(path, engine="h5netcdf") as f:
        ds = f.load()
    if HINGE_LABEL in ds.variables:  # as save_dataset writes it (CF: the sets as a label variable)
        labels = ds[HINGE_LABEL]
        ds = ds.drop_vars(HINGE_LABEL).assign_coords(hinges=("hinges", labels.values.astype(str), labels.attrs))
    else:  # a dataset written by xarray as it is held in memory
        ds = ds.assign_coords(hinges=ds["hinges"].values.astype(str))
    for k in ("reason", "basis_reason"):
        ds[k] = ds[k].astype(object)
    for k in FLAGS:
        ds[k] = ds[k].astype(bool)
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
    """The tidy table: one row per (hinges, phi1, phi2) with every cell and basis variable
    (atomically); each column is headed ``name [units]``."""
    proposed = [v for v in ds.data_vars if ds[v].dims == CELL]
    df = ds[proposed].to_dataframe().reset_index()
    basis = ds[[v for v in ds.data_vars if ds[v].dims == ("hinges", "phi1_deg")]].to_dataframe().reset_index()
    df = df.merge(basis, on=["hinges", "phi1_deg"])
    for k in FLAGS:  # 0/1 as in the NetCDF file
        df[k] = df[k].astype(int)
    return write_table(df, path, {k: ds[k].attrs.get("units") for k in df.columns})


def write_table(df, path: Path, units: dict[str, str | None]) -> Path:
    """A table as CSV (atomically) with each column headed ``name [units]`` (text columns:
    ``name``), under comment lines (``#``) naming the dacm version and the command."""
    from geometry.atomic import atomic_path
    from geometry.provenance import comment_header

    df = df.rename(columns={k: f"{k} [{units[k]}]" for k in df.columns if units.get(k)})
    with atomic_path(path) as tmp:
        with open(tmp, "w", newline="") as fh:
            fh.write(comment_header())
            df.to_csv(fh, index=False, float_format="%.6g")
    return path
