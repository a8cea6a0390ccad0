"""``dacm line``: frequency and step response of the transmission-line models (chapters III, V).

Argument parsing, printing and file names only; the analysis is
:mod:`sensor.pneumatic.line_response`, the figures :mod:`sensor.pneumatic.line_plots`.
"""

from __future__ import annotations

import argparse
import math

from sensor.cli.output import add_output_arguments, claim, print_json, staged
from sensor.cli.progress import add_quiet_argument, busy
from sensor.errors import SensorInputError
from sensor.pneumatic.lines import LINE_MODELS

MODELS = tuple(LINE_MODELS)


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "line", help="frequency and step response of the pneumatic line models vs Bergh-Tijdeman",
        description="Frequency response (amplitude ratio and phase of end over inlet pressure) of "
                    "the chosen transmission-line models against the analytic Bergh-Tijdeman "
                    "solution of a tube ending in a volume, and the step response of the "
                    "fixed-volume test (valve opened into line + volume, valve and chamber "
                    "pressures vs time). Writes line-frequency-response.png and line-step.png "
                    "to --out.")
    p.add_argument("--length", type=float, required=True, metavar="M", help="line length, m")
    p.add_argument("--bore", type=float, required=True, metavar="M", help="line inner diameter, m")
    p.add_argument("--volume", type=float, required=True, metavar="M3",
                   help="end (chamber) volume, m^3")
    p.add_argument("--pressure", type=float, required=True, metavar="PA",
                   help="absolute pressure, Pa, above the atmosphere (101325): mean pressure of "
                        "the frequency response and supply pressure of the step")
    p.add_argument("--model", action="append", default=[], metavar="NAME",
                   help=f"line model, repeatable or comma-separated: {' | '.join(MODELS)} "
                        "(default: all)")
    p.add_argument("--fmax", type=float, metavar="HZ",
                   help="highest frequency, Hz (default c / L); the grid starts at fmax / 100")
    p.add_argument("--points", type=int, default=400, metavar="N",
                   help="log-spaced frequencies (default 400)")
    add_output_arguments(p, "the plots")
    add_quiet_argument(p)
    p.add_argument("--no-plots", action="store_true", help="do not write the plots")
    p.add_argument("--json", action="store_true", help="print the results as JSON")
    p.set_defaults(func=run)


def _positive(flag: str, value, unit: str, top: float) -> float:
    if value is None or not (math.isfinite(value) and 0 < value <= top):
        raise SensorInputError(f"{flag} = {value!r}: must be a positive finite number <= {top:g} ({unit})")
    return float(value)


def parse_models(values: list[str]) -> tuple[str, ...]:
    """Model names from repeated and comma-separated ``--model`` values (default: all, in order)."""
    names = [n.strip() for v in values for n in v.split(",") if n.strip()]
    for n in names:
        if n not in MODELS:
            raise SensorInputError(f"--model = {n!r}: must be one of {', '.join(MODELS)}")
    return tuple(dict.fromkeys(names)) or MODELS


def case_from_args(args: argparse.Namespace):
    from sensor.pneumatic.air import AIR
    from sensor.pneumatic.line_response import LIMITS, MAX_FMAX_HZ, MAX_POINTS, LineCase

    length = _positive("--length", args.length, "m", LIMITS["length_m"])
    bore = _positive("--bore", args.bore, "m", LIMITS["bore_m"])
    volume = _positive("--volume", args.volume, "m^3", LIMITS["volume_m3"])
    atm, top = AIR.atmosphere_Pa, LIMITS["pressure_Pa"]
    if not (math.isfinite(args.pressure) and atm < args.pressure <= top):
        raise SensorInputError(f"--pressure = {args.pressure!r}: must be an absolute pressure above the "
                               f"atmosphere ({atm:g} Pa) and <= {top:g} Pa")
    fmax = 0.0 if args.fmax is None else _positive("--fmax", args.fmax, "Hz", MAX_FMAX_HZ)
    if not 10 <= args.points <= MAX_POINTS:
        raise SensorInputError(f"--points = {args.points!r}: must be an integer in [10, {MAX_POINTS}]")
    return LineCase(length, bore, volume, float(args.pressure), parse_models(args.model), fmax, args.points)


def _fmt(x, width: int, spec: str, suffix: str = "") -> str:
    """``x`` formatted by ``spec`` plus ``suffix``, or "-" for None, right-aligned in ``width``."""
    return f"{'-' if x is None else format(x, spec) + suffix:>{width}s}"

