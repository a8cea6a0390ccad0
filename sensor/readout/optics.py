"""Fiber-mirror intensity: collected power, output voltage and the linear working range.

One plastic fiber both emits and collects (thesis section 6.1.1, Figure 38, Appendix D).
A 2x2 coupler (Figure 61) sends ``coupler_ratio`` of the source into the sensing fiber and
the complementary ``1 - coupler_ratio`` of the returning light to the signal photodiode; the
fourth port feeds the reference photodiode with ``1 - coupler_ratio`` of the source.

Two models of the collection efficiency eta(d) (the fraction of the light leaving the end
face that re-enters the core after the mirror, reflectivity and Fresnel losses excluded):

* ``"geometric"`` (image-fiber model): the mirror at gap d acts as an image of the fiber at
  distance L = 2d. The fiber is taken as fully mode-filled, i.e. of constant radiance within
  its acceptance cone: every point of the core radiates a Lambertian cone cut at
  asin(NA). Ray optics, no paraxial approximation. With u = sin^2(theta) / NA^2 (uniform on
  [0, 1] for that emission) and c(s) the normalised overlap area of two core disks whose
  centres are s apart (the core's autocorrelation, circle-circle overlap),

      eta(L) = integral_0^1 c(L tan(asin(NA sqrt(u)))) du,

  evaluated for all gaps at once with a fixed 32-point Gauss-Legendre rule after the
  substitution u = u_edge sin^2(t) (u_edge: where c reaches 0), which takes away the
  square-root behaviour at both ends, so the rule converges exponentially (it agrees with
  adaptive quadrature within 1e-11). eta(0) = 1 exactly and eta -> a^2 / (NA^2 L^2)
  in the far field (a = core radius). Every ray that reaches the core arrives within the
  acceptance angle, so it is guided.
* ``"gaussian"``: the fiber emits a (multimode, embedded) Gaussian beam whose 1/e^2 radius
  grows as w(z)^2 = w0^2 + theta0^2 z^2; the coupling back is the overlap integral of the
  returning intensity with the core aperture, eta = 1 - exp(-2 a^2 / w(2d)^2). Matching:
  w0 = a (the second-moment radius of a uniformly lit core) and theta0 = sqrt(2) NA, which
  gives the Gaussian the same on-axis far-field intensity as the Lambertian-within-NA fiber,
  so both models share the far-field asymptote a^2 / (4 NA^2 d^2). (Matching second moments
  of the angular spread instead, theta0 = NA, would double the far-field signal.) At zero
  gap the Gaussian couples back 1 - e^-2 = 86.5 %, the geometric model 100 %.

Collected power: P_back = P_launch [R_f + (1 - R_f)^2 R_m eta(d)], the end-face Fresnel
back-reflection R_f adding a gap-independent floor. Output: V = offset + G S (1 - k) P_back
(transimpedance gain G, responsivity S, coupler ratio k). Units: gaps in mm, powers in W,
currents in A, voltages in V.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from sensor.errors import OpticsError

MODELS = ("geometric", "gaussian")
LINES = ("best_fit", "endpoint")


def _require(ok: bool, name: str, value, rule: str) -> None:
    if not ok:
        raise OpticsError(f"{name} = {value!r}: must be {rule}")


def _finite(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


@dataclass(frozen=True)
class OpticsSetup:
    """The fiber-mirror readout (defaults: the thesis' bench, section 6.1.3.2 and App. D).

    core_diameter_mm: 0.9 mm plastic (PMMA) fiber core, Industrial Fiber Optics Co.
    numerical_aperture: 0.5, typical of their step-index plastic fibers (0.47-0.5).
    mirror_reflectivity: 0.35, bare silicon in the red (n ~ 3.85: ((n-1)/(n+1))^2 = 0.345);
        the thesis' "magenta silicon mirror" is not characterised, measure yours.
    end_face_reflectance: 0.04, Fresnel reflection of the PMMA (n = 1.49) end face in air.
    coupler_ratio: 0.5, the 50:50 IF-540 coupler (fraction of the source sent to the fiber).
    source_power_W: 5 mW red laser (Lasiris).
    responsivity_A_per_W: 0.42, silicon PIN photodiode at 650 nm.
    gain_V_per_A: 10 kOhm transimpedance of the signal amplifier (about 1.9 V at zero gap).
    offset_V: signal amplifier output offset.
    reference_gain_V_per_A: 2 kOhm transimpedance of the reference channel (about 2.1 V).
    source_rin_dB_per_Hz: -120 dB/Hz white relative intensity noise of the laser diode.
    temperature_K: 295 K, for the Johnson noise of the transimpedance resistors.
    """

    core_diameter_mm: float = 0.9
    numerical_aperture: float = 0.5
    mirror_reflectivity: float = 0.35
    end_face_reflectance: float = 0.04
    coupler_ratio: float = 0.5
    source_power_W: float = 5e-3
    responsivity_A_per_W: float = 0.42
    gain_V_per_A: float = 1e4
    offset_V: float = 0.0
    reference_gain_V_per_A: float = 2e3
    source_rin_dB_per_Hz: float = -120.0
    temperature_K: float = 295.0

    def __post_init__(self) -> None:
        for name in self.__dataclass_fields__:
            value = getattr(self, name)
            _require(_finite(value), name, value, "a finite number")
        _require(self.core_diameter_mm > 0, "core_diameter_mm", self.core_diameter_mm, "> 0")
        _require(0 < self.numerical_aperture < 1, "numerical_aperture",
                 self.numerical_aperture, "in (0, 1)")
        _require(0 <= self.mirror_reflectivity <= 1, "mirror_reflectivity",
                 self.mirror_reflectivity, "in [0, 1]")
        _require(0 <= self.end_face_reflectance < 1, "end_face_reflectance",
                 self.end_face_reflectance, "in [0, 1)")
        _require(0 < self.coupler_ratio < 1, "coupler_ratio", self.coupler_ratio, "in (0, 1)")
        _require(self.source_power_W > 0, "source_power_W", self.source_power_W, "> 0")
        for name in ("responsivity_A_per_W", "gain_V_per_A", "reference_gain_V_per_A",
                     "temperature_K"):
            _require(getattr(self, name) > 0, name, getattr(self, name), "> 0")

    @property
    def core_radius_mm(self) -> float:
        """Core radius a, mm."""
        return 0.5 * self.core_diameter_mm

    @property
    def launched_power_W(self) -> float:
        """Power sent by the coupler into the sensing fiber, W."""
        return self.source_power_W * self.coupler_ratio

    @property
    def emitted_power_W(self) -> float:
        """Power leaving the fiber end face towards the mirror, W."""
        return self.launched_power_W * (1.0 - self.end_face_reflectance)

    @property
    def gaussian_waist_mm(self) -> float:
        """1/e^2 waist radius w0 of the matched Gaussian beam (= core radius), mm."""
        return self.core_radius_mm

    @property
    def gaussian_divergence_rad(self) -> float:
        """1/e^2 far-field half-angle theta0 of the matched Gaussian beam (sqrt(2) NA), rad."""
        return math.sqrt(2.0) * self.numerical_aperture


def _gaps(gap_mm) -> np.ndarray:
    gap = np.asarray(gap_mm, dtype=float)
    bad = ~np.isfinite(gap) | (gap < 0)
    if np.any(bad):
        raise OpticsError(f"gap_mm = {gap[bad].flat[0]!r}: must be finite and >= 0")
    return gap


def _model(model: str) -> str:
    _require(model in MODELS, "model", model, f"one of {MODELS}")
    return model


#: Gauss-Legendre nodes and weights on [-1, 1] of the image-fiber integrals.
_X, _W = np.polynomial.legendre.leggauss(32)


def _geometric_terms(gap: np.ndarray, setup: OpticsSetup) -> tuple[np.ndarray, np.ndarray]:
    """(eta, d eta / d gap in 1/mm) of the image-fiber model at gaps (mm), any shape."""
    na, two_a = setup.numerical_aperture, setup.core_diameter_mm
    length = 2.0 * gap[..., None]
    # u_edge: where a ray lands one core diameter off its origin (c = 0 beyond). With
    # u = u_edge sin^2(t) both the start (c ~ sqrt(u)) and that edge (sqrt(1 - x^2) ~ cos t)
    # are smooth in t, also when the edge lies just beyond u = 1.
    u_edge = (two_a / np.hypot(two_a, length) / na) ** 2
    t_end = np.arcsin(np.sqrt(np.minimum(1.0 / u_edge, 1.0)))
    t = 0.5 * t_end * (_X + 1.0)
    u = u_edge * np.sin(t) ** 2
    du = 0.5 * t_end * _W * u_edge * np.sin(2.0 * t)    # weights times du/dt
    tan_theta = na * np.sqrt(u) / np.sqrt(1.0 - na * na * u)
    x = np.minimum(length * tan_theta / two_a, 1.0)     # centre offset in core diameters
    root = np.sqrt(1.0 - x * x)
    overlap = (2.0 / math.pi) * (np.arccos(x) - x * root)  # c(x): circle-circle overlap
    eta = (du * overlap).sum(-1)
    # dc/dx = -(4/pi) sqrt(1 - x^2); x = L tan / (2a); dL/dgap = 2.
    deta_dl = (du * (-(4.0 / math.pi) * tan_theta / two_a * root)).sum(-1)
    return eta, 2.0 * deta_dl


def _gaussian_terms(gap: np.ndarray, setup: OpticsSetup) -> tuple[np.ndarray, np.ndarray]:
    """(eta, d eta / d gap in 1/mm) of the Gaussian-beam model."""
    a, w0, th = setup.core_radius_mm, setup.gaussian_waist_mm, setup.gaussian_divergence_rad
    w2 = w0**2 + (th * 2.0 * gap) ** 2
    decay = np.exp(-2.0 * a**2 / w2)
    return 1.0 - decay, -decay * (2.0 * a**2 / w2**2) * 8.0 * th**2 * gap


def _efficiency_and_slope(gap_mm, setup: OpticsSetup, model: str):
    gap = _gaps(gap_mm)
    if _model(model) == "gaussian":
        return _gaussian_terms(gap, setup)
    return _geometric_terms(gap, setup)


def collection_efficiency(gap_mm, setup: OpticsSetup, model: str = "geometric") -> np.ndarray:
    """eta(d): fraction of the light leaving the end face that re-enters the core (0..1).

    Excludes mirror reflectivity and Fresnel losses; ``gap_mm`` is the fiber-mirror gap, mm.
    """
    return _efficiency_and_slope(gap_mm, setup, model)[0]


def collected_power(gap_mm, setup: OpticsSetup, model: str = "geometric") -> np.ndarray:
    """Power travelling back up the sensing fiber, W: P_launch [R_f + (1-R_f)^2 R_m eta(d)]."""
    eta = collection_efficiency(gap_mm, setup, model)
    rf = setup.end_face_reflectance
    return setup.launched_power_W * (rf + (1.0 - rf) ** 2 * setup.mirror_reflectivity * eta)


def signal_photocurrent_A(gap_mm, setup: OpticsSetup, model: str = "geometric") -> np.ndarray:
    """Signal photodiode current, A: S (1 - k) P_back (noise-free, nominal source power)."""
    return (setup.responsivity_A_per_W * (1.0 - setup.coupler_ratio)
            * collected_power(gap_mm, setup, model))


def reference_photocurrent_A(setup: OpticsSetup) -> float:
    """Reference photodiode current, A: S (1 - k) P_source (nominal source power)."""
    return setup.responsivity_A_per_W * (1.0 - setup.coupler_ratio) * setup.source_power_W


def output_voltage(gap_mm, setup: OpticsSetup, model: str = "geometric") -> np.ndarray:
    """Noise-free signal amplifier output, V: offset + G S (1 - k) P_back(d).

    At the nominal source power the ratio readout (see :mod:`sensor.readout.noise`) reads the same.
    """
    return setup.offset_V + setup.gain_V_per_A * signal_photocurrent_A(gap_mm, setup, model)


def voltage_slope(gap_mm, setup: OpticsSetup, model: str = "geometric") -> np.ndarray:
    """dV/d(gap), V/mm (negative: a single-fiber curve falls with the gap). Analytic."""
    deta = _efficiency_and_slope(gap_mm, setup, model)[1]
    rf = setup.end_face_reflectance
    return (setup.gain_V_per_A * setup.responsivity_A_per_W * (1.0 - setup.coupler_ratio)
            * setup.launched_power_W * (1.0 - rf) ** 2 * setup.mirror_reflectivity * deta)


def _line_deviation(volts: np.ndarray, gaps: np.ndarray, line: str):
    """(max |V - line| / |span| in %, slope V/mm, intercept V) along the last axis."""
    if line == "endpoint":
        slope = (volts[..., -1] - volts[..., 0]) / (gaps[..., -1] - gaps[..., 0])
        intercept = volts[..., 0] - slope * gaps[..., 0]
    else:
        # Trapezoid weights: the grid fit converges to the continuous least-squares line
        # over the interval as step^2 (plain point weights would converge only as step).
        w = np.ones(gaps.shape[-1])
        w[[0, -1]] = 0.5
        gm = (w * gaps).sum(axis=-1, keepdims=True) / w.sum()
        vm = (w * volts).sum(axis=-1, keepdims=True) / w.sum()
        slope = ((w * (gaps - gm) * (volts - vm)).sum(axis=-1)
                 / (w * (gaps - gm) ** 2).sum(axis=-1))
        intercept = vm[..., 0] - slope * gm[..., 0]
    fit = intercept[..., None] + slope[..., None] * gaps
    span = np.abs(volts[..., -1] - volts[..., 0])
    with np.errstate(divide="ignore", invalid="ignore"):
        pct = 100.0 * np.abs(volts - fit).max(axis=-1) / span
    return np.where(span > 0, pct, np.inf), slope, intercept


@dataclass(frozen=True)
class Linearity:
    """Straight-line fit of V(gap) over [gap_lo_mm, gap_hi_mm].

    nonlinearity_pct: max |V - line| as % of the full-scale output span |V(hi) - V(lo)|.
    line: "best_fit" (the continuous least-squares line over the interval, evaluated on a
    uniform gap grid with trapezoid weights) or "endpoint" (the chord).
    """

    gap_lo_mm: float
    gap_hi_mm: float
    slope_V_per_mm: float
    intercept_V: float
    nonlinearity_pct: float
    line: str
    model: str


def _check_line(line: str) -> str:
    _require(line in LINES, "line", line, f"one of {LINES}")
    return line


def _check_step(step_mm: float) -> float:
    _require(_finite(step_mm) and step_mm > 0, "step_mm", step_mm, "a finite number > 0")
    return float(step_mm)


def linearity(gap_lo_mm: float, gap_hi_mm: float, setup: OpticsSetup,
              model: str = "geometric", line: str = "best_fit",
              step_mm: float = 0.001) -> Linearity:
    """Nonlinearity (% of full scale) and slope (V/mm) of V(gap) over one interval."""
    _check_line(line)
    lo, hi = float(_gaps(gap_lo_mm)), float(_gaps(gap_hi_mm))
    _require(hi > lo, "gap_hi_mm", gap_hi_mm, f"> gap_lo_mm = {gap_lo_mm!r}")
    gaps = np.linspace(lo, hi, max(3, int(round((hi - lo) / _check_step(step_mm))) + 1))
    pct, slope, intercept = _line_deviation(output_voltage(gaps, setup, model), gaps, line)
    return Linearity(lo, hi, float(slope), float(intercept), float(pct), line, model)


@dataclass(frozen=True)
class WorkingRange(Linearity):
    """The widest gap interval whose nonlinearity stays within ``tolerance_pct``."""

    tolerance_pct: float = 0.0

    @property
    def width_mm(self) -> float:
        """Interval width, mm."""
        return self.gap_hi_mm - self.gap_lo_mm


def working_range(setup: OpticsSetup, tolerance_pct: float, model: str = "geometric",
                  line: str = "best_fit", gap_min_mm: float = 0.0, gap_max_mm: float = 3.0,
                  step_mm: float = 0.005) -> WorkingRange:
    """Widest [lo, hi] within [gap_min_mm, gap_max_mm] with nonlinearity <= tolerance_pct.

    Nonlinearity is max |V - line| in % of the interval's full-scale output span; ``line`` is
    "best_fit" (least squares) or "endpoint". The search is exhaustive over a uniform grid of
    ``step_mm`` (interval ends are resolved to one step); among equally wide intervals the
    most linear wins. Returns the interval, its least-squares (or chord) slope in V/mm and
    the nonlinearity reached.
    """
    _require(_finite(tolerance_pct) and tolerance_pct > 0, "tolerance_pct", tolerance_pct,
             "a finite number > 0")
    _check_line(line)
    lo, hi = float(_gaps(gap_min_mm)), float(_gaps(gap_max_mm))
    _require(hi > lo, "gap_max_mm", gap_max_mm, f"> gap_min_mm = {gap_min_mm!r}")
    n = int(round((hi - lo) / _check_step(step_mm))) + 1
    _require(n >= 3, "step_mm", step_mm, f"small enough for 3 grid points in [{lo}, {hi}] mm")
    gaps = np.linspace(lo, hi, n)
    volts = output_voltage(gaps, setup, model)
    for width in range(n - 1, 1, -1):
        pct, slope, intercept = _line_deviation(sliding_window_view(volts, width + 1),
                                                sliding_window_view(gaps, width + 1), line)
        if np.min(pct) <= tolerance_pct:
            i = int(np.argmin(pct))
            return WorkingRange(float(gaps[i]), float(gaps[i + width]), float(slope[i]),
                                float(intercept[i]), float(pct[i]), line, model,
                                float(tolerance_pct))
    raise OpticsError(f"tolerance_pct = {tolerance_pct!r}: no interval of 3 grid points "
                      f"(step {step_mm} mm) is that linear; loosen it or refine step_mm")
