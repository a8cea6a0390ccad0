"""Designs compared at equal force range (DESIGN section 13): the tool's answer to a designer.

At the target output travel a body's sensitivity is travel / range, so the thesis' quality
(sensitivity / H) rewards soft bodies of tiny range. A designer picks the range first and
wants the lowest hysteresis there. The basis body's hinge thickness is continuous, so the
sweep's basis family (every phi1 of the grid, hinges 1-8 from ``min_feature_mm`` up) gives a
basis body of any range in its reach: between two family bodies log H, log resolution and
the stress utilisation are interpolated linearly in log range (range grows about as t^3).

Only bodies within the material's allowable stress at full scale count as answers here
(:mod:`sensor.mechanics.stress`); ``feasible`` (geometry and solve) keeps the thesis'
Figure 49 meaning.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
import xarray as xr

#: Ranges the sweep summary answers (N), and the tolerance of "the same range".
SUMMARY_RANGES_N = (1.0, 2.0, 5.0, 10.0, 20.0)
SAME_RANGE = 0.02


def admissible(ds: xr.Dataset, hinges: str) -> np.ndarray:
    """(phi1, phi2) mask of cells that are feasible and within the allowable stress."""
    sub = ds.sel(hinges=hinges)
    return sub["feasible"].values & (sub["stress_utilisation"].values <= 1.0)


def basis_at_range(ds: xr.Dataset, range_N, stress: bool = True) -> dict[str, np.ndarray]:
    """The basis family body of each range in ``range_N`` (N, any shape) with the lowest H
    over the grid's phi1: its ``hysteresis``, ``resolution_N``, ``stress_utilisation``,
    ``phi1_deg`` and ``hinge_mm``; NaN where no family body reaches the range (within the
    allowable stress, unless ``stress`` is False)."""
    r = np.asarray(range_N, dtype=float)
    lr = np.log(np.where(r > 0, r, np.nan)).ravel()
    best = {k: np.full(lr.shape, np.nan) for k in ("hysteresis", "resolution_N", "stress_utilisation",
                                                   "phi1_deg", "hinge_mm")}
    logt = np.log(ds["family_hinge_mm"].values)
    for i, phi1 in enumerate(ds["phi1_deg"].values):
        fr = ds["family_range_N"].values[i]
        ok = np.isfinite(fr) & np.isfinite(ds["family_hysteresis"].values[i])
        if ok.sum() < 2:
            continue
        x = np.log(fr[ok])
        order = np.argsort(x)
        x = x[order]
        inside = (lr >= x[0]) & (lr <= x[-1])

        def at(values, log=True, ok=ok, order=order, x=x, inside=inside):
            v = np.asarray(values)[ok][order]
            y = np.interp(lr, x, np.log(v) if log else v)
            return np.where(inside, np.exp(y) if log else y, np.nan)

        h = at(ds["family_hysteresis"].values[i])
        util = at(ds["family_stress_utilisation"].values[i], log=False)
        if stress:
            h = np.where(util <= 1.0, h, np.nan)
        better = np.isfinite(h) & ~(h >= best["hysteresis"])
        best["hysteresis"][better] = h[better]
        best["resolution_N"][better] = at(ds["family_resolution_N"].values[i])[better]
        best["stress_utilisation"][better] = util[better]
        best["phi1_deg"][better] = phi1
        best["hinge_mm"][better] = np.exp(np.interp(lr, x, logt[ok][order]))[better]
    return {k: v.reshape(r.shape) for k, v in best.items()}


def fill_equal_range(ds: xr.Dataset) -> None:
    """Fill the ``equal_range_*`` variables of every cell (in place): the best basis body
    of the cell's own range and the ratios of H and resolution to it (NaN for cells that
    are not admissible or whose range no basis body reaches within the allowable stress)."""
    for h, hs in enumerate(ds["hinges"].values):
        ok = admissible(ds, str(hs))
        b = basis_at_range(ds, np.where(ok, ds["range_N"].values[h], np.nan))
        ds["equal_range_basis_hysteresis"].values[h] = b["hysteresis"]
        ds["equal_range_basis_resolution_N"].values[h] = b["resolution_N"]
        ds["equal_range_basis_phi1_deg"].values[h] = b["phi1_deg"]
        ds["equal_range_basis_hinge_mm"].values[h] = b["hinge_mm"]
        ds["equal_range_ratio_hysteresis"].values[h] = ds["hysteresis"].values[h] / b["hysteresis"]
        ds["equal_range_ratio_resolution"].values[h] = ds["resolution_N"].values[h] / b["resolution_N"]


#: Columns of a front and of the cells the summary names.
CELL_COLUMNS = ("phi1_deg", "phi2_deg", "range_N", "hysteresis", "resolution_N", "amplification",
                "k_out_N_per_mm", "strain_energy_mJ", "stress_utilisation", "equal_range_ratio_hysteresis")


def _cells(ds: xr.Dataset, hinges: str) -> pd.DataFrame:
    """The admissible cells of a hinge set as a table (with grid indices i, j)."""
    sub = ds.sel(hinges=hinges)
    ok = admissible(ds, hinges)
    i, j = np.nonzero(ok)
    df = pd.DataFrame({k: sub[k].values[i, j] for k in CELL_COLUMNS if k not in ("phi1_deg", "phi2_deg")})
    df.insert(0, "phi2_deg", sub["phi2_deg"].values[j])
    df.insert(0, "phi1_deg", sub["phi1_deg"].values[i])
    df["i"], df["j"] = i, j
    return df


def pareto_front(ds: xr.Dataset, hinges: str, tolerance: float = SAME_RANGE) -> pd.DataFrame:
    """The (range, H) front of a hinge set: every admissible cell whose H is the lowest
    among the admissible cells within ``tolerance`` of its range, by range."""
    df = _cells(ds, hinges).sort_values("range_N").reset_index(drop=True)
    r, h = df["range_N"].values, df["hysteresis"].values
    lo = np.searchsorted(r, r * (1 - tolerance), side="left")  # |r' / r - 1| <= tolerance, as answer_at
    hi = np.searchsorted(r, r * (1 + tolerance), side="right")
    keep = np.array([h[n] <= h[lo[n]:hi[n]].min() for n in range(len(df))], dtype=bool)
    return df[keep].drop(columns=["i", "j"]).reset_index(drop=True)


@dataclass(frozen=True)
class RangeAnswer:
    """The best admissible cell of one hinge set at one range, and the best basis body of
    that range. ``cell`` is None when no admissible cell lies within the tolerance;
    ``basis`` holds NaN when no basis body reaches the range within the allowable stress
    (``basis_any_stress`` is the best regardless of stress); ``toggle`` the cell's
    :meth:`~sensor.mechanics.toggle.StrokeChange.to_dict` (None without a cell)."""

    hinges: str
    range_N: float
    cell: dict | None
    basis: dict
    basis_any_stress: dict
    edge: str
    toggle: dict | None = None


def answer_at(ds: xr.Dataset, hinges: str, range_N: float, tolerance: float = SAME_RANGE) -> RangeAnswer:
    """The equal-range answer at ``range_N`` for one hinge set."""
    df = _cells(ds, hinges)
    near = df[np.abs(df["range_N"] / range_N - 1) <= tolerance]
    cell = None if near.empty else near.loc[near["hysteresis"].idxmin()].to_dict()
    if cell is not None:  # grid indices are integers (a pandas row holds them as floats)
        cell.update(i=int(cell["i"]), j=int(cell["j"]))
    basis = {k: float(v) for k, v in basis_at_range(ds, range_N).items()}
    loose = {k: float(v) for k, v in basis_at_range(ds, range_N, stress=False).items()}
    edge = "" if cell is None else edge_note(ds, hinges, int(cell["i"]), int(cell["j"]))
    toggle = None if cell is None else cell_toggle(ds, hinges, cell["phi1_deg"], cell["phi2_deg"])
    return RangeAnswer(hinges, float(range_N), cell, basis, loose, edge, toggle)


def cell_toggle(ds: xr.Dataset, hinges: str, phi1: float, phi2: float) -> dict:
    """Whether a cell of the sweep is next to the toggle, and how its k_out and A change over
    the stroke to the sweep's travel (:func:`sensor.mechanics.toggle.stroke_change`, its
    JSON keys): the cell's design solved again, to the travel and to its linear limit."""
    import json

    from sensor.design_space.spec import SweepSpec
    from sensor.mechanics.toggle import design_stroke_change

    design = SweepSpec(**_spec_args(ds)).design(hinges, phi1, phi2)
    return design_stroke_change(design, json.loads(ds.attrs["spec"])["target_output_mm"]).to_dict()


