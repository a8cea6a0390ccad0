"""Frequency and step response of the transmission-line models (chapters III, V), as plain data.

Frequency response: p_end / p_in, the chamber pressure over the valve-port (inlet) pressure
for a small sinusoid about ``pressure_Pa``, of each chosen model against the analytic
Bergh-Tijdeman solution of a tube ending in a volume (isothermal end volume):

* distributed, two-volume, preliminary: the plant's own linearisation
  (:meth:`~sensor.pneumatic.plant.CompiledPlant.linear_line_model`, inlet pressure imposed,
  valve shut), evaluated as a sum of modes;
* dead-volume (eq 16): the line volume is merged with the chamber, which *is* the valve port,
  so p_end / p_in = 1 exactly (the linearisation returns this unity);
* richer-hurmuzlu (eqs 4-5): the chamber receives the valve flow delayed by L / c and scaled by
  A = exp(-R_t R T L / (2 P c)).  A lumped volume's pressure is proportional to the mass it
  received, so the chamber pressure is the inlet (valve-side) pressure delayed and scaled:
  p_end / p_in = A exp(-j w L / c), amplitude A, phase -360 f L / c degrees.  Small signals
  about rest have no mean flow, so R_t is the laminar 32 mu / D^2 of eq 5, P = ``pressure_Pa``
  and c the adiabatic speed of sound (as the plant's delay).

Step response: the fixed-volume test of thesis Figures 5 and 7 - the valve (default Festo
preset) opens fully at t = 0 from a line and chamber at atmosphere to a supply at
``pressure_Pa``, and reverses (vents) at T; T doubles from 50 ms until the distributed line's
chamber is stationary at the end of both halves (see :func:`step_test`).

Steady discharge (choking you can see): the distributed line fed at its inlet by a valve
DISCHARGE_VALVE_SCALE times the Festo preset, fully open from a supply at ``pressure_Pa``, into the
atmosphere (a 10 m^3 chamber), run until its flow is steady (:func:`discharge_test`): the steady
mass flow, the exit-face Mach, whether it chokes and the largest element Mach, beside the
analytic isothermal and Fanno flows from the port node's pressure as stagnation pressure
(:mod:`.choked_flow`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar
from scipy.signal import find_peaks

from sensor.errors import SensorInputError, SolverError
from sensor.pneumatic.bergh_tijdeman import bergh_tijdeman
from sensor.pneumatic.choked_flow import fanno_flow, isothermal_flow
from sensor.pneumatic.cylinder import FixedChambers
from sensor.pneumatic._kernel import MAX_PRESSURE_PA
from sensor.pneumatic.lines import LINE_MODELS, MAX_BORE_M, MAX_LENGTH_M, attenuation_factor, make_line
from sensor.pneumatic.plant import Plant
from sensor.pneumatic.sensors import ideal_sensors
from sensor.pneumatic.simulate import constant_command, simulate
from sensor.pneumatic.valve import FESTO_MPYE, Valve

FREQUENCY_DECADES = 2.0      # the grid runs log-spaced from fmax / 100 to fmax
STEP_SAMPLES = 1000          # samples per step run (the control rate follows from its length)
SETTLE_FRACTION = 0.01       # chamber within 1 % of the pressure step counts as settled
FIRST_HALF_PERIOD_S = 0.05
MAX_HALF_PERIOD_S = 60.0
PEAK_PROMINENCE = 1e-3       # a resonance stands 0.1 % of the largest |H| above its surroundings
MAX_POINTS = 100_000         # frequency points (each costs every model's modal sum)
MAX_VOLUME_M3 = 1.0
MAX_FMAX_HZ = 1e6            # far above the acoustic modes of any line the models describe
DISCHARGE_VALVE_SCALE = 20.0  # the discharge test's inlet valve / the Festo preset (conductance)
DISCHARGE_VOLUME_M3 = 10.0    # the atmosphere the line discharges into (its pressure rises < 0.1 %)
DISCHARGE_STEADY = 1e-3       # flow steady: the last 10 % of the run within 0.1 % of its end value
FIRST_DISCHARGE_S = 0.2


LIMITS = {"length_m": MAX_LENGTH_M, "bore_m": MAX_BORE_M, "volume_m3": MAX_VOLUME_M3,
          "pressure_Pa": MAX_PRESSURE_PA}
"""Upper bound of each dimension of a :class:`LineCase` (SI units)."""


@dataclass(frozen=True)
class LineCase:
    """One line into a fixed end volume (SI units): the input of :func:`analyse`."""

    length_m: float
    bore_m: float
    volume_m3: float
    pressure_Pa: float
    models: tuple[str, ...] = tuple(LINE_MODELS)
    fmax_Hz: float = 0.0        # 0: c / L
    points: int = 400

    def __post_init__(self) -> None:
        for name, top in LIMITS.items():
            value = getattr(self, name)
            if not (math.isfinite(value) and 0 < value <= top):
                raise SensorInputError(f"line case {name} = {value!r}: must be a positive finite number <= {top:g}")
        for m in self.models:
            if m not in LINE_MODELS:
                raise SensorInputError(f"line case model = {m!r}: must be one of {', '.join(LINE_MODELS)}")
        if not (math.isfinite(self.fmax_Hz) and 0 <= self.fmax_Hz <= MAX_FMAX_HZ):
            raise SensorInputError(f"line case fmax_Hz = {self.fmax_Hz!r}: must be a finite number in "
                                   f"[0, {MAX_FMAX_HZ:g}]")
        if not (isinstance(self.points, (int, np.integer)) and 10 <= self.points <= MAX_POINTS):
            raise SensorInputError(f"line case points = {self.points!r}: must be an integer in [10, {MAX_POINTS}]")

@dataclass(frozen=True)
class Response:
    """p_end / p_in = rational(f) exp(-j 2 pi f delay_s): ``rational`` is a callable of Hz."""

    rational: object
    delay_s: float = 0.0

    def amplitude(self, frequency_Hz):
        """|p_end / p_in| (the delay has unit modulus and is left out exactly)."""
        return np.abs(self.rational(np.asarray(frequency_Hz, float)))

    def phase_deg(self, frequency_Hz):
        """Unwrapped phase (deg); the pure delay is added exactly, not unwrapped."""
        f = np.asarray(frequency_Hz, float)
        return np.degrees(np.unwrap(np.angle(self.rational(f)))) - 360.0 * f * self.delay_s


def richer_hurmuzlu_gain(mass_flow_kg_s: float, pressure_Pa: float, case: LineCase, air) -> float:
    """Eq 4 attenuation exp(-R_t R T L / (2 P c)) at a mass flow and chamber pressure P."""
    return float(attenuation_factor(mass_flow_kg_s, case.length_m, case.bore_m, pressure_Pa, air))


def richer_hurmuzlu_response(case: LineCase, air) -> Response:
    """Small-signal p_end / p_in of eqs 4-5: zero mean flow (laminar R_t), delay L / c."""
    gain = richer_hurmuzlu_gain(0.0, case.pressure_Pa, case, air)
    return Response(lambda f: np.full(np.shape(f), gain, complex), case.length_m / air.speed_of_sound)


def fixed_volume_plant(model: str, case: LineCase):
    """The fixed-volume rig: both sides the same line into ``volume_m3``, supply ``pressure_Pa``."""
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
    return Response(lambda f: bergh_tijdeman(f, case.length_m, case.bore_m, case.volume_m3,
                                             case.pressure_Pa, air=air))


def first_resonance(response: Response, frequency_Hz) -> float | None:
    """Frequency (Hz) of the first peak of |H| on the grid standing PEAK_PROMINENCE of the largest
    |H| above its surroundings, refined by a bounded search between its neighbours; None if none."""
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
    hit = np.flatnonzero(frac >= level)
    return float(t[hit[0]]) if hit.size else None


def step_metrics(ds, half: float, supply: float, atm: float) -> dict:
    """Chamber pressurisation: share of the step reached at the reversal (%), 10 % delay and
    10-90 % rise time (s, None if not reached), overshoot and ripple (peak-to-peak over the last
    quarter of the charging half; % of the step), the largest valve-chamber gap while charging
    (Pa), and over the whole test the largest mean Mach number of the line's flow elements
    (``max_mach``), the largest exit-face Mach and whether an end face choked (0 and false for
    models without flow elements)."""
    t = ds.time.values
    on = t <= half
    pc = ds.pressure_chamber.sel(side=1).values[on]
    pv = ds.pressure_valve.sel(side=1).values[on]
    frac = (pc - atm) / (supply - atm)
    t10, t90 = _first_time(t[on], frac, 0.1), _first_time(t[on], frac, 0.9)
    mach = ds.line_max_mach.sel(side=1).values
    return {"reached_pct": float(100.0 * frac[-1]), "delay_10pct_s": t10,
            "max_mach": float(np.nanmax(mach)),
            "max_exit_mach": float(np.nanmax(ds.line_exit_mach.sel(side=1).values)),
            "choked": bool(ds.line_choked.sel(side=1).values.any()),
            "rise_10_90_s": None if t90 is None else t90 - t10,
            "overshoot_pct": float(100.0 * max(0.0, frac.max() - 1.0)),
            "ripple_pct": float(100.0 * np.ptp(frac[t[on] >= 0.75 * half])),
            "max_valve_chamber_gap_Pa": float(np.max(np.abs(pv - pc)))}

def discharge_valve() -> Valve:
    """Port 1 open to the supply with DISCHARGE_VALVE_SCALE times the Festo preset's full
    conductance at every command; port 2 shut."""
    c = DISCHARGE_VALVE_SCALE * float(np.max(FESTO_MPYE.arrays()[1]))
    return Valve("discharge", (-1.0, 1.0), (c, c), (0.0, 0.0), critical_ratio=FESTO_MPYE.critical_ratio)


def discharge_test(case: LineCase, segments: int | None = None) -> dict:
    """The steady discharge of the module docstring for the distributed line of ``case``."""
    line = make_line("distributed", case.length_m, case.bore_m, **({} if segments is None else {"segments": segments}))
    cp = Plant(supply_Pa=case.pressure_Pa, valve=discharge_valve(), line_1=line, line_2=line,
               actuator=FixedChambers(DISCHARGE_VOLUME_M3, DISCHARGE_VOLUME_M3)).compile()
    air = cp.plant.air
    duration = FIRST_DISCHARGE_S
    while True:
        ds = simulate(cp, constant_command(1.0), duration, rate_Hz=STEP_SAMPLES / duration, sensors=ideal_sensors())
        flow = ds.chamber_mass_flow.sel(side=1).values[:-1]
        tail = flow[int(0.9 * flow.size):]
        if np.ptp(tail) <= DISCHARGE_STEADY * abs(flow[-1]):
            break
        duration *= 2.0
        if duration > MAX_HALF_PERIOD_S:
            raise SensorInputError(f"discharge test: the flow did not settle within {MAX_HALF_PERIOD_S:g} s "
                                   f"(--length {case.length_m:g} m, --bore {case.bore_m:g} m)")
    p0 = float(ds.pressure_valve.sel(side=1).values[-1])
    back = float(ds.pressure_chamber.sel(side=1).values[-1])
    refs = {}
    for name, fn in (("isothermal", isothermal_flow), ("fanno", fanno_flow)):
        m, choked = fn(p0, back, case.length_m, case.bore_m, air)
        refs[name] = {"mass_flow_kg_s": m, "choked": choked, "deviation_pct": 100.0 * (flow[-1] / m - 1.0)}
    return {"model": "distributed", "valve_conductance_m3_s_Pa": float(cp.csup.max()), "duration_s": duration,
            "stagnation_pressure_Pa": p0, "back_pressure_Pa": back, "mass_flow_kg_s": float(flow[-1]),
            "exit_mach": float(ds.line_exit_mach.sel(side=1).values[-2]),
            "choked": bool(ds.line_choked.sel(side=1).values[-2]),
            "max_mach": float(ds.line_max_mach.sel(side=1).values[-2]), "references": refs}


def _series(response: Response, f) -> dict:
    return {"frequency_hz": f.tolist(), "amplitude_ratio": response.amplitude(f).tolist(),
            "phase_deg": response.phase_deg(f).tolist()}


def analyse(case: LineCase) -> dict:
    """Frequency responses, resonances, amplitude errors and the step test, as plain data."""
    plants = {m: fixed_volume_plant(m, case) for m in case.models}
    air = next(iter(plants.values())).plant.air
    fmax = case.fmax_Hz or air.speed_of_sound / case.length_m
    f = np.logspace(math.log10(fmax) - FREQUENCY_DECADES, math.log10(fmax), case.points)
    ref = reference_response(case, air)
    f_ref = first_resonance(ref, f)
    band = f <= (0.8 * f_ref if f_ref is not None else f[-1])
    amp_ref = ref.amplitude(f)
    result = {
        "inputs": {"length_m": case.length_m, "bore_m": case.bore_m, "volume_m3": case.volume_m3,
                   "pressure_Pa": case.pressure_Pa, "fmax_Hz": fmax},
        "reference": {"name": "bergh-tijdeman", **_series(ref, f), "first_resonance_hz": f_ref,
                      "peak_amplitude_ratio": float(amp_ref.max())},
        "models": {},
    }
    for model, cp in plants.items():
        h = model_response(model, case, cp)
        amp = h.amplitude(f)
        if not np.all(np.isfinite(amp)):
            raise SolverError(f"line frequency response of the {model} model is not finite between "
                              f"{f[0]:.4g} and {f[-1]:.4g} Hz")
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
    if "distributed" in case.models:
        result["discharge"] = discharge_test(case)
    return result

