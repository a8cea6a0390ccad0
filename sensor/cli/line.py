"""``dacm line``: frequency and step response of the transmission-line models (chapters III, V).

Frequency response: p_end / p_in, the chamber pressure over the valve-port (inlet) pressure
for a small sinusoid about ``--pressure``, of each chosen model against the analytic
Bergh-Tijdeman solution of a tube ending in a volume (isothermal end volume):

* distributed, two-volume: the plant's own linearisation
  (:meth:`~sensor.pneumatic.plant.CompiledPlant.linear_line_model`, inlet pressure imposed,
  valve shut), evaluated as a sum of modes;
* dead-volume (eq 16): the line volume is merged with the chamber, which *is* the valve port,
  so p_end / p_in = 1 exactly (the linearisation returns this unity);
* richer-hurmuzlu (eqs 4-5): the chamber receives the valve flow delayed by L / c and scaled by
  A = exp(-R_t R T L / (2 P c)).  A lumped volume's pressure is proportional to the mass it
  received, so the chamber pressure is the inlet (valve-side) pressure delayed and scaled:
  p_end / p_in = A exp(-j w L / c), amplitude A, phase -360 f L / c degrees.  Small signals
  about rest have no mean flow, so R_t is the laminar 32 mu / D^2 of eq 5, P = ``--pressure``
  and c the adiabatic speed of sound (as the plant's delay).

Step response: the fixed-volume test of thesis Figures 5 and 7 - the valve (default Festo
preset) opens fully at t = 0 from a line and chamber at atmosphere to a supply at
``--pressure``, and reverses (vents) at T; T doubles from 50 ms until every chosen model's
chamber is stationary at the end of both halves (see :func:`step_test`).
"""

from __future__ import annotations

import argparse
import json
import math
from dataclasses import dataclass
from pathlib import Path

from sensor.errors import SensorInputError

MODELS = ("dead-volume", "richer-hurmuzlu", "two-volume", "distributed")
FREQUENCY_DECADES = 2.0      # the grid runs log-spaced from fmax / 100 to fmax
STEP_SAMPLES = 1000          # samples per step run (the control rate follows from its length)
SETTLE_FRACTION = 0.01       # chamber within 1 % of the pressure step counts as settled
FIRST_HALF_PERIOD_S = 0.05
MAX_HALF_PERIOD_S = 60.0
PEAK_PROMINENCE = 1e-3       # a resonance stands 0.1 % of the largest |H| above its surroundings


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
    p.add_argument("--out", type=Path, default=Path("dacm-out"), metavar="DIR",
                   help="folder for the plots (default ./dacm-out; created if missing)")
    p.add_argument("--no-plots", action="store_true", help="do not write the plots")
    p.add_argument("--json", action="store_true", help="print the results as JSON")
    p.set_defaults(func=run)


# --------------------------------------------------------------------------- input


@dataclass(frozen=True)
class LineCase:
    """Validated CLI input (SI units)."""

    length_m: float
    bore_m: float
    volume_m3: float
    pressure_Pa: float
    models: tuple[str, ...]
    fmax_Hz: float
    points: int


def _positive(flag: str, value, unit: str) -> float:
    if value is None or not (math.isfinite(value) and value > 0):
        raise SensorInputError(f"{flag} = {value!r}: must be a positive finite number ({unit})")
    return float(value)


def parse_models(values: list[str]) -> tuple[str, ...]:
    """Model names from repeated and comma-separated ``--model`` values (default: all, in order)."""
    names = [n.strip() for v in values for n in v.split(",") if n.strip()]
    for n in names:
        if n not in MODELS:
            raise SensorInputError(f"--model = {n!r}: must be one of {', '.join(MODELS)}")
    return tuple(dict.fromkeys(names)) or MODELS


