"""Figures of a phi1/phi2 sweep: the Figure 49 ratio panels, and hysteresis and resolution
against range (the equal-range answer, DESIGN section 13)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr
from matplotlib import rcParams
from matplotlib.colors import BoundaryNorm
from matplotlib.figure import Figure

from geometry import style
from geometry.atomic import save_figure
from sensor.design_space.equal_range import SUMMARY_RANGES_N, admissible, basis_at_range

style.use()

#: Thesis specimens (Table 5), hinge set 05-03: marked on that hinge set's panels only.
SAMPLES = {"A": (21.0, 34.0), "B": (22.0, 17.2)}
SAMPLES_HINGES = "05-03"

#: Axis labels of the ratio variables. H is SE times the law's constant, so the
#: strain-energy panel is also the hysteresis ratio.
LABELS = {
    "ratio_amplification": "amplification ratio A / A_basis",
    "ratio_k_out": "output stiffness ratio k_out / k_out,basis",
    "ratio_strain_energy": "strain energy (= hysteresis) ratio SE / SE_basis",
    "ratio_quality": "quality ratio (sensitivity/H) / basis",
    "equal_range_ratio_hysteresis": "H / H of the best basis body of the same range",
    "robust_quality_ratio": "robust quality (10th percentile) / basis quality",
}
#: The rows of Figure 49 (the thesis' ratios; drawn there only, not again one by one).
FIGURE49_ROWS = ("ratio_amplification", "ratio_k_out", "ratio_strain_energy")
#: The ratios drawn as figures of their own (the robust quality with Monte Carlo only).
RATIO_FIGURES = ("ratio_quality", "equal_range_ratio_hysteresis")


#: Subplot spacing of the sweep figures, fixed: their texts are, and tight_layout costs a
#: full text layout per figure (and makes savefig lay the figure out again per format).
#: The saved picture is cropped to its tight bounding box, so the outer margins are free.
FIXED_LAYOUT = {"left": 0.08, "right": 0.97, "bottom": 0.1, "wspace": 0.3}


def _save(fig, path: Path, formats=("png", "svg")) -> list[Path]:
    """Write one figure in several formats (atomically) and close it, cropped to its tight
    bounding box, which is computed once (``bbox_inches="tight"`` draws the whole figure
    again for every format)."""
    bbox = fig.get_tightbbox().padded(rcParams["savefig.pad_inches"])
    return [save_figure(fig, path.with_suffix(f".{fmt}"), close=(fmt == formats[-1]),
                        bbox_inches=bbox) for fmt in formats]


#: Quantile bands of a ratio panel: each colour holds 1/12 of the cells drawn.
BANDS = 12
#: What the colour bars show, said under every sweep figure's title.
BAND_NOTE = (f"colour bands: {BANDS} quantiles of the cells drawn (each holds 1/{BANDS} of them), "
             "shown at equal length on the colour bar, not to scale")
#: Label box of the ratio = 1 contour: bold crimson on white, so it stands out on its line.
ONE_LABEL_BOX = {"boxstyle": "round,pad=0.15", "fc": "white", "ec": "crimson", "lw": 0.6}


def plot_ratio_panel(ax, ds: xr.Dataset, var: str, hinges: str) -> None:
    """One Figure 49 panel: filled contours of a ratio over phi1 x phi2 (phi1 across), one
    colour per quantile band (a BoundaryNorm, so every band is told apart; the colour bar
    gives each band the same length and says so), every value with two decimals."""
    da = ds[var].sel(hinges=hinges)
    stress = var.startswith("equal_range")
    feas = admissible(ds, hinges) if stress else ds["feasible"].sel(hinges=hinges).values
    z = np.where(feas, da.values, np.nan).T  # rows phi2, columns phi1
    x, y = ds["phi1_deg"].values, ds["phi2_deg"].values
    # infeasible cells hatched; cells without a value (no basis body of their range) dotted;
    # drawn first, so contour labels near their edge stay on top
    for mask, hatch in (((~feas).T, "////"), ((feas & ~np.isfinite(da.values)).T, "...")):
        if mask.any():
            m = mask.astype(float)
            ax.contourf(x, y, m, levels=[0.5, 1.5], colors="none", hatches=[hatch], zorder=1)
            ax.contour(x, y, m, levels=[0.5], colors="0.4", linewidths=0.6, zorder=1)
    finite = z[np.isfinite(z)]
    if finite.size >= 4 and np.ptp(finite) > 0:
        levels = np.unique(np.quantile(finite, np.linspace(0, 1, BANDS + 1)))
        quantiles = len(levels) >= 3
        if not quantiles:
            levels = np.linspace(finite.min(), finite.max(), 5)
        cf = ax.contourf(x, y, z, levels=levels, cmap="viridis", extend="neither",
                         norm=BoundaryNorm(levels, ncolors=256), zorder=0)
        cs = ax.contour(x, y, z, levels=levels[1:-1:2], colors="k", linewidths=0.5, zorder=2)
        for t in ax.clabel(cs, fmt="%.2f", fontsize=8):
            t.set_zorder(4)
        if finite.min() < 1 < finite.max():
            one = ax.contour(x, y, z, levels=[1.0], colors="crimson", linewidths=2.2, zorder=3)
            for t in ax.clabel(one, fmt="1", fontsize=9, inline_spacing=8):
                t.set(fontweight="bold", bbox=ONE_LABEL_BOX, zorder=4)
        # one precision per bar: two decimals, three when the smallest band edge needs them
        small = np.abs(levels[levels != 0]).min() if (levels != 0).any() else 1.0
        decimals = 3 if small < 0.01 else 2
        bar = ax.figure.colorbar(cf, ax=ax, shrink=0.9, format=f"%.{decimals}f", spacing="uniform")
        bar.set_label(LABELS.get(var, var) + ("" if quantiles else " (linear)"), fontsize=9)
    for name, (p1, p2) in SAMPLES.items() if hinges == SAMPLES_HINGES else ():
        i, j = np.abs(x - p1).argmin(), np.abs(y - p2).argmin()
        ax.plot(p1, p2, "o", mfc="white", mec="k", ms=7, zorder=5)
        where = {"xytext": (5, 5)} if feas[i, j] else {"xytext": (0, -8), "ha": "center", "va": "top"}
        note = "" if feas[i, j] else ("\n(over the allowable stress)" if stress else "\n(infeasible)")
        ax.annotate(f"sample {name}{note}", (p1, p2), textcoords="offset points", fontsize=8.5, zorder=5,
                    bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.8}, **where)
    ax.set_xlabel("phi1 (deg): side-link lean from vertical")
    ax.set_ylabel("phi2 (deg): middle-link rise above horizontal")
    ax.set_title(f"{LABELS.get(var, var)}\nhinge set {hinges}")


def figure_names(monte_carlo: bool) -> list[str]:
    """The stems of a sweep's figures, slowest first: Figure 49, hysteresis against range,
    the ratios of :data:`RATIO_FIGURES`, and the robust quality with Monte Carlo."""
    return ["figure49", "hysteresis-vs-range", *RATIO_FIGURES, *(["robust_quality_ratio"] if monte_carlo else [])]


def start_figures(ds: xr.Dataset, fronts: dict[str, pd.DataFrame], out_dir: Path, pool):
    """Every figure of a sweep (PNG and SVG), handed out to ``pool`` (a
    :class:`~sensor.design_space.execution.TaskPool`, one figure a task): returns the
    function that waits for the written paths."""
    monte_carlo = any(k.startswith("mc_") for k in ds.data_vars)
    jobs = [(name, ds, fronts, out_dir) for name in figure_names(monte_carlo)]
    drawn = pool.start(draw_figure, jobs)
    return lambda: [path for paths in drawn() for path in paths]


def draw_figure(job) -> list[Path]:
    """Draw and write one figure of :func:`figure_names`; ``job`` is (stem, dataset, fronts,
    folder)."""
    name, ds, fronts, out_dir = job
    if name == "figure49":
        return plot_figure49(ds, out_dir)
    if name == "hysteresis-vs-range":
        return plot_hysteresis_vs_range(ds, fronts, out_dir)
    if name == "robust_quality_ratio":
        rob = ds["mc_quality_mm_per_N_p10"] / ds["basis_quality_mm_per_N"]
        return plot_ratio_figure(ds.assign(robust_quality_ratio=rob), name, out_dir)
    return plot_ratio_figure(ds, name, out_dir)


def plot_figure49(ds: xr.Dataset, out_dir: Path) -> list[Path]:
    """Figure 49: the amplification, k_out and SE ratios, one row each, one column per hinge
    set. PNG and SVG."""
    hsets = [str(h) for h in ds["hinges"].values]
    fig49 = Figure(figsize=(5.2 * len(hsets), 13))
    axes = fig49.subplots(3, len(hsets), squeeze=False)
    for r, var in enumerate(FIGURE49_ROWS):
        for c, h in enumerate(hsets):
            plot_ratio_panel(axes[r, c], ds, var, h)
    fig49.suptitle("Proposed DACM over the basis body at the same phi1 (thesis Figure 49); "
                   f"bold red: ratio = 1, hatched: infeasible\n{BAND_NOTE}")
    fig49.subplots_adjust(**FIXED_LAYOUT, top=0.905, hspace=0.32)
    return _save(fig49, out_dir / "figure49")


def plot_ratio_figure(ds: xr.Dataset, var: str, out_dir: Path) -> list[Path]:
    """One ratio (a key of :data:`LABELS`) with one panel per hinge set. PNG and SVG."""
    hsets = [str(h) for h in ds["hinges"].values]
    fig = Figure(figsize=(5.2 * len(hsets), 4.6))
    axes = fig.subplots(1, len(hsets), squeeze=False)
    for c, h in enumerate(hsets):
        plot_ratio_panel(axes[0, c], ds, var, h)
        if var == "robust_quality_ratio":
            axes[0, c].set_title(f"robust quality (10th percentile over hinge scatter) / basis\nhinge set {h}")
    what = ("hatched: infeasible or over the allowable stress; dotted: no basis body reaches the "
            "cell's range within the allowable stress" if var.startswith("equal_range")
            else "bold red: ratio = 1, hatched: infeasible")
    fig.suptitle(f"{what}\n{BAND_NOTE}", fontsize=9.5)
    fig.subplots_adjust(**FIXED_LAYOUT, top=0.8)
    return _save(fig, out_dir / var)


def plot_hysteresis_vs_range(ds: xr.Dataset, fronts: dict[str, pd.DataFrame], out_dir: Path,
                             designs: dict[str, dict] | None = None) -> list[Path]:
    """H and resolution against range (log axes): the admissible cells and the (range, H)
    front of each hinge set, the basis family at each phi1 of the grid (thin lines; its
    hinge thickness varied continuously), the best basis body of each range (bold), the
    ranges of the printed answer (dashed), and ``designs``, label -> a ``dacm design``
    result (``range_N``, ``hysteresis``, ``resolution_N``), as stars."""
    fig = Figure(figsize=(12.5, 5.2))
    axes = fig.subplots(1, 2)
    colours = dict(zip(fronts, ("tab:blue", "tab:orange", "tab:green")))
    lo = np.nanmin(ds["family_range_N"].values)
    hi = np.nanmax(ds["family_range_N"].values)
    grid = np.geomspace(lo, hi, 400)
    best, loose = basis_at_range(ds, grid), basis_at_range(ds, grid, stress=False)
    for ax, var, label in ((axes[0], "hysteresis", "predicted hysteresis H (fraction of full scale)"),
                           (axes[1], "resolution_N", "RMS resolution (N), worst over the range")):
        for i in range(ds["phi1_deg"].size):
            ok = ds["family_stress_utilisation"].values[i] <= 1.0
            ax.plot(ds["family_range_N"].values[i][ok], ds[f"family_{var}"].values[i][ok], "-",
                    color="0.75", lw=0.6, zorder=1)
        ax.plot([], [], "-", color="0.75", lw=0.6, label="basis family, one line per phi1 of the grid")
        ax.plot(grid, loose[var], "k:", lw=1.2, label="best basis body, stress limit ignored")
        ax.plot(grid, best[var], "k-", lw=2.2, label="best basis body of each range")
        for h, front in fronts.items():
            ok = admissible(ds, h)
            sub = ds.sel(hinges=h)
            ax.scatter(sub["range_N"].values[ok], sub[var].values[ok], s=3, alpha=0.25,
                       color=colours[h], zorder=2, label=f"DACM {h}: cells within stress")
            ax.plot(front["range_N"], front[var], "-", color=colours[h], lw=1.6, zorder=3,
                    label=f"DACM {h}: lowest H at each range")
        for k, r in enumerate(SUMMARY_RANGES_N):
            ax.axvline(r, color="0.5", lw=0.6, ls="--", zorder=0,
                       label=f"ranges of the printed answer ({', '.join(f'{v:g}' for v in SUMMARY_RANGES_N)} N)"
                       if k == 0 else None)
        for (name, d), marker in zip((designs or {}).items(), ("*", "P", "X")):
            ax.plot(d["range_N"], d[var], marker, color="crimson", mec="k", mew=0.5, ms=13, zorder=6,
                    label=f"{name}: H {d['hysteresis']:.4f}")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xticks([0.2, 0.5, 1, 2, 5, 10, 20, 50], labels=["0.2", "0.5", "1", "2", "5", "10", "20", "50"])
        ax.set_xlabel(f"range (N): input force at {ds.attrs['target_output_mm']:g} mm output travel")
        ax.set_ylabel(label)
        ax.grid(True, which="major", alpha=0.3)
    axes[0].set_title("Hysteresis at equal range (lower is better)")
    axes[1].set_title("Resolution at equal range (lower is better)")
    axes[0].legend(fontsize=8, loc="upper left")
    fig.suptitle("Proposed DACM against the basis body at the same force range; only bodies within "
                 "the allowable hinge stress at full scale")
    fig.subplots_adjust(**FIXED_LAYOUT, top=0.88)
    return _save(fig, out_dir / "hysteresis-vs-range")
