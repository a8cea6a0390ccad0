"""The sensor model: a force history in, what the sensor reads out (volts, ADC codes, newtons).

The chain (DESIGN section 7; thesis sections 6.1.3 and 6.2, Appendix D), one sample at a time:

1. Mechanics: the mirror's travel x_e(F) against the input force, solved once with the chain
   solver up to the full-scale travel X_fs (``increments`` points, uniform in travel) and
   interpolated with a monotone (PCHIP) spline. The force at X_fs is the range F_fs.
2. Hysteresis, rate independent: x = x_e(F) + X_fs h(s), s = F / F_fs. h is a Preisach model
   with a uniform weight mu on the triangle 0 <= beta <= alpha <= 1: every branch is a
   parabola from its last turning point, P = -mu/2 + mu sum_j (+/-)(p_j - p_(j-1))^2 over
   the turning points p_j still in memory (rising segments +, falling -, a reversal is wiped
   out once the input passes the older extremum), and h = P - mu (s - 1/2). The full-range
   loop 0 -> F_fs -> 0 has h = -mu s(1-s) loading and +mu s(1-s) unloading: the unloading
   branch lags (reads more travel), both close at the ends, and max(delta x) / X_fs = mu / 2
   (eq 87). mu = 2 H, with H from the strain-energy law (:mod:`sensor.mechanics.hysteresis`) at the
   full-scale strain energy. Minor loops close; a reversal over a fraction d of the range
   leaves a loop H d^2 high, so small force jitter adds almost no hysteresis.
3. Optics: gap = fiber_clearance_mm - x; V(gap) from :func:`sensor.readout.optics.output_voltage`,
   tabulated on a gap grid and interpolated with a cubic spline.
4. Noise: white Gaussian, RMS :func:`sensor.readout.noise.noise_rms_V` at the current gap over the
   bandwidth f_s / 2 (ideal anti-alias filter), one standard normal per sample drawn from
   the caller's ``numpy.random.Generator`` (no generator: noise-free).
5. ADC: ``adc_bits`` over [adc_min_V, adc_max_V], rounding to the nearest code.
6. Calibration: a simulated loading-unloading cycle gives the least-squares line F = a + b V
   (as thesis Figures 43 and 45: sensitivity and nonlinearity) and the mean branch through
   the middle of the loop, read back with a monotone spline (see :class:`Calibration`).

Forces outside [0, F_fs] (the sensor is compression-only; beyond F_fs the mirror heads for
the fiber) raise :class:`SensorRangeError` with ``overload="raise"`` (default) or are clipped
to the range and flagged ``saturated`` with ``overload="saturate"``; NaN always raises.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline, PchipInterpolator

from geometry.params import Design
from geometry.topology import build_beam_model
from sensor.errors import SensorInputError, SensorRangeError
from sensor.mechanics.hysteresis import DEFAULT_LAW, H_LIMIT, VIRGIN, StrainEnergyLaw, preisach_offsets
from sensor.mechanics.qualifiers import qualify
from sensor.mechanics.solver import SolverOptions, solve
from sensor.readout.noise import READOUTS, noise_rms_V
from sensor.readout.optics import MODELS, OpticsSetup, output_voltage
from sensor.validation import is_integer, is_real, require

OVERLOADS = ("raise", "saturate")
GAP_TABLE_POINTS = 241  # cubic spline of V(gap): error < 1e-6 V, under 1/300 of a 16-bit code


@dataclass(frozen=True)
class Readout:
    """Acquisition: sample rate, ADC and which optics/noise model to use.

    sample_rate_Hz: 1 kHz; the noise bandwidth is f_s / 2.
    adc_bits, adc_min_V, adc_max_V: NI USB-6221 (thesis 6.1.3.2): 16 bits on +/-10 V,
        a 305 uV step.
    mode: "ratio" (signal / reference photodiode, cancels source drift) or "direct".
    model: intensity model of :mod:`sensor.readout.optics`, "geometric" or "gaussian".
    """

    sample_rate_Hz: float = 1000.0
    adc_bits: int = 16
    adc_min_V: float = -10.0
    adc_max_V: float = 10.0
    mode: str = "ratio"
    model: str = "geometric"

    def __post_init__(self) -> None:
        require(is_real(self.sample_rate_Hz) and self.sample_rate_Hz > 0, "sample_rate_Hz",
                 self.sample_rate_Hz, "a finite number > 0 (Hz)")
        require(is_integer(self.adc_bits) and 1 <= self.adc_bits <= 32, "adc_bits", self.adc_bits, "an integer in 1..32")
        for name in ("adc_min_V", "adc_max_V"):
            require(is_real(getattr(self, name)), name, getattr(self, name), "a finite number (V)")
        require(self.adc_max_V > self.adc_min_V, "adc_max_V", self.adc_max_V,
                 f"> adc_min_V = {self.adc_min_V!r}")
        require(self.mode in READOUTS, "mode", self.mode, f"one of {READOUTS}")
        require(self.model in MODELS, "model", self.model, f"one of {MODELS}")

    @property
    def adc_step_V(self) -> float:
        """One ADC code, V."""
        return (self.adc_max_V - self.adc_min_V) / 2**self.adc_bits

    @property
    def bandwidth_Hz(self) -> float:
        """Noise bandwidth of one sample, Hz (Nyquist)."""
        return self.sample_rate_Hz / 2.0


CALIBRATIONS = ("curve", "linear")


@dataclass(frozen=True, eq=False)
class Calibration:
    """Volts back to newtons, from one simulated loading-unloading cycle.

    ``intercept_N``, ``slope_N_per_V``: the least-squares line F = a + b V over both
    branches (thesis Figures 43 and 45); its slope gives the datasheet sensitivity.
    ``volts_table``, ``force_table``: the mean of the loading and unloading branches at each
    force (the line through the middle of the loop). ``method`` "curve" (default) reads
    newtons with a monotone spline through that table, so only hysteresis (+/- half the loop)
    and resolution remain; "linear" reads with the line, as the thesis did, adding the
    nonlinearity (tens of % FS with a single-fiber readout) to the error.
    """

    intercept_N: float
    slope_N_per_V: float
    volts_table: np.ndarray
    force_table: np.ndarray
    method: str = "curve"

    def __post_init__(self) -> None:
        require(self.method in CALIBRATIONS, "calibration", self.method, f"one of {CALIBRATIONS}")
        object.__setattr__(self, "_curve", PchipInterpolator(self.volts_table, self.force_table))

    def force_N(self, volts):
        """Calibrated force, N, of a voltage (V; scalar or array)."""
        v = np.asarray(volts, dtype=float)
        if self.method == "linear":
            return self.intercept_N + self.slope_N_per_V * v
        return self._curve(v)


@dataclass(frozen=True)
class Readings:
    """What the sensor read, one element per sample.

    force_N: the force applied (after clipping, with ``overload="saturate"``); travel_mm:
    mirror travel (with hysteresis); gap_mm: fiber-mirror gap; volts: ADC output (noisy,
    quantised), V; counts: ADC codes; newtons: calibrated reading, N; saturated: the force
    was clipped to the range or the ADC clipped.
    """

    force_N: np.ndarray
    travel_mm: np.ndarray
    gap_mm: np.ndarray
    volts: np.ndarray
    counts: np.ndarray
    newtons: np.ndarray
    saturated: np.ndarray


@dataclass(frozen=True)
class Reading:
    """One sample of :class:`Readings` (floats, an int code and a bool)."""

    force_N: float
    travel_mm: float
    gap_mm: float
    volts: float
    counts: int
    newtons: float
    saturated: bool


# --- the transducer: force -> volts --------------------------------------------------------

@dataclass(frozen=True, eq=False)
class Transducer:
    """Force to volts: a solved design, its optics, hysteresis, noise and ADC (no calibration)."""

    name: str
    range_N: float                 # force at full-scale travel, N
    target_output_mm: float    # mirror travel at range_N, mm
    fiber_clearance_mm: float      # fiber-mirror gap at rest, mm
    input_travel_mm: float         # input (top plate) travel at range_N, mm
    strain_energy_mJ: float        # at full scale
    hysteresis: float              # H (fraction of full scale) of the full-range loop
    optics: OpticsSetup
    readout: Readout
    overload: str
    curve_force_N: np.ndarray      # solved mirror force-travel curve
    curve_travel_mm: np.ndarray
    travel_spline: PchipInterpolator
    volts_spline: CubicSpline      # noise-free V(gap)
    noise_spline: CubicSpline      # RMS noise (V) against gap at the sample rate

    @property
    def gap_range_mm(self) -> tuple[float, float]:
        """(smallest, largest) gap over the range, mm."""
        return self.fiber_clearance_mm - self.target_output_mm, self.fiber_clearance_mm

    def noise_free_volts(self, travel_mm) -> np.ndarray:
        """Noise-free, unquantised output, V, at mirror travel(s) in mm."""
        return self.volts_spline(self.fiber_clearance_mm - np.asarray(travel_mm, dtype=float))

    def analog_volts(self, forces_N) -> np.ndarray:
        """Noise-free, unquantised output, V, along a force history from the unloaded state
        (with hysteresis: what a bench calibration averaging many samples sees)."""
        return _analog(self, forces_N, None, VIRGIN)[0][3]


@dataclass(frozen=True, eq=False)
class SensorModel(Transducer):
    """One sensor: a :class:`Transducer` and its calibration back to newtons.

    Build with :func:`build_sensor`. ``read(forces)`` reads a whole force history,
    ``stepper()`` gives an object that reads it sample by sample with identical results.
    """

    calibration: Calibration

    def read(self, forces_N, rng: np.random.Generator | None = None,
             state: tuple[float, ...] = VIRGIN) -> Readings:
        """Read a force history (N, 1-D, in time order) from memory ``state`` (unloaded)."""
        return _read(self, forces_N, rng, state)[0]

    def stepper(self, rng: np.random.Generator | None = None) -> "SensorStepper":
        """A sample-by-sample reader starting unloaded."""
        return SensorStepper(self, rng)


class SensorStepper:
    """Reads one force sample at a time; holds the hysteresis memory (turning points)."""

    def __init__(self, sensor: SensorModel, rng: np.random.Generator | None = None):
        self.sensor, self.rng, self.state = sensor, rng, VIRGIN

    def step(self, force_N: float) -> Reading:
        """Read one force sample (N); advances the memory only if the sample is accepted."""
        r, self.state = _read(self.sensor, np.array([force_N], dtype=float), self.rng, self.state)
        return Reading(float(r.force_N[0]), float(r.travel_mm[0]), float(r.gap_mm[0]),
                       float(r.volts[0]), int(r.counts[0]), float(r.newtons[0]),
                       bool(r.saturated[0]))


def _checked_forces(forces_N, range_N: float, overload: str) -> tuple[np.ndarray, np.ndarray]:
    """(forces within [0, range_N], clipped mask) or SensorRangeError."""
    f = np.asarray(forces_N, dtype=float)
    if f.ndim != 1:
        raise SensorRangeError(f"forces_N has shape {f.shape}: must be a 1-D force history")
    bad = np.flatnonzero(~np.isfinite(f))
    if len(bad):
        raise SensorRangeError(f"force_N[{bad[0]}] = {float(f[bad[0]])!r}: must be a finite number (N)")
    out = (f < 0.0) | (f > range_N)
    if overload == "raise" and out.any():
        i = int(np.flatnonzero(out)[0])
        raise SensorRangeError(
            f"force_N[{i}] = {f[i]:.6g}: must lie in the range [0, {range_N:.6g}] N "
            "(compression only, up to full-scale mirror travel; use overload='saturate' "
            "to clip and flag instead)")
    return np.clip(f, 0.0, range_N), out


def _analog(sensor: Transducer, forces_N, rng, state):
    """Force history -> (forces, travel, gap, analog volts, clipped), final memory state."""
    if rng is not None and not isinstance(rng, np.random.Generator):
        raise SensorInputError(f"rng = {rng!r}: must be a numpy.random.Generator or None")
    f, clipped = _checked_forces(forces_N, sensor.range_N, sensor.overload)
    h, state = preisach_offsets(f / sensor.range_N, 2.0 * sensor.hysteresis, state)
    travel = sensor.travel_spline(f) + sensor.target_output_mm * h
    gap = sensor.fiber_clearance_mm - travel
    if (gap <= 0).any():
        i = int(np.flatnonzero(gap <= 0)[0])
        raise SensorRangeError(f"force_N[{i}] = {f[i]:.6g}: the mirror would touch the fiber "
                               f"(gap {gap[i]:.4g} mm)")
    volts = sensor.volts_spline(gap)
    if rng is not None:
        volts = volts + sensor.noise_spline(gap) * rng.standard_normal(len(f))
    return (f, travel, gap, volts, clipped), state


def _quantise(ro: Readout, volts: np.ndarray):
    """(ADC volts, codes, clipped) of analog volts: nearest code, clipped to the ADC range."""
    top = 2**ro.adc_bits - 1
    codes = np.rint((volts - ro.adc_min_V) / ro.adc_step_V)
    clipped = (codes < 0) | (codes > top)
    codes = np.clip(codes, 0, top).astype(np.int64)
    return ro.adc_min_V + codes * ro.adc_step_V, codes, clipped


def _read(sensor: SensorModel, forces_N, rng, state):
    """The whole chain and the calibration; returns (Readings, final memory state)."""
    (f, travel, gap, analog, clipped), state = _analog(sensor, forces_N, rng, state)
    volts, codes, adc_clipped = _quantise(sensor.readout, analog)
    return Readings(f, travel, gap, volts, codes, sensor.calibration.force_N(volts),
                    clipped | adc_clipped), state


# --- building and calibrating ------------------------------------------------------------

def loading_cycle(range_N: float, points: int = 201) -> np.ndarray:
    """Forces of one loading-unloading cycle 0 -> range_N -> 0, ``points`` per branch, N."""
    require(isinstance(points, int) and points >= 3, "points", points, "an integer >= 3")
    up = np.linspace(0.0, range_N, points)
    return np.concatenate([up, up[-2::-1]])


def fit_calibration(forces_N, volts, method: str = "curve") -> Calibration:
    """Calibration from one loading-unloading cycle of :func:`loading_cycle` (forces, N, and
    the volts read): the least-squares line over both branches, and the mean branch."""
    f, v = np.asarray(forces_N, dtype=float), np.asarray(volts, dtype=float)
    n = (len(f) + 1) // 2
    a, b = np.polynomial.polynomial.polyfit(v, f, 1)
    mid = 0.5 * (v[:n] + v[n - 1:][::-1])
    if np.any(np.diff(mid) <= 0):
        raise SensorInputError("the calibration cycle's volts do not rise with the force at every "
                          "point: the sensor's output is not monotone over its range")
    return Calibration(float(a), float(b), mid, f[:n].copy(), method)


def build_sensor(design: Design, optics: OpticsSetup = OpticsSetup(), readout: Readout = Readout(),
                 law: StrainEnergyLaw = DEFAULT_LAW, target_output_mm: float = 1.0,
                 overload: str = "raise", increments: int = 20,
                 calibration: str = "curve", calibration_points: int = 201) -> SensorModel:
    """Solve a design once and assemble its sensor model.

    The calibration is fitted to one loading-unloading cycle of ``calibration_points`` per
    branch read noise-free and before the ADC: the ideal of a bench calibration averaging
    many samples, so what remains in a reading is hysteresis, noise and quantisation.

    ``target_output_mm``: mirror travel at full scale (default 1 mm, the thesis' design
    travel and its 1 mm wide linear interval); it must stay below the design's
    ``fiber_clearance_mm`` (the gap at rest) so the mirror never touches the fiber.
    ``calibration``: "curve" or "linear" (see :class:`Calibration`).
    """
    require(is_real(target_output_mm) and 0 < target_output_mm < design.fiber_clearance_mm,
             "target_output_mm", target_output_mm,
             f"in (0, fiber_clearance_mm = {design.fiber_clearance_mm:g}) mm: the mirror must not "
             "touch the fiber")
    require(overload in OVERLOADS, "overload", overload, f"one of {OVERLOADS}")
    require(is_integer(increments) and increments >= 4, "increments", increments,
             "an integer >= 4")
    r = solve(build_beam_model(design), target_output_mm=target_output_mm,
              options=SolverOptions(increments=increments))
    q = qualify(r, law)
    H = q.hysteresis
    require(0 <= H < H_LIMIT, "predicted hysteresis", H,
             f"in [0, {H_LIMIT:g}) for this hysteresis model (a very high strain energy)")
    # Gap table: from (almost) touching to beyond rest, covering every hysteretic excursion.
    clearance = design.fiber_clearance_mm
    gaps = np.linspace(0.0, clearance + 2 * H * target_output_mm, GAP_TABLE_POINTS)
    volts = output_voltage(gaps, optics, readout.model)
    noise = noise_rms_V(optics, readout.bandwidth_Hz, gaps, readout.model, readout.mode)
    t = Transducer(
        name=design.name, range_N=q.range_N, target_output_mm=float(target_output_mm),
        fiber_clearance_mm=clearance, input_travel_mm=r.input_travel_mm,
        strain_energy_mJ=r.strain_energy_mJ, hysteresis=H, optics=optics, readout=readout,
        overload=overload, curve_force_N=r.force_N, curve_travel_mm=r.output_mm,
        travel_spline=PchipInterpolator(r.force_N, r.output_mm),
        volts_spline=CubicSpline(gaps, volts), noise_spline=CubicSpline(gaps, noise))
    span = t.noise_free_volts([0.0, target_output_mm])
    if min(span) < readout.adc_min_V or max(span) > readout.adc_max_V - readout.adc_step_V:
        raise SensorRangeError(f"output {min(span):.4g}..{max(span):.4g} V over the range: must "
                               f"fit the ADC range [{readout.adc_min_V:g}, {readout.adc_max_V:g}] V "
                               "(change the gain or the ADC range)")
    forces = loading_cycle(t.range_N, calibration_points)
    volts_read = t.analog_volts(forces)
    fields = {f.name: getattr(t, f.name) for f in dataclasses.fields(Transducer)}
    return SensorModel(**fields, calibration=fit_calibration(forces, volts_read, calibration))