def case_from_args(args: argparse.Namespace) -> LineCase:
    from sensor.pneumatic.air import AIR

    length = _positive("--length", args.length, "m")
    bore = _positive("--bore", args.bore, "m")
    volume = _positive("--volume", args.volume, "m^3")
    atm = AIR.atmosphere_Pa
    if not (math.isfinite(args.pressure) and args.pressure > atm):
        raise SensorInputError(f"--pressure = {args.pressure!r}: must be an absolute pressure above the "
                          f"atmosphere ({atm:g} Pa)")
    fmax = AIR.speed_of_sound / length if args.fmax is None else _positive("--fmax", args.fmax, "Hz")
    if args.points < 10:
        raise SensorInputError(f"--points = {args.points!r}: must be an integer >= 10")
    return LineCase(length, bore, volume, float(args.pressure), parse_models(args.model), fmax,
                    args.points)


# --------------------------------------------------------------------------- physics


@dataclass(frozen=True)
class Response:
    """p_end / p_in = rational(f) exp(-j 2 pi f delay_s): ``rational`` is a callable of Hz."""

    rational: object
    delay_s: float = 0.0

    def amplitude(self, frequency_Hz):
        """|p_end / p_in| (the delay has unit modulus and is left out exactly)."""
        import numpy as np

        return np.abs(self.rational(np.asarray(frequency_Hz, float)))

    def phase_deg(self, frequency_Hz):
        """Unwrapped phase (deg); the pure delay is added exactly, not unwrapped."""
        import numpy as np

        f = np.asarray(frequency_Hz, float)
        return np.degrees(np.unwrap(np.angle(self.rational(f)))) - 360.0 * f * self.delay_s


def richer_hurmuzlu_gain(mass_flow_kg_s: float, pressure_Pa: float, case: LineCase, air) -> float:
    """Eq 4 attenuation exp(-R_t R T L / (2 P c)) at a mass flow and chamber pressure P."""
    from sensor.pneumatic.lines import attenuation_factor

    return float(attenuation_factor(mass_flow_kg_s, case.length_m, case.bore_m, pressure_Pa, air))


def richer_hurmuzlu_response(case: LineCase, air) -> Response:
    """Small-signal p_end / p_in of eqs 4-5: zero mean flow (laminar R_t), delay L / c."""
    import numpy as np

    gain = richer_hurmuzlu_gain(0.0, case.pressure_Pa, case, air)
    return Response(lambda f: np.full(np.shape(f), gain, complex), case.length_m / air.speed_of_sound)


def fixed_volume_plant(model: str, case: LineCase):
    """The fixed-volume rig: both sides the same line into ``volume_m3``, supply ``pressure_Pa``."""
    from sensor.pneumatic.cylinder import FixedChambers
    from sensor.pneumatic.lines import make_line
    from sensor.pneumatic.plant import Plant

    line = make_line(model, case.length_m, case.bore_m)
    return Plant(supply_Pa=case.pressure_Pa, line_1=line, line_2=line,
                 actuator=FixedChambers(case.volume_m3, case.volume_m3)).compile()


def model_response(model: str, case: LineCase, plant) -> Response:
    """p_end / p_in of one model (module docstring says how each is obtained)."""
    if model == "richer-hurmuzlu":
        return richer_hurmuzlu_response(case, plant.plant.air)
    return Response(plant.linear_line_model(case.pressure_Pa))


def reference_response(case: LineCase, air) -> Response:
    """Bergh-Tijdeman with wall heat transfer and an isothermal end volume (the plant's chambers)."""
    from sensor.pneumatic.bergh_tijdeman import bergh_tijdeman

    return Response(lambda f: bergh_tijdeman(f, case.length_m, case.bore_m, case.volume_m3,
                                             case.pressure_Pa, air=air))


