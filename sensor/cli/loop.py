"""``dacm loop``: one closed-loop experiment of the tele-operated pneumatic actuator (observer,
controller, optional DACM force sensor), or a whole study of thesis chapters IV-V."""

from __future__ import annotations

import json
import math
import sys
import warnings
from pathlib import Path

from sensor.errors import SensorInputError

STUDIES = ("observer", "controllers", "sensor")


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "loop", help="closed-loop pneumatic force control with the force-feedback pressure observer "
                     "(chapters IV-V), optionally read by a DACM sensor",
        description="Simulate the valve, the transmission lines (distributed, high fidelity), the "
                    "cylinder against a spring, the pressure observer and a force controller at 1 kHz. "
                    "Prints the force-control MSE and the pressure-estimation MSE of eq 44 over the "
                    "steady window (last 2 s; 2 s from a step) and writes plots to --out. "
                    "--study runs a whole chapter's grid and writes its tables and figures.")
    p.add_argument("--line-length", type=float, default=7.25, metavar="M", help="line length, m (default 7.25)")
    p.add_argument("--reference", default="sine:1Hz", metavar="REF",
                   help="desired force: sine:<f>Hz | square:<f>Hz | step (default sine:1Hz); for "
                        "impedance it moves z_d so that k_d z~ has this shape")
    p.add_argument("--amplitude", type=float, default=24.0, metavar="N", help="reference amplitude, N (default 24)")
    p.add_argument("--offset", type=float, default=0.0, metavar="N", help="reference offset, N (default 0)")
    p.add_argument("--controller", default="pi", metavar="NAME", help="pi | impedance | smc | line-model (default pi)")
    p.add_argument("--observer", default="force", metavar="NAME",
                   help="force (eqs 19-24) | standard (k = 0) | valve (valve-port pressures) (default force)")
    p.add_argument("--valve", default=None, metavar="NAME",
                   help="festo-mpye-5-1/8-lf | enfield-lh05 (default: Festo for pi/impedance, Enfield for "
                        "smc/line-model, as the thesis)")
    p.add_argument("--sensor", default=None, metavar="PRESET|TOML",
                   help="DACM force sensor (a preset such as sample-a-as-cut, or a design .toml) instead of "
                        "the load cell; the environment then is a push-only 2 kN/m spring in series with it")
    p.add_argument("--segments", type=int, default=20, metavar="N", help="segments per line (default 20)")
    p.add_argument("--duration", type=float, default=6.0, metavar="S", help="simulated time, s (default 6)")
    p.add_argument("--study", default=None, metavar="NAME", help="observer | controllers | sensor: run a whole study")
    p.add_argument("--out", type=Path, default=Path("dacm-out"), metavar="DIR",
                   help="folder for plots and tables (default ./dacm-out; created if missing)")
    p.add_argument("--no-plots", action="store_true", help="do not write plots")
    p.add_argument("--json", action="store_true", help="print the results as JSON")
    p.set_defaults(func=run)


def _setup(args):
    from sensor.pneumatic.controllers import CONTROLLERS
    from sensor.pneumatic.cylinder import spring_contact
    from sensor.pneumatic.observer import OBSERVER_KINDS
    from sensor.pneumatic.studies import DacmForceSensor, Setup, series_spring

    if args.controller not in CONTROLLERS:
        raise SensorInputError(f"--controller {args.controller!r}: must be one of {', '.join(CONTROLLERS)}")
    if args.observer not in OBSERVER_KINDS:
        raise SensorInputError(f"--observer {args.observer!r}: must be one of {', '.join(OBSERVER_KINDS)}")
    if not (math.isfinite(args.line_length) and args.line_length > 0):
        raise SensorInputError(f"--line-length {args.line_length!r}: must be a positive finite number (m)")
    valve = args.valve or ("enfield-lh05" if args.controller in ("smc", "line-model") else "festo-mpye-5-1/8-lf")
    kw = {}
    if args.sensor:
        fs = DacmForceSensor(args.sensor)
        kw = {"force_sensor": fs, "environment": spring_contact(series_spring(2000.0, fs.stiffness_N_m), 0.025)}
    setup = Setup(controller=args.controller, observer=args.observer, reference=args.reference,
                  amplitude_N=args.amplitude, offset_N=args.offset, line_length_m=args.line_length,
                  segments=args.segments, valve=valve, duration_s=args.duration, **kw)
    setup.ref  # parse now: a bad reference is a one-line error
    return setup


