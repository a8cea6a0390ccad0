"""Figures of the closed-loop experiments and studies of chapters IV-V, as
:class:`matplotlib.figure.Figure` objects (no backend is set; write them with
:func:`geometry.atomic.save_figure`).

Legend names are the studies' table headings (:data:`~sensor.pneumatic.studies.ESTIMATOR_HEADINGS`,
:data:`~sensor.pneumatic.studies.CH5_HEADINGS`); every axis carries one unit; the MSE window
of eq 44 is shaded on time axes, and phase plots show that window only.
"""
from __future__ import annotations

from matplotlib.figure import Figure

from geometry import style
from sensor.pneumatic.loop_metrics import window
from sensor.pneumatic.studies import CH5_HEADINGS, CH5_PRIMARY, ESTIMATOR_HEADINGS

style.use()


ESTIMATOR_COLOURS = {"observer": "tab:blue", "open_loop": "tab:orange", "valve_ports": "tab:green"}
CONTROLLER_COLOURS = {"smc": "tab:red", "line_model_thesis": "tab:blue", "smc_rule": "tab:red",
                      "line_model_thesis_rule": "tab:blue", "line_model_damped": "tab:green"}
WINDOW_SHADE = {"color": "0.85", "zorder": 0}
OUTSIDE = {"fontsize": 8.5, "loc": "upper left", "bbox_to_anchor": (1.01, 1.0)}


def _mark_window(ax, sl) -> None:
    ax.axvspan(sl.start, sl.stop, **WINDOW_SHADE, label="MSE window")


def _pressure_error_kPa(ds, side: int, name: str):
    return (ds[name] - ds.pressure_chamber.sel(side=side)) / 1e3


def loop_figure(ds, setup) -> Figure:
    """One run: forces, both chamber pressures (true, estimated, valve port, line model) with
    the MSE window shaded, and the estimation-error phase plot over that window."""
    fig = Figure(figsize=(13, 7.5), layout="constrained")
    ax = fig.subplots(2, 2)
    sl = window(ds, setup.ref)
    t = ds.time.values
    a = ax[0, 0]
    _mark_window(a, sl)
    a.plot(t, ds.environment_force.values, color="tab:blue", lw=2.5, alpha=0.5, label="contact force F_e (wide)")
    a.plot(t, ds.measured_force_N.values, color="0.2", lw=0.6, label="force reading")
    a.plot(t, ds.desired_force_N.values, color="k", ls="--", lw=1.0, label="desired F_d")
    a.set(xlabel="time (s)", ylabel="force (N)",
          title=f"{setup.controller}, {setup.reference}, {setup.line_length_m:g} m")
    a.legend(**OUTSIDE)
    for s, a in ((1, ax[0, 1]), (2, ax[1, 0])):
        _mark_window(a, sl)
        # over the whole run and, inset, over the MSE window; the true pressure wide and light
        # underneath, so the estimates that follow it show
        inset = a.inset_axes([0.52, 0.06, 0.45, 0.4])
        for target, part in ((a, slice(None)), (inset, sl)):
            w = ds.sel(time=part)
            tw = w.time.values
            target.plot(tw, w.pressure_chamber.sel(side=s).values / 1e3, color="0.55", lw=3.5, alpha=0.6,
                    label="chamber (true, wide)", zorder=1)
            target.plot(tw, w.pressure_valve.sel(side=s).values / 1e3, color="tab:green", lw=0.8, label="valve port",
                    zorder=2)
            if f"line_model_pressure_{s}_Pa" in ds:
                target.plot(tw, w[f"line_model_pressure_{s}_Pa"].values / 1e3, color="tab:purple", lw=0.8, ls="-.",
                        label="line model", zorder=3)
            target.plot(tw, w[f"estimated_pressure_{s}_Pa"].values / 1e3, color="tab:orange", lw=1.0, ls=(0, (4, 2)),
                    label=f"{setup.observer} estimate", zorder=4)
        inset.set_title("MSE window", fontsize=8, pad=2)
        inset.tick_params(labelsize=7.5)
        a.set(xlabel="time (s)", ylabel="pressure (kPa abs)", title=f"chamber {s}")
        a.legend(**OUTSIDE)
    a = ax[1, 1]
    w = ds.sel(time=sl)
    a.plot(_pressure_error_kPa(w, 1, "estimated_pressure_1_Pa"), _pressure_error_kPa(w, 2, "estimated_pressure_2_Pa"),
           color="tab:orange", lw=0.7)
    a.set(xlabel="P~1 (kPa)", ylabel="P~2 (kPa)", aspect="equal", adjustable="datalim",
          title=f"estimation error over the MSE window {sl.start:.3g}-{sl.stop:.3g} s (cf. Figures 16-18)")
    a.axhline(0, color="0.6", lw=0.5)
    a.axvline(0, color="0.6", lw=0.5)
    return fig