def first_resonance(response: Response, frequency_Hz) -> float | None:
    """Frequency (Hz) of the first peak of |H| on the grid standing PEAK_PROMINENCE of the largest
    |H| above its surroundings, refined by a bounded search between its neighbours; None if none."""
    from scipy.optimize import minimize_scalar
    from scipy.signal import find_peaks

    amp = response.amplitude(frequency_Hz)
    peaks = find_peaks(amp, prominence=PEAK_PROMINENCE * amp.max())[0]
    if peaks.size == 0:
        return None
    i = int(peaks[0])
    lo, hi = float(frequency_Hz[i - 1]), float(frequency_Hz[i + 1])
    res = minimize_scalar(lambda x: -response.amplitude([x])[0], bounds=(lo, hi),
                          method="bounded", options={"xatol": 1e-6 * hi})
    return float(res.x)


def step_test(plants: dict, case: LineCase) -> tuple[float, dict]:
    """(half period T, {model: dataset}) of the valve opened at 0 and reversed at T.

    T doubles from FIRST_HALF_PERIOD_S until the high-fidelity (distributed) line's chamber is
    stationary: over the last 10 % of each half it moves by less than SETTLE_FRACTION of the
    pressure step.  The distributed line sets the time because it is the physical reference; the
    reduced models need not settle (the Richer-Hurmuzlu chamber of a long line stalls, and with
    its delay it can keep a limit cycle, see :func:`step_metrics`)."""
    from sensor.pneumatic.sensors import ideal_sensors
    from sensor.pneumatic.simulate import simulate

    timing = plants.get("distributed") or fixed_volume_plant("distributed", case)
    tol = SETTLE_FRACTION * (case.pressure_Pa - timing.plant.air.atmosphere_Pa)
    half = FIRST_HALF_PERIOD_S

    def step(cp, half):
        return simulate(cp, lambda t, m: 1.0 if t < half else -1.0, 2.0 * half,
                        rate_Hz=STEP_SAMPLES / (2.0 * half), sensors=ideal_sensors())

    while not _stationary(ref := step(timing, half), half, tol):
        half *= 2.0
        if half > MAX_HALF_PERIOD_S:
            raise SensorInputError(f"step test: the chamber did not settle within {MAX_HALF_PERIOD_S:g} s "
                              f"(--length {case.length_m:g} m, --bore {case.bore_m:g} m, --volume "
                              f"{case.volume_m3:g} m^3): the line is too narrow or the volume too large")
    return half, {m: ref if cp is timing else step(cp, half) for m, cp in plants.items()}


def _stationary(ds, half: float, tol: float) -> bool:
    pc = ds.pressure_chamber.sel(side=1)
    at = [float(pc.sel(time=t, method="nearest")) for t in (0.9 * half, half, 1.9 * half, 2.0 * half)]
    return abs(at[1] - at[0]) <= tol and abs(at[3] - at[2]) <= tol


def _first_time(t, frac, level: float) -> float | None:
    import numpy as np

    hit = np.flatnonzero(frac >= level)
    return float(t[hit[0]]) if hit.size else None


def step_metrics(ds, half: float, supply: float, atm: float) -> dict:
    """Chamber pressurisation: share of the step reached at the reversal (%), 10 % delay and
    10-90 % rise time (s, None if not reached), overshoot and ripple (peak-to-peak over the last
    quarter of the charging half; % of the step) and the largest valve-chamber gap while charging
    (Pa)."""
    import numpy as np

    t = ds.time.values
    on = t <= half
    pc = ds.pressure_chamber.sel(side=1).values[on]
    pv = ds.pressure_valve.sel(side=1).values[on]
    frac = (pc - atm) / (supply - atm)
    t10, t90 = _first_time(t[on], frac, 0.1), _first_time(t[on], frac, 0.9)
    return {"reached_pct": float(100.0 * frac[-1]), "delay_10pct_s": t10,
            "rise_10_90_s": None if t90 is None else t90 - t10,
            "overshoot_pct": float(100.0 * max(0.0, frac.max() - 1.0)),
            "ripple_pct": float(100.0 * np.ptp(frac[t[on] >= 0.75 * half])),
            "max_valve_chamber_gap_Pa": float(np.max(np.abs(pv - pc)))}