def run(args) -> int:
    from sensor.errors import CapacityWarning

    if args.study is not None and args.study not in STUDIES:
        raise SensorInputError(f"--study {args.study!r}: must be one of {', '.join(STUDIES)}")
    if args.segments < 1:
        raise SensorInputError(f"--segments {args.segments!r}: must be an integer >= 1")
    if not (math.isfinite(args.duration) and args.duration > 0):
        raise SensorInputError(f"--duration {args.duration!r}: must be a positive finite number (s)")
    if not args.no_plots or args.study:
        args.out.mkdir(parents=True, exist_ok=True)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", CapacityWarning)
        result = _run_study(args) if args.study else _run_one(args)
    for w in caught:
        if issubclass(w.category, CapacityWarning):
            print(f"dacm loop: warning: {w.message}", file=sys.stderr)
    if args.json:
        print(json.dumps(result, indent=1))
    return 0


def _run_one(args) -> dict:
    from sensor.pneumatic.studies import metrics
    from sensor.pneumatic.studies import run as run_experiment

    setup = _setup(args)
    ds = run_experiment(setup)
    m = metrics(ds, setup.ref)
    result = {"controller": setup.controller, "observer": setup.observer, "reference": setup.reference,
              "amplitude_N": setup.amplitude_N, "line_length_m": setup.line_length_m, "valve": setup.valve,
              "sensor": args.sensor or "load cell", "duration_s": setup.duration_s,
              "gains": json.loads(ds.attrs["gains"]), **m}
    if not args.no_plots:
        result["plot"] = str(plot_run(ds, setup, args.out / "loop.png"))
    if not args.json:
        print(f"{setup.controller} control, {setup.observer} observer, {setup.reference} ({setup.amplitude_N:g} N), "
              f"{setup.line_length_m:g} m lines, {setup.valve}, sensor: {result['sensor']}")
        if result["gains"]:
            print("  gains (section 5.4.2, from the line): " + ", ".join(f"{k} {v:.4g}" for k, v in result["gains"].items()))
        print(f"  force-control MSE         {m['force_mse_N2']:10.3f} N^2   (window {m['window_s'][0]:.2f}-"
              f"{m['window_s'][1]:.2f} s)")
        print(f"  pressure MSE (eq 44)      {m['pressure_mse_kPa2']:10.2f} kPa^2 ({setup.observer} estimate)")
        print(f"  valve-port pressure MSE   {m['valve_pressure_mse_kPa2']:10.2f} kPa^2")
        if "virtual_input_mse_N2" in m:
            print(f"  virtual-input MSE_2       {m['virtual_input_mse_N2']:10.3f} N^2")
            print(f"  line-model pressure MSE   {m['line_model_pressure_mse_kPa2']:10.2f} kPa^2")
        if "plot" in result:
            print(f"  wrote {result['plot']}")
    return result


def _run_study(args) -> dict:
    from sensor.pneumatic import studies as ex

    seg = args.segments
    if args.study == "observer":
        res = ex.observer_study(segments=seg)
        text = ex.observer_tables(res)
        files = [] if args.no_plots else observer_figures(res, args.out)
        out = {"tables": res["tables"]}
    elif args.study == "controllers":
        keep = {(5.0, r, "line-model") for r in ex.CH5_REFERENCES} | {(10.0, "sine:2Hz", c) for c in ("smc", "line-model")} \
            | {(2.0, "sine:0.5Hz", c) for c in ("smc", "line-model")}
        res = ex.controller_study(segments=seg, keep_runs=keep)
        text = ex.controller_tables(res)
        files = [] if args.no_plots else controller_figures(res, args.out)
        out = {"rows": res["rows"]}
    else:
        res = ex.sensor_study(segments=seg)
        text = ex.sensor_tables(res)
        files = [] if args.no_plots else sensor_figures(res, args.out)
        out = {"rows": res["rows"]}
    from geometry.atomic import atomic_path
    md = args.out / f"loop-{args.study}.md"
    with atomic_path(md) as tmp:
        Path(tmp).write_text(text)
    out["files"] = [str(md)] + [str(f) for f in files]
    if not args.json:
        print(text)
        print("wrote " + ", ".join(out["files"]))
    return out


# --- plots -----------------------------------------------------------------------------------------

def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def _save(fig, path: Path) -> Path:
    from geometry.atomic import save_figure

    fig.tight_layout()
    return save_figure(fig, path, dpi=90)