def edge_note(ds: xr.Dataset, hinges: str, i: int, j: int) -> str:
    """'' for a cell inside the grid's feasible region; else which edge it is on and where
    the feasible region really ends (found by bisecting the feasibility rules outward)."""
    from geometry.checks import check_design
    from sensor.design_space.spec import SweepSpec

    spec = SweepSpec(**_spec_args(ds))
    p1, p2 = ds["phi1_deg"].values, ds["phi2_deg"].values
    notes = []
    for axis, k, n, values in (("phi1", i, len(p1), p1), ("phi2", j, len(p2), p2)):
        for step, side in ((-1, "first"), (1, "last")):
            if not (k + step < 0 or k + step >= n):
                continue
            here = float(values[k])

            def feasible(v, axis=axis):
                a, b = (v, float(p2[j])) if axis == "phi1" else (float(p1[i]), v)
                return check_design(spec.design(hinges, a, b)).first_failure

            limit = 0.0 if step < 0 else 90.0
            if feasible(here) is not None:
                continue
            lo, hi = here, limit
            fail = None
            for _ in range(30):
                mid = 0.5 * (lo + hi)
                f = feasible(mid) if 0.0 < mid < 90.0 else "angle"
                if f is None:
                    lo = mid
                else:
                    hi, fail = mid, f
            rule = fail.rule if fail is not None and not isinstance(fail, str) else "angle range"
            notes.append(f"{axis} = {here:g} deg is the grid's {side} value; feasible cells go on "
                         f"to {axis} = {lo:.2f} deg ({rule})")
    return "; ".join(notes)


def _spec_args(ds: xr.Dataset) -> dict:
    """The SweepSpec fields a dataset was made with (its base design and hinge sets)."""
    import json

    spec = json.loads(ds.attrs["spec"])
    return {"hinge_sets": tuple(spec["hinge_sets"]), "base": spec["base"]}