def run(args: argparse.Namespace) -> int:
    from sensor.pneumatic.line_plots import case_title
    from sensor.pneumatic.line_response import analyse

    case = case_from_args(args)
    files = [] if args.no_plots else claim(args, ["line-frequency-response.png", "line-step.png"])
    with busy(f"line {case.length_m:g} m: {len(case.models)} models", args.quiet):
        result = analyse(case)
    if not args.no_plots:
        from geometry.atomic import save_figure
        from sensor.pneumatic.line_plots import frequency_figure, step_figure

        with staged(args) as stage:
            save_figure(frequency_figure(result), stage / files[0].name, dpi=100)
            save_figure(step_figure(result), stage / files[1].name, dpi=100)
    result["files"] = [str(p) for p in files]
    if args.json:
        print_json(result, result["files"])
        return 0
    ref = result["reference"]
    band = "0.8 f_res" if ref["first_resonance_hz"] is not None else "fmax"
    print(f"line: {case_title(result['inputs'], 'cm^3')}; frequencies "
          f"{ref['frequency_hz'][0]:.4g}-{result['inputs']['fmax_Hz']:.4g} Hz")
    print(f"\nfrequency response p_end / p_in  (amplitude error against Bergh-Tijdeman up to {band})")
    print(f" {'model':16s} {'1st resonance (Hz)':>18s} {'vs B-T':>8s} {'peak |H|':>9s} "
          f"{'max |H| error':>14s}")
    print(f" {'bergh-tijdeman':16s} {_fmt(ref['first_resonance_hz'], 18, '.3f')} "
          f"{'':>8s} {ref['peak_amplitude_ratio']:9.3f}")
    for name, m in result["models"].items():
        print(f" {name:16s} {_fmt(m['first_resonance_hz'], 18, '.3f')} "
              f"{_fmt(m['resonance_error_pct'], 8, '+.1f', '%')} {m['peak_amplitude_ratio']:9.3f} "
              f"{m['max_amplitude_error_pct']:13.1f}%")
    step = result["step"]
    print(f"\nstep test: valve {step['valve']} opened at 0 s (atmosphere -> {case.pressure_Pa:g} Pa), "
          f"reversed at {step['valve_reversal_s']:g} s")
    print(f" {'model':16s} {'reached':>8s} {'delay 10% (ms)':>15s} {'rise 10-90% (ms)':>17s} "
          f"{'overshoot':>10s} {'ripple':>7s} {'max valve-chamber gap (kPa)':>28s} {'max Mach':>9s} "
          f"{'exit Mach':>9s} {'choked':>6s}")
    for name, m in step["models"].items():
        ms = [None if m[k] is None else 1e3 * m[k] for k in ("delay_10pct_s", "rise_10_90_s")]
        print(f" {name:16s} {m['reached_pct']:7.1f}% {_fmt(ms[0], 15, '.1f')} {_fmt(ms[1], 17, '.1f')} "
              f"{m['overshoot_pct']:9.1f}% {m['ripple_pct']:6.1f}% "
              f"{m['max_valve_chamber_gap_Pa'] / 1e3:28.1f} {m['max_mach']:9.3f} {m['max_exit_mach']:9.3f} "
              f"{'yes' if m['choked'] else 'no':>6s}")
    rh = step["models"].get("richer-hurmuzlu")
    if rh is not None and rh["reached_pct"] < 90.0:
        print(f" note: richer-hurmuzlu attenuates the fully open valve flow "
              f"({1e3 * step['full_open_flow_kg_s']:.2f} g/s, turbulent R_t of eq 5) into a chamber at "
              f"atmosphere by eq 4's factor {step['richer_hurmuzlu_attenuation_at_start']:.3g}: "
              "the chamber stalls")
    dis = result.get("discharge")
    if dis is not None:
        iso, fan = dis["references"]["isothermal"], dis["references"]["fanno"]
        print(f"\nsteady discharge (distributed line, port node {dis['stagnation_pressure_Pa'] / 1e5:.4g} bar -> "
              f"{dis['back_pressure_Pa'] / 1e5:.4g} bar): {1e3 * dis['mass_flow_kg_s']:.4g} g/s, exit Mach "
              f"{dis['exit_mach']:.3f}, {'choked' if dis['choked'] else 'not choked'}, largest element Mach "
              f"{dis['max_mach']:.3f}")
        print(f" isothermal with friction (isentropic entrance) {1e3 * iso['mass_flow_kg_s']:.4g} g/s "
              f"({iso['deviation_pct']:+.1f} %), Fanno (adiabatic) {1e3 * fan['mass_flow_kg_s']:.4g} g/s "
              f"({fan['deviation_pct']:+.1f} %)")
    for p in files:
        print(f"wrote {p}")
    return 0