def plot_run(ds, setup, path: Path) -> Path:
    """Forces, chamber pressures (true, estimated, valve port) and the estimation-error phase plot."""
    plt = _plt()
    fig, ax = plt.subplots(2, 2, figsize=(11, 7))
    t = ds.time.values
    a = ax[0, 0]
    a.plot(t, ds.desired_force_N, "k--", lw=1, label="desired F_d")
    a.plot(t, ds.environment_force, lw=1, label="contact force F_e")
    a.plot(t, ds.measured_force_N, lw=0.6, alpha=0.6, label="force reading")
    a.set(xlabel="time (s)", ylabel="force (N)", title=f"{setup.controller}, {setup.reference}, {setup.line_length_m:g} m")
    a.legend(fontsize=7)
    for s, a in ((1, ax[0, 1]), (2, ax[1, 0])):
        a.plot(t, ds.pressure_chamber.sel(side=s) / 1e3, "k", lw=1, label="chamber (true)")
        a.plot(t, ds[f"estimated_pressure_{s}_Pa"] / 1e3, lw=1, label=f"{setup.observer} estimate")
        a.plot(t, ds.pressure_valve.sel(side=s) / 1e3, lw=0.8, alpha=0.7, label="valve port")
        if f"line_model_pressure_{s}_Pa" in ds:
            a.plot(t, ds[f"line_model_pressure_{s}_Pa"] / 1e3, lw=0.8, label="line model")
        a.set(xlabel="time (s)", ylabel="pressure (kPa abs)", title=f"chamber {s}")
        a.legend(fontsize=7)
    a = ax[1, 1]
    e1 = (ds.estimated_pressure_1_Pa - ds.pressure_chamber.sel(side=1)) / 1e3
    e2 = (ds.estimated_pressure_2_Pa - ds.pressure_chamber.sel(side=2)) / 1e3
    a.plot(e1, e2, lw=0.6)
    a.set(xlabel="P~1 (kPa)", ylabel="P~2 (kPa)", title="estimation error phase plot (cf. Figures 16-18)")
    lim = max(1.0, float(abs(e1[len(e1) // 3:]).max()), float(abs(e2[len(e2) // 3:]).max()))
    a.set_xlim(-lim, lim)
    a.set_ylim(-lim, lim)
    return _save(fig, path)


def observer_figures(res, out: Path) -> list[Path]:
    """Phase plots of the three estimators per experiment (Figures 16-18), the SMC bars (Figure 26)
    and the switch-on transient (Figure 27)."""
    plt = _plt()
    runs, tables = res["runs"], res["tables"]
    exps = [("pi", "sine:1Hz"), ("pi", "sine:2Hz"), ("impedance", "square:0.5Hz")]
    fig, ax = plt.subplots(1, 3, figsize=(13, 4.2))
    for a, (c, r) in zip(ax, exps):
        for obs in ("valve", "standard", "force"):
            ds = runs[(c, r, obs)]
            w = ds.sel(time=slice(float(ds.time[-1]) - 2.0, None))
            a.plot((w.estimated_pressure_1_Pa - w.pressure_chamber.sel(side=1)) / 1e3,
                   (w.estimated_pressure_2_Pa - w.pressure_chamber.sel(side=2)) / 1e3, lw=0.7, label=obs)
        a.set(xlabel="P~1 (kPa)", ylabel="P~2 (kPa)", title=f"{c} {r}, 7.25 m")
        a.legend(fontsize=7)
    files = [_save(fig, out / "loop-observer-phase.png")]
    fig, ax = plt.subplots(1, 3, figsize=(12, 3.6))
    smc = tables["smc"]
    labels = sorted({r["experiment"].split()[-1] for r in smc}, key=lambda x: float(x[5:-2]))
    for k, (key, unit) in enumerate((("force_mse_N2", "N^2"), ("pressure_mse_kPa2", "kPa^2"))):
        for j, obs in enumerate(("standard", "force")):
            vals = [next(r[key] for r in smc if r["observer"] == obs and r["experiment"].endswith(lab)) for lab in labels]
            ax[k].bar([i + 0.4 * j for i in range(len(labels))], vals, 0.4, label=obs)
        ax[k].set_xticks([i + 0.2 for i in range(len(labels))], labels)
        ax[k].set(ylabel=f"MSE ({unit})", title=f"SMC impedance: {key.split('_')[0]} (Figure 26)")
        ax[k].legend(fontsize=7)
    sw = tables["switch_on"]
    ax[2].plot(sw["cycle_start_s"], sw["force_mse_N2"], "o-", label="force (N^2)")
    ax[2].plot(sw["cycle_start_s"], sw["pressure_mse_kPa2"], "s-", label="pressure (kPa^2)")
    ax[2].axvline(sw["on_s"], color="k", ls="--", lw=1)
    ax[2].set(yscale="log", xlabel="cycle start (s)", title="observer switched on (Figure 27)")
    ax[2].legend(fontsize=7)
    files.append(_save(fig, out / "loop-observer-smc.png"))
    return files


def controller_figures(res, out: Path) -> list[Path]:
    """MSE_1 against line length per reference (Figure 32), pressure-estimation MSE at 2 Hz
    (Figure 37) and the virtual-input tracking at 5 m (Figures 33-34)."""
    plt = _plt()
    rows = res["rows"]
    lengths = sorted({r["line_length_m"] for r in rows})
    refs = [r for r in ("sine:0.5Hz", "sine:1Hz", "sine:2Hz") if any(x["reference"] == r for x in rows)]
    fig, ax = plt.subplots(1, len(refs) + 1, figsize=(4 * (len(refs) + 1), 3.6))
    for a, ref in zip(ax, refs):
        for ctrl in ("smc", "line-model"):
            a.plot(lengths, [next(x["force_mse_N2"] for x in rows if x["line_length_m"] == L and x["reference"] == ref
                                  and x["controller"] == ctrl) for L in lengths], "o-", label=ctrl)
        a.set(yscale="log", xlabel="line length (m)", ylabel="MSE_1 (N^2)", title=f"{ref} (Figure 32)")
        a.legend(fontsize=7)
    a = ax[-1]
    ref = refs[-1]
    sel = [next(x for x in rows if x["line_length_m"] == L and x["reference"] == ref and x["controller"] == "line-model")
           for L in lengths]
    a.plot(lengths, [x["pressure_mse_kPa2"] for x in sel], "o-", label="standard model")
    a.plot(lengths, [x["line_model_pressure_mse_kPa2"] for x in sel], "s-", label="line model")
    a.set(yscale="log", xlabel="line length (m)", ylabel="pressure MSE (kPa^2)", title=f"{ref} (Figure 37)")
    a.legend(fontsize=7)
    files = [_save(fig, out / "loop-controllers-mse.png")]
    keep = [k for k in res["runs"] if k[0] == 5.0 and k[2] == "line-model"]
    if keep:
        fig, ax = plt.subplots(1, len(keep), figsize=(4 * len(keep), 3.4))
        for a, k in zip(list(ax) if len(keep) > 1 else [ax], keep):
            ds = res["runs"][k]
            a.plot(ds.time, ds.virtual_input_desired_N, lw=0.8, label="F_vd")
            a.plot(ds.time, ds.virtual_input_N, lw=0.8, label="F_V")
            a.plot(ds.time, ds.desired_force_N, "k--", lw=0.8, label="F_d")
            a.plot(ds.time, ds.environment_force, lw=0.8, label="F_e")
            a.set(xlabel="time (s)", ylabel="force (N)", title=f"5 m, {k[1]} (Figures 33-34)")
            a.legend(fontsize=6)
        files.append(_save(fig, out / "loop-controllers-virtual-input.png"))
    return files


def sensor_figures(res, out: Path) -> list[Path]:
    """Contact force and reading of each DACM sensor in the loop, and the MSE bars."""
    plt = _plt()
    names = sorted({k[0] for k in res["runs"]})
    fig, ax = plt.subplots(1, len(names) + 1, figsize=(4 * (len(names) + 1), 3.6))
    for a, name in zip(ax, names):
        ds = res["runs"][(name, "DACM " + name)]
        w = ds.sel(time=slice(float(ds.time[-1]) - 2.0, None))
        a.plot(w.time, w.desired_force_N, "k--", lw=0.8, label="F_d")
        a.plot(w.time, w.environment_force, lw=0.8, label="contact force")
        a.plot(w.time, w.measured_force_N, lw=0.6, alpha=0.7, label="DACM reading")
        a.set(xlabel="time (s)", ylabel="force (N)", title=name)
        a.legend(fontsize=6)
    a = ax[-1]
    rows = res["rows"]
    for j, kind in enumerate(("DACM", "load cell")):
        vals = [next(r["force_mse_N2"] for r in rows if r["sensor"] == n and r["reading"].startswith(kind)) for n in names]
        a.bar([i + 0.4 * j for i in range(len(names))], vals, 0.4, label=kind)
    a.set_xticks([i + 0.2 for i in range(len(names))], [n.replace("-as-cut", "") for n in names])
    a.set(ylabel="force MSE (N^2)", title="force-control error")
    a.legend(fontsize=7)
    return [_save(fig, out / "loop-sensor.png")]
