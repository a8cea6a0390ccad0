"""``dacm measure``: a measured loading-unloading loop beside the model of its design."""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

from sensor.cli.design_args import add_design_arguments, design_from_args, input_file
from sensor.cli.output import add_output_arguments, claim, print_json, staged

COLUMNS = ("force,displacement", "force,volts")


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "measure", help="measured loop in: hysteresis (eq 87), sensitivity, nonlinearity vs model",
        description="Read a measured loading-unloading loop (CSV: force in N, then the mirror "
                    "travel in mm or the sensor's volts; a header row is optional) and state its "
                    "eq 87 hysteresis, sensitivity and nonlinearity beside the model of the "
                    "design at the same largest force. --calibrate fits E (from a "
                    "force,displacement loop) and the strain-energy law's constant, and writes "
                    "the design with the fitted material to OUT/<name>-calibrated.toml, which "
                    "every command reads with --config.")
    p.add_argument("loop", type=Path, metavar="LOOP.csv", help="the measured loop")
    add_design_arguments(p)
    p.add_argument("--columns", default=COLUMNS[0], metavar="SPEC",
                   help=f"what the two columns hold: {' | '.join(COLUMNS)} (default {COLUMNS[0]})")
    p.add_argument("--calibrate", action="store_true",
                   help="fit E and the strain-energy law; write OUT/<name>-calibrated.toml")
    add_output_arguments(p, "the calibrated design <name>-calibrated.toml")
    p.add_argument("--json", action="store_true", help="print the results as JSON")
    p.set_defaults(func=run)


def unit_named(figures) -> dict:
    """A loop's figures for JSON, the response unit (mm or V) in the key names."""
    u = figures.unit
    return {"kind": figures.kind, "max_force_N": figures.max_force_N, f"span_{u}": figures.span,
            "hysteresis": figures.hysteresis, f"sensitivity_{u}_per_N": figures.sensitivity,
            "nonlinearity_pct": figures.nonlinearity_pct}


def run(args: argparse.Namespace) -> int:
    from geometry.params import save_design
    from sensor.errors import SolverError, UsageError
    from sensor.mechanics.hysteresis import DEFAULT_LAW
    from sensor.readout.measured import fit_law, fit_modulus, loop_figures, model_loop, read_loop_csv

    if args.columns not in COLUMNS:
        raise UsageError(f"--columns = {args.columns!r}: must be one of {', '.join(COLUMNS)}")
    kind = args.columns.split(",")[1]
    if args.calibrate and kind != "displacement":
        raise UsageError("--calibrate needs --columns force,displacement (volts also depend "
                         "on the optics)")
    design = design_from_args(args)
    path = claim(args, [f"{design.name}-calibrated.toml"])[0] if args.calibrate else None
    loop = read_loop_csv(input_file("LOOP.csv", args.loop), kind)
    measured = loop_figures(loop)
    try:
        model = loop_figures(model_loop(design, kind, measured.max_force_N, DEFAULT_LAW))
    except SolverError as exc:
        raise UsageError(f"{args.loop}: the model of {design.name} cannot be loaded to the "
                         f"loop's largest force {measured.max_force_N:g} N ({exc})") from None
    out = {"design": design.name, "loop": str(args.loop), "measured": unit_named(measured),
           "model": unit_named(model), "calibration": None}
    if args.calibrate:
        fit = fit_modulus(loop, design)
        law = fit_law(loop, fit.strain_energy_mJ)
        calibrated = design.replace(material=dataclasses.replace(design.material, E_MPa=fit.E_MPa),
                                    name=f"{design.name}-calibrated")
        with staged(args) as stage:
            save_design(calibrated, stage / path.name)
        out["calibration"] = {**dataclasses.asdict(fit), "h_per_mJ": law.h_per_mJ,
                              "h_per_mJ_default": DEFAULT_LAW.h_per_mJ}
    if args.json:
        print_json(out, [path] if out["calibration"] else [])
        return 0
    u = measured.unit
    print(f"{args.loop} ({kind}) against {design.name}, 0 -> {measured.max_force_N:.4g} N")
    print(f"  {'':<16}{'measured':>12}{'model':>12}")
    for label, key, scale, fmt in (("sensitivity", "sensitivity", 1.0, f"{{:12.4g}} {u}/N"),
                                   ("hysteresis", "hysteresis", 100.0, "{:12.3f} % (eq 87)"),
                                   ("nonlinearity", "nonlinearity_pct", 1.0, "{:12.3f} %"),
                                   ("span", "span", 1.0, f"{{:12.4g}} {u}")):
        m, p = getattr(measured, key) * scale, getattr(model, key) * scale
        print(f"  {label:<16}{m:12.4g}" + fmt.format(p))
    if out["calibration"]:
        c = out["calibration"]
        print(f"  fitted E = {c['E_MPa']:.0f} MPa (model {c['E_model_MPa']:.0f} MPa; RMS residual "
              f"{c['rms_residual_N'] * 1e3:.2f} mN); law H = {c['h_per_mJ']:.4f} x SE per mJ "
              f"(default {c['h_per_mJ_default']:.4f})")
        print(f"wrote {path}")
    return 0