def observer_phase_figure(res) -> Figure:
    """Figures 16-18: estimation-error phase plots of the three estimators over each MSE window."""
    exps = [e for e in res["experiments"] if e["controller"] != "smc"]
    fig = Figure(figsize=(4.4 * len(exps), 4.4), layout="constrained")
    for a, e in zip(fig.subplots(1, len(exps)), exps):
        for key in ("valve_ports", "open_loop", "observer"):
            ds = res["runs"][(e["controller"], e["reference"], key)]
            w = ds.sel(time=slice(*e["window_s"]))
            a.plot(_pressure_error_kPa(w, 1, "estimated_pressure_1_Pa"), _pressure_error_kPa(w, 2, "estimated_pressure_2_Pa"),
                   lw=0.7, color=ESTIMATOR_COLOURS[key], label=f"{ESTIMATOR_HEADINGS[key]} ({e[key]:.3g} kPa^2)")
        a.set(xlabel="P~1 (kPa)", ylabel="P~2 (kPa)", title=f"{e['figure']}: {e['experiment']}, 7.25 m")
        a.legend(fontsize=8)
    return fig


def observer_smc_figure(res) -> Figure:
    """Figure 26 (force and pressure MSE per estimator, separate axes) and Figure 27 (per-cycle
    MSEs around the observer's switch-on, separate axes)."""
    smc = [e for e in res["experiments"] if e["controller"] == "smc"]
    fig = Figure(figsize=(15, 3.8), layout="constrained")
    ax = fig.subplots(1, 4)
    labels = [e["reference"] for e in smc]
    keys = list(ESTIMATOR_HEADINGS)
    width = 0.8 / len(keys)
    for a, (unit, get) in zip(ax[:2], (("N^2", lambda e, k: e["force_mse_N2"][k]), ("kPa^2", lambda e, k: e[k]))):
        for j, k in enumerate(keys):
            a.bar([i + width * j for i in range(len(smc))], [get(e, k) for e in smc], width,
                  color=ESTIMATOR_COLOURS[k], label=ESTIMATOR_HEADINGS[k])
        a.set_xticks([i + width * (len(keys) - 1) / 2 for i in range(len(smc))], labels)
        a.set(yscale="log", ylabel=f"MSE ({unit})", xlabel="z_d")
    fig.legend(*ax[0].get_legend_handles_labels(), loc="outside upper left", ncols=3, fontsize=8)
    ax[0].set_title("Figure 26: force MSE, SMC impedance")
    ax[1].set_title("Figure 26: pressure MSE (eq 44)")
    sw = res["switch_on"]
    for a, key, unit in ((ax[2], "force_mse_N2", "N^2"), (ax[3], "pressure_mse_kPa2", "kPa^2")):
        a.plot(sw["cycle_start_s"], sw[key], "o-", ms=3, color="tab:blue")
        a.axvline(sw["on_s"], color="k", ls="--", lw=1, label=f"observer on ({sw['on_s']:g} s)")
        a.set(yscale="linear" if unit == "N^2" else "log", xlabel="cycle start (s)", ylabel=f"per-cycle MSE ({unit})",
              title=f"Figure 27: {'force' if unit == 'N^2' else 'pressure'} MSE per cycle")
        a.legend(fontsize=8)
    return fig