# --------------------------------------------------------------------------- output


_COLOURS = {"dead-volume": "tab:orange", "richer-hurmuzlu": "tab:purple", "two-volume": "tab:green",
            "distributed": "tab:red"}


def _title(case: LineCase, cm3: str = "cm$^3$") -> str:
    return (f"L = {case.length_m:g} m, D = {case.bore_m * 1e3:g} mm, V = {case.volume_m3 * 1e6:g} {cm3}, "
            f"P = {case.pressure_Pa / 1e5:g} bar abs")


def plot_frequency(result: dict, case: LineCase, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from geometry.atomic import save_figure

    fig, (ax_a, ax_p) = plt.subplots(2, 1, figsize=(6.4, 5.6), sharex=True)
    ref = result["reference"]
    ax_a.plot(ref["frequency_hz"], ref["amplitude_ratio"], "k--", lw=2.2, label="Bergh-Tijdeman")
    ax_p.plot(ref["frequency_hz"], ref["phase_deg"], "k--", lw=2.2)
    for name, m in result["models"].items():
        ax_a.plot(m["frequency_hz"], m["amplitude_ratio"], color=_COLOURS[name], lw=1.3, label=name)
        ax_p.plot(m["frequency_hz"], m["phase_deg"], color=_COLOURS[name], lw=1.3)
    if ref["first_resonance_hz"] is not None:
        for ax in (ax_a, ax_p):
            ax.axvline(ref["first_resonance_hz"], color="0.6", ls=":", lw=1)
    ax_a.set(xscale="log", yscale="log", ylabel="|p_end / p_in|", title=_title(case))
    ax_p.set(xlabel="frequency (Hz)", ylabel="phase (deg)")
    ax_a.legend(fontsize=8)
    for ax in (ax_a, ax_p):
        ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    save_figure(fig, path, dpi=100)


def plot_step(step: dict, case: LineCase, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from geometry.atomic import save_figure

    fig, (ax_c, ax_v) = plt.subplots(2, 1, figsize=(6.4, 5.6), sharex=True)
    t = step["time_s"]
    for name, m in step["models"].items():
        ax_c.plot(t, [p / 1e5 for p in m["chamber_pressure_Pa"]], color=_COLOURS[name], label=name)
        ax_v.plot(t, [p / 1e5 for p in m["valve_pressure_Pa"]], color=_COLOURS[name])
    for ax in (ax_c, ax_v):
        ax.axvline(step["valve_reversal_s"], color="0.6", ls=":", lw=1)
        ax.grid(True, alpha=0.3)
    ax_c.set(ylabel="chamber P (bar abs)",
             title=f"fixed-volume step, valve {step['valve']}\n{_title(case)}")
    ax_v.set(xlabel="time (s)", ylabel="valve port P (bar abs)")
    ax_c.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, path, dpi=100)


def _series(response: Response, f) -> dict:
    return {"frequency_hz": f.tolist(), "amplitude_ratio": response.amplitude(f).tolist(),
            "phase_deg": response.phase_deg(f).tolist()}


def analyse(case: LineCase) -> dict:
    """Frequency responses, resonances, amplitude errors and the step test, as plain data."""
    import numpy as np

    f = np.logspace(math.log10(case.fmax_Hz) - FREQUENCY_DECADES, math.log10(case.fmax_Hz), case.points)
    plants = {m: fixed_volume_plant(m, case) for m in case.models}
    air = next(iter(plants.values())).plant.air
    ref = reference_response(case, air)
    f_ref = first_resonance(ref, f)
    band = f <= (0.8 * f_ref if f_ref is not None else f[-1])
    amp_ref = ref.amplitude(f)
    result = {
        "inputs": {"length_m": case.length_m, "bore_m": case.bore_m, "volume_m3": case.volume_m3,
                   "pressure_Pa": case.pressure_Pa},
        "reference": {"name": "bergh-tijdeman", **_series(ref, f), "first_resonance_hz": f_ref,
                      "peak_amplitude_ratio": float(amp_ref.max())},
        "models": {},
    }
    for model, cp in plants.items():
        h = model_response(model, case, cp)
        amp = h.amplitude(f)
        f_res = first_resonance(h, f)
        result["models"][model] = {
            **_series(h, f), "first_resonance_hz": f_res,
            "resonance_error_pct": None if f_res is None or f_ref is None else 100.0 * (f_res / f_ref - 1.0),
            "peak_amplitude_ratio": float(amp.max()),
            "max_amplitude_error_pct": float(100.0 * np.max(np.abs(amp[band] / amp_ref[band] - 1.0))),
        }
    half, runs = step_test(plants, case)
    any_run = next(iter(runs.values()))
    valve = next(iter(plants.values())).plant.valve
    full_flow = valve.mass_flow(1.0, case.pressure_Pa, air.atmosphere_Pa)
    result["step"] = {
        "valve": valve.name, "valve_reversal_s": half,
        "full_open_flow_kg_s": full_flow,
        "richer_hurmuzlu_attenuation_at_start": richer_hurmuzlu_gain(full_flow, air.atmosphere_Pa, case, air),
        "time_s": any_run.time.values.tolist(),
        "models": {m: {"valve_pressure_Pa": ds.pressure_valve.sel(side=1).values.tolist(),
                       "chamber_pressure_Pa": ds.pressure_chamber.sel(side=1).values.tolist(),
                       **step_metrics(ds, half, case.pressure_Pa, air.atmosphere_Pa)}
                   for m, ds in runs.items()},
    }
    return result


def _fmt(x, width: int, spec: str, suffix: str = "") -> str:
    """``x`` formatted by ``spec`` plus ``suffix``, or "-" for None, right-aligned in ``width``."""
    return f"{'-' if x is None else format(x, spec) + suffix:>{width}s}"


def run(args: argparse.Namespace) -> int:
    case = case_from_args(args)
    result = analyse(case)
    files = []
    if not args.no_plots:
        args.out.mkdir(parents=True, exist_ok=True)
        files = [args.out / "line-frequency-response.png", args.out / "line-step.png"]
        plot_frequency(result, case, files[0])
        plot_step(result["step"], case, files[1])
    result["files"] = [str(p) for p in files]
    if args.json:
        print(json.dumps(result))
        return 0
    ref = result["reference"]
    band = "0.8 f_res" if ref["first_resonance_hz"] is not None else "fmax"
    print(f"line: {_title(case, 'cm^3')}; frequencies "
          f"{result['reference']['frequency_hz'][0]:.4g}-{case.fmax_Hz:.4g} Hz")
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
          f"{'overshoot':>10s} {'ripple':>7s} {'max valve-chamber gap (kPa)':>28s}")
    for name, m in step["models"].items():
        ms = [None if m[k] is None else 1e3 * m[k] for k in ("delay_10pct_s", "rise_10_90_s")]
        print(f" {name:16s} {m['reached_pct']:7.1f}% {_fmt(ms[0], 15, '.1f')} {_fmt(ms[1], 17, '.1f')} "
              f"{m['overshoot_pct']:9.1f}% {m['ripple_pct']:6.1f}% "
              f"{m['max_valve_chamber_gap_Pa'] / 1e3:28.1f}")
    rh = step["models"].get("richer-hurmuzlu")
    if rh is not None and rh["reached_pct"] < 90.0:
        print(f" note: richer-hurmuzlu attenuates the fully open valve flow "
              f"({1e3 * step['full_open_flow_kg_s']:.2f} g/s, turbulent R_t of eq 5) into a chamber at "
              f"atmosphere by eq 4's factor {step['richer_hurmuzlu_attenuation_at_start']:.3g}: "
              "the chamber stalls")
    for p in files:
        print(f"wrote {p}")
    return 0
