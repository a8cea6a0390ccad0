"""Figures of a phi1/phi2 sweep: the Figure 49 ratio panels and the Pareto front."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import xarray as xr

from geometry.atomic import save_figure

#: Thesis specimens marked on every panel (Table 5).
SAMPLES = {"A": (21.0, 34.0), "B": (22.0, 17.2)}

#: Axis labels of the ratio variables (the Monte-Carlo robust quality has no panel of its own).
PANELS = {
    "ratio_amplification": "amplification ratio A / A_basis",
    "ratio_k_out": "output stiffness ratio k_out / k_out,basis",
    "ratio_strain_energy": "strain energy ratio SE / SE_basis",
    "ratio_hysteresis": "predicted hysteresis ratio H / H_basis",
    "ratio_quality": "quality ratio (sensitivity/H) / basis",
}
LABELS = {**PANELS, "robust_quality_ratio": "robust quality (10th percentile) / basis quality"}


def _save(fig, path: Path, formats=("png", "svg")) -> list[Path]:
    """Write one figure in several formats (atomically) and close it."""
    return [save_figure(fig, path.with_suffix(f".{fmt}"), dpi=130, close=(fmt == formats[-1]),
                        bbox_inches="tight") for fmt in formats]


def plot_ratio_panel(ax, ds: xr.Dataset, var: str, hinges: str) -> None:
    """One Figure 49 panel: filled contours of a ratio over phi1 x phi2 (phi1 across)."""
    da = ds[var].sel(hinges=hinges)
    feas = ds["feasible"].sel(hinges=hinges).values
    z = np.where(feas, da.values, np.nan).T  # rows phi2, columns phi1
    x, y = ds["phi1_deg"].values, ds["phi2_deg"].values
    finite = z[np.isfinite(z)]
    if finite.size >= 4 and np.ptp(finite) > 0:
        levels = np.unique(np.quantile(finite, np.linspace(0, 1, 13)))
        if len(levels) < 3:
            levels = np.linspace(finite.min(), finite.max(), 5)
        cf = ax.contourf(x, y, z, levels=levels, cmap="viridis", extend="neither")
        cs = ax.contour(x, y, z, levels=levels[1:-1:2], colors="k", linewidths=0.5)
        ax.clabel(cs, fmt="%.2f", fontsize=7)
        if finite.min() < 1 < finite.max():
            one = ax.contour(x, y, z, levels=[1.0], colors="crimson", linewidths=2.2)
            ax.clabel(one, fmt="1", fontsize=8)
        plt.colorbar(cf, ax=ax, label=LABELS.get(var, var), shrink=0.9)
    # infeasible cells hatched
    mask = (~feas).T.astype(float)
    if mask.any():
        ax.contourf(x, y, mask, levels=[0.5, 1.5], colors="none", hatches=["////"])
        ax.contour(x, y, mask, levels=[0.5], colors="0.4", linewidths=0.6)
    for name, (p1, p2) in SAMPLES.items():
        ax.plot(p1, p2, "o", mfc="white", mec="k", ms=7, zorder=5)
        ax.annotate(f"sample {name}", (p1, p2), xytext=(5, 5), textcoords="offset points", fontsize=8)
    ax.set_xlabel("phi1 (deg): side-link lean from vertical")
    ax.set_ylabel("phi2 (deg): middle-link rise above horizontal")
    ax.set_title(f"{LABELS.get(var, var)}\nhinge set {hinges}", fontsize=9)


def plot_figure49(ds: xr.Dataset, out_dir: Path) -> list[Path]:
    """Figure 49 (amplification, k_out and SE ratios per hinge set) plus hysteresis and
    quality ratios; one figure per ratio with one panel per hinge set, and the combined
    Figure 49 layout. PNG and SVG."""
    written = []
    hsets = [str(h) for h in ds["hinges"].values]
    fig49, axes = plt.subplots(3, len(hsets), figsize=(5.2 * len(hsets), 13), squeeze=False)
    for r, var in enumerate(("ratio_amplification", "ratio_k_out", "ratio_strain_energy")):
        for c, h in enumerate(hsets):
            plot_ratio_panel(axes[r, c], ds, var, h)
    fig49.suptitle("Proposed DACM over the basis body at the same phi1 (thesis Figure 49); "
                   "bold red: ratio = 1, hatched: infeasible", fontsize=10)
    fig49.tight_layout()
    written += _save(fig49, out_dir / "figure49")
    for var in PANELS:
        fig, axes = plt.subplots(1, len(hsets), figsize=(5.2 * len(hsets), 4.6), squeeze=False)
        for c, h in enumerate(hsets):
            plot_ratio_panel(axes[0, c], ds, var, h)
        fig.tight_layout()
        written += _save(fig, out_dir / var)
    if any(k.startswith("mc_") for k in ds.data_vars):
        fig, axes = plt.subplots(1, len(hsets), figsize=(5.2 * len(hsets), 4.6), squeeze=False)
        for c, h in enumerate(hsets):
            rob = ds["mc_quality_mm_per_N_p10"] / ds["basis_quality_mm_per_N"]
            plot_ratio_panel(axes[0, c], ds.assign(robust_quality_ratio=rob), "robust_quality_ratio", h)
            axes[0, c].set_title(f"robust quality (10th percentile over hinge scatter) / basis\nhinge set {h}", fontsize=9)
        fig.tight_layout()
        written += _save(fig, out_dir / "robust_quality_ratio")
    return written


def pareto_front(ds: xr.Dataset, hinges: str) -> pd.DataFrame:
    """Feasible cells not dominated in (higher sensitivity, lower predicted hysteresis)."""
    sub = ds.sel(hinges=hinges)
    df = sub[["sensitivity_mm_per_N", "hysteresis", "quality_mm_per_N", "amplification",
              "k_out_N_per_mm", "strain_energy_mJ"]].to_dataframe().reset_index()
    df = df[sub["feasible"].values.ravel()].sort_values(["hysteresis", "sensitivity_mm_per_N"],
                                                        ascending=[True, False])
    best = -np.inf
    keep = []
    for idx, s in zip(df.index, df["sensitivity_mm_per_N"]):
        if s > best:
            keep.append(idx)
            best = s
    return df.loc[keep].drop(columns=["hinges"], errors="ignore").reset_index(drop=True)


def plot_pareto(ds: xr.Dataset, fronts: dict[str, pd.DataFrame], out_dir: Path) -> list[Path]:
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    for h, front in fronts.items():
        sub = ds.sel(hinges=h)
        feas = sub["feasible"].values
        ax.scatter(sub["hysteresis"].values[feas], sub["sensitivity_mm_per_N"].values[feas], s=4, alpha=0.25,
                   label=f"{h}: feasible cells")
        ax.plot(front["hysteresis"], front["sensitivity_mm_per_N"], "-o", ms=3, label=f"{h}: Pareto front")
        b = sub["basis_hysteresis"].values, sub["basis_sensitivity_mm_per_N"].values
        ax.plot(b[0], b[1], "k--", lw=0.8, alpha=0.6)
    ax.plot([], [], "k--", lw=0.8, label="basis bodies")
    ax.set_xscale("log")  # cells near toggle (phi2 small) reach H ~ 1 and would hide the front
    ax.set_xlabel("predicted hysteresis H (fraction of full scale, log scale)")
    ax.set_ylabel("sensitivity (mm/N)")
    ax.set_title("Sensitivity against predicted hysteresis")
    ax.legend(fontsize=8)
    fig.tight_layout()
    return _save(fig, out_dir / "pareto")
