"""``dacm sensor``: the datasheet of a design read by the fiber-mirror optics, with plots of
the intensity curve (like thesis Figure 62) and the calibration loop (Figures 43 and 45)."""

from __future__ import annotations

import argparse
import dataclasses

from sensor.cli.design_args import add_design_arguments, check_flags, design_from_args, flagged
from sensor.cli.output import add_output_arguments, claim, print_json, staged
from sensor.cli.parser import add_target_output_argument
from sensor.cli.progress import add_quiet_argument, busy
from sensor.validation import Number, require_finite

#: Rules of the numeric flags.
RULES = {"target_output": Number(0.0, 1000.0, lo_open=True, unit="mm"),
         "sample_rate": Number(0.0, 1e7, lo_open=True, unit="Hz"),
         "adc_bits": Number(1, 32, integer=True),
         "na": Number(0.0, 1.0, lo_open=True),
         "tolerance": Number(0.0, 100.0, lo_open=True, unit="% FS")}
ADC_VOLTS = Number(-1e3, 1e3, unit="V")
#: Readout field -> flag, for the one-line errors.
READOUT_FLAGS = {"sample_rate_Hz": "--sample-rate", "adc_bits": "--adc-bits", "adc_min_V": "--adc-range",
                 "adc_max_V": "--adc-range", "mode": "--readout", "model": "--optics-model"}


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "sensor", help="sensor datasheet of a design: range, sensitivity, resolution, "
                       "nonlinearity, hysteresis, cross-axis; intensity and calibration plots",
        description="Build the sensor model of a design (solved mirror force-travel curve, "
                    "strain-energy hysteresis law, fiber-mirror optics, noise at the sample "
                    "rate, ADC), simulate a loading-unloading calibration cycle and print the "
                    "datasheet. The gap at rest is the design's fiber_clearance_mm; full scale "
                    "is the force that moves the mirror --target-output mm towards the fiber. "
                    "Writes <name>-intensity.png and <name>-calibration.png to --out.")
    add_design_arguments(p)
    add_target_output_argument(p, "mirror travel at full scale, mm (default 1; below the fiber clearance)",
                               old="--full-scale", default=1.0)
    p.add_argument("--sample-rate", type=float, default=1000.0, metavar="HZ",
                   help="sample rate, Hz; noise bandwidth is half of it (default 1000)")
    p.add_argument("--adc-bits", type=int, default=16, metavar="N", help="ADC bits (default 16)")
    p.add_argument("--adc-range", type=float, nargs=2, default=(-10.0, 10.0),
                   metavar=("MIN_V", "MAX_V"), help="ADC input range, V (default -10 10)")
    p.add_argument("--na", type=float, metavar="NA",
                   help="fiber numerical aperture (default 0.5, see sensor.readout.optics)")
    p.add_argument("--optics-model", default="geometric", metavar="MODEL",
                   help="intensity model: geometric | gaussian (default geometric)")
    p.add_argument("--readout", default="ratio", metavar="KIND",
                   help="ratio (signal / reference photodiode) | direct (default ratio)")
    p.add_argument("--calibration", default="curve", metavar="KIND",
                   help="newtons from volts by the mean-branch curve | the least-squares "
                        "line, as the thesis (default curve)")
    p.add_argument("--tolerance", type=float, default=1.0, metavar="PCT",
                   help="nonlinearity tolerance of the working range shaded on the intensity "
                        "plot, %% FS (default 1)")
    add_output_arguments(p, "the plots")
    p.add_argument("--no-plots", action="store_true", help="do not write the plots")
    p.add_argument("--json", action="store_true", help="print the results as JSON")
    add_quiet_argument(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from geometry.atomic import save_figure
    from geometry.params import cut_note
    from geometry.checks import assert_feasible
    from sensor.errors import SensorInputError, UsageError
    from sensor.readout.datasheet import cross_axis, datasheet
    from sensor.readout.optics import OpticsSetup
    from sensor.readout.plots import calibration_figure, intensity_figure
    from sensor.readout.sensor_model import CALIBRATIONS, Readout, build_sensor

    check_flags(args, RULES)
    for v in args.adc_range:
        ADC_VOLTS.check("--adc-range", v, UsageError)
    design = design_from_args(args)
    if args.calibration not in CALIBRATIONS:
        raise UsageError(f"--calibration = {args.calibration!r}: must be one of "
                             f"{', '.join(CALIBRATIONS)}")
    files = [] if args.no_plots else claim(
        args, [f"{design.name}-intensity.png", f"{design.name}-calibration.png"])
    assert_feasible(design)
    optics = OpticsSetup() if args.na is None else OpticsSetup(numerical_aperture=args.na)
    try:
        readout = Readout(sample_rate_Hz=args.sample_rate, adc_bits=args.adc_bits,
                          adc_min_V=args.adc_range[0], adc_max_V=args.adc_range[1],
                          mode=args.readout, model=args.optics_model)
    except SensorInputError as exc:
        raise UsageError(flagged(str(exc), READOUT_FLAGS)) from None
    with busy(f"sensor {design.name}", args.quiet) as step:
        step("solving and calibrating")
        sensor = build_sensor(design, optics, readout, target_output_mm=args.target_output,
                              calibration=args.calibration)
        ds = datasheet(sensor, material=design.material.name)
        step("cross-axis")
        cross = cross_axis(design, sensor.input_travel_mm)
        values = {**dataclasses.asdict(ds), **{f"cross_axis {k}": v for k, v in dataclasses.asdict(cross).items()}}
        require_finite(f"datasheet of {design.name}", values)
        if files:
            step("plots")
            with staged(args) as stage:
                save_figure(intensity_figure(sensor, ds, args.tolerance), stage / files[0].name)
                save_figure(calibration_figure(sensor, ds), stage / files[1].name)
    if args.json:
        print_json({**dataclasses.asdict(ds), "cross_axis": dataclasses.asdict(cross), "kerf_mm": design.kerf_mm},
                   files)
        return 0
    rows = [
        ("range", f"0 - {ds.range_N:.3f} N  (mirror travel {ds.target_output_mm:g} mm, "
                  f"gap {ds.gap_max_mm:.2f} -> {ds.gap_min_mm:.2f} mm)"),
        ("output span", f"{ds.span_V:.4f} V"),
        ("sensitivity", f"{ds.sensitivity_mV_per_N:.2f} mV/N  (least-squares line)"),
        ("resolution", f"{ds.resolution_N * 1e3:.3f} mN RMS  (noise {ds.noise_rms_V * 1e6:.2f} uV "
                       f"RMS at {ds.sample_rate_Hz:g} S/s, ADC step {ds.adc_step_V * 1e6:.0f} uV)"),
        ("nonlinearity", f"{ds.nonlinearity_pct:.2f} % FS  (mean branch against the line)"),
        ("hysteresis", f"{ds.hysteresis_pct:.2f} % FS  (eq 87 on volts; mechanical H "
                       f"{ds.hysteresis_mechanical_pct:.2f} % from SE {ds.strain_energy_mJ:.3f} mJ)"),
        ("quality", f"{ds.quality_mV_per_N:.0f} mV/N per unit hysteresis"),
        ("cross-axis", f"{cross.ratio_pct:.3f} %  (mirror travel for {cross.imposed_travel_mm:.3f} mm "
                       f"lateral vs axial input travel; tilt {cross.tilt_deg:+.2f} deg; "
                       "thesis 1.66 % delrin)"),
    ]
    print(f"{design.name} ({design.material.name}, {cut_note(design.kerf_mm)})")
    for k, v in rows:
        print(f"  {k:<14} {v}")
    for f in files:
        print(f"wrote {f}")
    return 0
