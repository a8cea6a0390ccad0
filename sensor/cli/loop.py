"""``dacm loop``: one closed-loop experiment of the tele-operated pneumatic actuator (observer,
controller, optional DACM force sensor), or a whole study of thesis chapters IV-V."""

from __future__ import annotations

import json
import math
import sys
import warnings
from pathlib import Path

from sensor.cli.output import add_output_arguments, claim, make_out_dir, print_json
from sensor.cli.progress import counting
from sensor.errors import SensorInputError

STUDIES = ("observer", "controllers", "plant-physics", "sensor")
MAX_DURATION_S = 3600.0   # simulated time of one run; the stored samples are bounded again by simulate


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "loop", help="closed-loop pneumatic force control with the force-feedback pressure observer "
                     "(chapters IV-V), optionally read by a DACM sensor",
        description="Simulate the valve, the transmission lines (distributed, high fidelity), the "
                    "cylinder against a spring, the pressure observer and a force controller at 1 kHz, "
                    "everything starting from the atmosphere. Prints the force-control MSE and the "
                    "pressure-estimation MSE of eq 44 over the steady window (the last whole cycles "
                    "covering 2 s; 2 s from a step) and whether the run had settled there, and writes "
                    "loop.png to --out. --study runs a whole chapter's grid and writes its tables, "
                    "verdicts and figures.")
    p.add_argument("--line-length", type=float, default=7.25, metavar="M", help="line length, m (default 7.25)")
    p.add_argument("--reference", default="sine:1Hz", metavar="REF",
                   help="desired force: sine:<f>Hz | square:<f>Hz | step (default sine:1Hz); for "
                        "impedance it moves z_d so that k_d z~ has this shape")
    p.add_argument("--amplitude", type=float, default=None, metavar="N",
                   help="reference amplitude, N (default 24; with --sensor 35 %% of its range)")
    p.add_argument("--offset", type=float, default=None, metavar="N",
                   help="reference offset, N (default 0; with --sensor 50 %% of its range)")
    p.add_argument("--controller", default="pi", metavar="NAME",
                   help="pi | impedance | smc | line-model (eqs 70, 72 as written) | line-model-damped "
                        "(with our line-flow damping k_m) (default pi)")
    p.add_argument("--observer", default="force", metavar="NAME",
                   help="force (eqs 19-24) | standard (k = 0) | valve (valve-port pressures) (default force)")
    p.add_argument("--valve", default=None, metavar="NAME",
                   help="festo-mpye-5-1/8-lf | enfield-lh05 (default: Festo for pi/impedance, Enfield for "
                        "smc/line-model, as the thesis)")
    p.add_argument("--sensor", default=None, metavar="PRESET|TOML",
                   help="DACM force sensor (a preset such as sample-a-as-cut, or a design .toml) instead of "
                        "the load cell; the environment then is a push-only 2 kN/m spring in series with it")
    p.add_argument("--segments", type=int, default=20, metavar="N", help="segments per line (default 20)")
    p.add_argument("--duration", type=float, default=None, metavar="S",
                   help="simulated time, s (default 30 s or 25 periods, whichever is longer: long enough to settle)")
    p.add_argument("--stiction", type=float, default=0.0, metavar="N",
                   help="static friction F_s of the piston, N, with the Stribeck curve (default 0; the thesis "
                        "measured 0.25 N)")
    p.add_argument("--coulomb", type=float, default=None, metavar="N",
                   help="sliding (Coulomb) friction F_c of the piston, N (default 0.05)")
    p.add_argument("--spool-bandwidth", type=float, default=math.inf, metavar="HZ",
                   help="first-order spool bandwidth of the valve, Hz (default: ideal spool, as the thesis)")
    p.add_argument("--energy", action="store_true",
                   help="chamber energy equation with wall heat transfer instead of isothermal eq 15")
    p.add_argument("--study", default=None, metavar="NAME",
                   help="observer | controllers | plant-physics | sensor: run a whole study")
    add_output_arguments(p, "plots and tables")
    p.add_argument("--no-plots", action="store_true", help="do not write plots")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--json", action="store_true", help="print the results as JSON")
    p.set_defaults(func=run)


def _setup(args):
    from sensor.pneumatic.experiment import setup_from_flags

    return setup_from_flags(args.controller, args.observer, args.reference, args.amplitude, args.offset,
                            args.line_length, args.segments, args.valve, args.sensor, args.duration,
                            physics_from_flags(args))


def physics_from_flags(args) -> dict:
    from sensor.pneumatic.experiment import physics_from_flags as physics

    return physics(args.stiction, args.coulomb, args.spool_bandwidth, args.energy)