def controller_mse_figure(res) -> Figure:
    """Figure 32 (MSE_1 against line length per sine reference, Table 4 beside) and Figure 37
    (pressure-estimation MSE at 2 Hz on its own axis)."""
    rows = res["rows"]
    lengths = sorted({r["line_length_m"] for r in rows})
    refs = [r for r in ("sine:0.5Hz", "sine:1Hz", "sine:2Hz") if any(x["reference"] == r for x in rows)]
    get = {(r["line_length_m"], r["reference"]): r for r in rows}
    fig = Figure(figsize=(4.2 * (len(refs) + 1), 4.0), layout="constrained")
    ax = fig.subplots(1, len(refs) + 1)
    for a, ref in zip(ax, refs):
        for key, heading in CH5_HEADINGS.items():
            a.plot(lengths, [get[(L, ref)][key]["mse1_N2"] for L in lengths], "o-" if key in CH5_PRIMARY else "o:",
                   ms=4, color=CONTROLLER_COLOURS[key], label=heading)
        t4 = [(L, get[(L, ref)]["thesis_table4"]["mse1_N2"]) for L in lengths if get[(L, ref)]["thesis_table4"]]
        a.plot([x[0] for x in t4], [x[1] for x in t4], "k^--", ms=5, lw=0.8, label="Table 4 (thesis, measured)")
        a.set(yscale="log", xlabel="line length (m)", ylabel="MSE_1 (N^2)", title=f"Figure 32: {ref}")
    # legends above the panels, clear of the curves: one for the Figure 32 panels (the same
    # entries), one for Figure 37
    fig.legend(*ax[0].get_legend_handles_labels(), loc="outside upper left", ncols=3, fontsize=8)
    a = ax[-1]
    ref = refs[-1]
    a.plot(lengths, [get[(L, ref)]["line_model_thesis"]["pressure_mse_kPa2"] for L in lengths], "o-", color="tab:orange",
           label="standard model (thesis controller's run)")
    a.plot(lengths, [get[(L, ref)]["line_model_thesis"]["line_model_pressure_mse_kPa2"] for L in lengths], "s-",
           color=CONTROLLER_COLOURS["line_model_thesis"], label="line model (thesis controller's run)")
    a.plot(lengths, [get[(L, ref)]["line_model_damped"]["line_model_pressure_mse_kPa2"] for L in lengths], "s-",
           color=CONTROLLER_COLOURS["line_model_damped"], label="line model (ours)")
    a.set(yscale="log", xlabel="line length (m)", ylabel="pressure MSE (kPa^2)", title=f"Figure 37: {ref}")
    fig.legend(*a.get_legend_handles_labels(), loc="outside upper right", ncols=1, fontsize=8)
    return fig


def controller_virtual_input_figure(res, length_m: float = 5.0, seconds: float = 3.0) -> Figure | None:
    """Figures 33-34: F_vd, F_V, F_d and F_e over the last ``seconds`` of each kept line-model run
    at ``length_m``; None when no such run was kept."""
    keep = [k for k in res["runs"] if k[0] == length_m and not k[2].startswith("smc")]
    if not keep:
        return None
    fig = Figure(figsize=(4.6 * len(keep), 3.8), layout="constrained")
    axes = fig.subplots(1, len(keep), squeeze=False)[0]
    for a, k in zip(axes, keep):
        ds = res["runs"][k]
        w = ds.sel(time=slice(float(ds.time[-1]) - seconds, None))
        t = w.time.values
        a.plot(t, w.virtual_input_desired_N.values, color="tab:purple", lw=0.8, label="F_vd")
        a.plot(t, w.virtual_input_N.values, color="tab:green", lw=0.8, label="F_V")
        a.plot(t, w.environment_force.values, color="tab:blue", lw=0.8, label="F_e")
        a.plot(t, w.desired_force_N.values, color="k", ls="--", lw=0.8, label="F_d")
        a.set(xlabel="time (s)", ylabel="force (N)", title=f"{length_m:g} m, {k[1]}: {CH5_HEADINGS[k[2]]}")
        a.legend(fontsize=8, loc="upper right")
    return fig


def sensor_figure(res) -> Figure:
    """Contact force and reading of each DACM sensor in the loop over its MSE window, and the
    force-MSE bars against the load cell."""
    names = list(dict.fromkeys(k[0] for k in res["runs"]))
    fig = Figure(figsize=(4.2 * (len(names) + 1), 3.8), layout="constrained")
    ax = fig.subplots(1, len(names) + 1)
    rows = res["rows"]
    for a, name in zip(ax, names):
        row = next(r for r in rows if r["sensor"] == name and r["reading"].startswith("DACM"))
        ds = res["runs"][(name, "DACM " + name)]
        w = ds.sel(time=slice(*row["window_s"]))
        t = w.time.values
        a.plot(t, w.measured_force_N.values, color="tab:gray", lw=0.6, label="DACM reading")
        a.plot(t, w.environment_force.values, color="tab:blue", lw=0.9, label="contact force")
        a.plot(t, w.desired_force_N.values, color="k", ls="--", lw=0.8, label="F_d")
        a.set(xlabel="time (s)", ylabel="force (N)", title=name)
    # one legend for the time panels, above them: inside a panel it covered the peaks
    fig.legend(*ax[0].get_legend_handles_labels(), loc="outside upper left", ncols=3, fontsize=8)
    a = ax[-1]
    for j, (kind, colour) in enumerate((("DACM", "tab:blue"), ("load cell", "tab:gray"))):
        vals = [next(r["force_mse_N2"] for r in rows if r["sensor"] == n and r["reading"].startswith(kind)) for n in names]
        a.bar([i + 0.4 * j for i in range(len(names))], vals, 0.4, color=colour, label=kind)
    a.set_xticks([i + 0.2 for i in range(len(names))], [n.replace("-as-cut", "") for n in names])
    a.set(ylabel="force MSE (N^2)", title="force-control error")
    a.legend(fontsize=8)
    return fig