def run(args) -> int:
    from sensor.errors import CapacityWarning

    if args.study is not None and args.study not in STUDIES:
        raise SensorInputError(f"--study {args.study!r}: must be one of {', '.join(STUDIES)}")
    from sensor.pneumatic.lines import MAX_SEGMENTS

    if not 1 <= args.segments <= MAX_SEGMENTS:
        raise SensorInputError(f"--segments {args.segments!r}: must be an integer in [1, {MAX_SEGMENTS}]")
    if args.duration is not None and not (math.isfinite(args.duration) and 0 < args.duration <= MAX_DURATION_S):
        raise SensorInputError(f"--duration {args.duration!r}: must be a positive finite number <= "
                               f"{MAX_DURATION_S:g} (s)")
    physics = physics_from_flags(args)
    if args.study and (physics["stiction_N"] or args.coulomb is not None or physics["energy"]
                       or math.isfinite(physics["spool_bandwidth_Hz"])):
        raise SensorInputError("--stiction, --coulomb, --spool-bandwidth and --energy: apply to a single run, not "
                               "to --study (--study plant-physics varies them itself)")
    if not args.no_plots or args.study:
        names = ([f"loop-{args.study}.md", *(p.name for p in args.out.glob(f"loop-{args.study}*.png"))]
                 if args.study else ["loop.png"])
        claim(args, names)
        make_out_dir(args.out)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", CapacityWarning)
        result = _run_study(args) if args.study else _run_one(args)
    for w in caught:
        if issubclass(w.category, CapacityWarning):
            print(f"dacm loop: warning: {w.message}", file=sys.stderr)
    if args.json:
        files = result.pop("files", None) or ([result.pop("plot")] if "plot" in result else [])
        print_json(result, files)
    return 0


def _run_one(args) -> dict:
    from geometry.atomic import save_figure
    from sensor.pneumatic.plots import loop_figure
    from sensor.pneumatic.experiment import measure
    from sensor.pneumatic.experiment import run as run_experiment

    setup, notes = _setup(args)
    for note in notes:
        print(f"dacm loop: {note}", file=sys.stderr)
    with counting("loop", args.quiet) as bar:
        ds = run_experiment(setup, progress=lambda k, n: bar(k, n, "control periods"))
    m = measure(setup, ds)
    result = {"controller": setup.controller, "observer": setup.observer, "reference": setup.reference,
              "amplitude_N": setup.amplitude_N, "offset_N": setup.offset_N, "line_length_m": setup.line_length_m,
              "valve": setup.valve, "sensor": args.sensor or "load cell", "duration_s": setup.duration_s,
              "stiction_N": setup.stiction_N, "coulomb_N": setup.coulomb_N,
              "spool_bandwidth_Hz": None if math.isinf(setup.spool_bandwidth_Hz) else setup.spool_bandwidth_Hz,
              "energy": setup.energy,
              "gains": json.loads(ds.attrs["gains"]), **m}
    if not args.no_plots:
        result["plot"] = str(save_figure(loop_figure(ds, setup), args.out / "loop.png"))
    if not args.json:
        print(f"{setup.controller} control, {setup.observer} observer, {setup.reference} ({setup.amplitude_N:.3g} N "
              f"about {setup.offset_N:.3g} N), {setup.line_length_m:g} m lines, {setup.valve}, sensor: {result['sensor']}")
        if result["gains"]:
            print("  gains (section 5.4.2, from the line): " + ", ".join(f"{k} {v:.4g}" for k, v in result["gains"].items()))
        print(f"  force-control MSE         {m['force_mse_N2']:10.3f} N^2   (window {m['window_s'][0]:.2f}-"
              f"{m['window_s'][1]:.2f} s, {_status_line(m)})")
        print(f"  pressure MSE (eq 44)      {m['pressure_mse_kPa2']:10.2f} kPa^2 ({setup.observer} estimate)")
        print(f"  valve-port pressure MSE   {m['valve_pressure_mse_kPa2']:10.2f} kPa^2")
        if "virtual_input_mse_N2" in m:
            print(f"  virtual-input MSE_2       {m['virtual_input_mse_N2']:10.3f} N^2")
            print(f"  line-model pressure MSE   {m['line_model_pressure_mse_kPa2']:10.2f} kPa^2")
        if "plot" in result:
            print(f"  wrote {result['plot']}")
    return result


def _status_line(m: dict) -> str:
    """The run's status for the console: settled, the limit cycle with its frequency and
    amplitude, or unsettled with the advice."""
    if m["limit_cycle"]:
        return f"limit cycle at {m['limit_cycle_hz']:.3g} Hz, amplitude {m['limit_cycle_amplitude_N']:.3g} N"
    if m.get("settled_by") == "noise_free_twin":
        return f"settled by its noise-free twin, its own blocks {100 * m['noise_block_change']:.0f} % apart"
    return "settled" if m["settled"] else "NOT settled, run longer"


def _run_study(args) -> dict:
    from geometry.atomic import atomic_path
    from sensor.pneumatic.loop_metrics import SETTLING_RULE
    from sensor.pneumatic.study_report import run_study

    kw = {"segments": args.segments, **({} if args.duration is None else {"duration_s": args.duration})}
    with counting(f"loop --study {args.study}", args.quiet) as progress:
        res, text, out, figs = run_study(args.study, progress, **kw)
    out["settling_rule"] = SETTLING_RULE
    md = args.out / f"loop-{args.study}.md"
    with atomic_path(md) as tmp:
        Path(tmp).write_text(text)
    out["files"] = [str(md)] + ([] if args.no_plots else _write_figures(res, figs, args.out))
    if not args.json:
        print(text)
        print("wrote " + ", ".join(out["files"]))
    return out


def _write_figures(res, figs: dict, out: Path) -> list[str]:
    from geometry.atomic import save_figure

    written = []
    for name, make in figs.items():
        fig = make(res)
        if fig is not None:
            written.append(str(save_figure(fig, out / name)))
    return written
