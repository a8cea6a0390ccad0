"""What a sensor's datasheet states, and its cross-axis sensitivity.

The datasheet re-runs the noise-free calibration cycle of a :class:`SensorModel` and states
range, sensitivity, resolution, nonlinearity and hysteresis (eq 87 on volts) as the thesis
reports its specimens (section 6.1.3.2, Figures 43 and 45); the cross-axis ratio is the
thesis' lateral-loading test (1.66 % for delrin).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from geometry.params import Design
from geometry.topology import build_beam_model
from sensor.errors import SensorInputError, SolverError
from sensor.mechanics.hysteresis import hysteresis, quality
from sensor.mechanics.solver import SolverOptions, solve
from sensor.readout.sensor_model import SensorModel, loading_cycle
from sensor.validation import is_real, require

# --- datasheet -----------------------------------------------------------------------------

@dataclass(frozen=True)
class Datasheet:
    """What a sensor's datasheet states (one calibration cycle, see :func:`datasheet`)."""

    name: str
    range_N: float
    target_output_mm: float
    gap_min_mm: float
    gap_max_mm: float
    span_V: float
    sensitivity_mV_per_N: float       # 1 / calibration slope
    resolution_N: float               # RMS, noise and quantisation, worst over the range
    nonlinearity_pct: float           # % FS
    hysteresis_pct: float             # % FS, eq 87 on volts against force
    hysteresis_mechanical_pct: float  # H given to the model (strain-energy law)
    quality_mV_per_N: float           # sensitivity / (hysteresis_pct / 100)
    noise_rms_V: float                # largest over the range, at the sample rate, V
    adc_step_V: float
    sample_rate_Hz: float
    adc_bits: int
    strain_energy_mJ: float
    material: str


def datasheet(sensor: SensorModel, material: str = "") -> Datasheet:
    """Simulate the noise-free calibration cycle again and state the sensor's figures.

    sensitivity: 1 / b of the least-squares line F = a + b V. nonlinearity_pct: largest
    |a + b V_mid - F| / range_N, V_mid the mean of the loading and unloading branches at each
    force (hysteresis is stated separately). hysteresis_pct: eq 87, max |V_unload - V_load| /
    V span. resolution_N: RMS, the worst over the range of |dF/dV| sqrt(sigma^2 + q^2 / 12),
    dF/dV the slope of the calibration in use, sigma the RMS noise at the sample rate, q the
    ADC step (uniform quantisation error).
    """
    cal = sensor.calibration
    forces = loading_cycle(sensor.range_N, len(cal.force_table))
    volts = sensor.analog_volts(forces)
    nonlin = np.max(np.abs(cal.intercept_N + cal.slope_N_per_V * cal.volts_table
                           - cal.force_table)) / sensor.range_N
    gaps = sensor.fiber_clearance_mm - sensor.travel_spline(cal.force_table)
    sigma = sensor.noise_spline(gaps)
    q = sensor.readout.adc_step_V
    slope = (np.full_like(gaps, cal.slope_N_per_V) if cal.method == "linear"
             else cal._curve.derivative()(cal.volts_table))
    hyst = hysteresis(forces, volts)
    sens = 1e3 / cal.slope_N_per_V
    lo, hi = sensor.gap_range_mm
    return Datasheet(
        name=sensor.name, range_N=sensor.range_N, target_output_mm=sensor.target_output_mm,
        gap_min_mm=lo, gap_max_mm=hi, span_V=float(np.ptp(volts)), sensitivity_mV_per_N=sens,
        resolution_N=float(np.max(np.abs(slope) * np.sqrt(sigma**2 + q**2 / 12.0))),
        nonlinearity_pct=100.0 * float(nonlin), hysteresis_pct=100.0 * hyst,
        hysteresis_mechanical_pct=100.0 * sensor.hysteresis, quality_mV_per_N=float(quality(sens, hyst)),
        noise_rms_V=float(np.max(sigma)), adc_step_V=q,
        sample_rate_Hz=sensor.readout.sample_rate_Hz, adc_bits=int(sensor.readout.adc_bits),
        strain_energy_mJ=sensor.strain_energy_mJ, material=material)


# --- cross-axis sensitivity ----------------------------------------------------------------

@dataclass(frozen=True)
class CrossAxis:
    """Mirror travel along the sensing axis under an imposed lateral vs axial input travel.

    ratio_pct = 100 max(|lateral +x|, |lateral -x|) / axial (the thesis' "variation in the
    lateral loading case as % of the axial", 1.66 % delrin, 3.29 % ABS). tilt_deg: mirror
    rotation under the lateral travel (the intensity model ignores tilt).
    """

    imposed_travel_mm: float
    axial_mirror_travel_mm: float
    lateral_mirror_travel_mm: tuple[float, float]   # for +x and -x
    ratio_pct: float
    lateral_force_N: float
    axial_force_N: float
    tilt_deg: float


def cross_axis(design: Design, imposed_travel_mm: float) -> CrossAxis:
    """Impose the same input (top plate) travel laterally (+x, -x) and axially; compare the
    mirror's travel along the sensing axis.

    A lateral force meets the body's compliant shear mode, so the lateral travel is imposed
    (displacement control of the input node), like the thesis' XY-stage. Pass the sensor's
    full-scale input travel to stay within range (amplifying bodies reach the fiber long
    before 1 mm of input travel).
    """
    require(is_real(imposed_travel_mm) and imposed_travel_mm > 0, "imposed_travel_mm",
             imposed_travel_mm, "a finite number > 0 (mm)")
    guided = build_beam_model(design)                     # axial: the stage guides the input
    free = build_beam_model(design, input_guided=False)   # lateral: the stage drives it sideways
    mirror, axis = guided.output_node, np.asarray(guided.output_direction, dtype=float)

    def drive(direction):
        model = guided if direction[0] == 0 else free
        driven = dataclasses.replace(model, input_direction=np.array(direction, dtype=float),
                                     output_node=model.input_node,
                                     output_direction=np.array(direction, dtype=float))
        try:
            r = solve(driven, target_output_mm=imposed_travel_mm, options=SolverOptions(increments=8))
        except SolverError as exc:
            raise SensorInputError(f"imposed_travel_mm = {imposed_travel_mm!r}: the body cannot be "
                              f"driven that far along {direction}: {exc}") from None
        travel = float((r.deformed_nodes[mirror] - model.nodes[mirror]) @ axis)
        return travel, r.input_force_N, float(np.degrees(r.node_rotation_rad[mirror]))

    axial, f_ax, _ = drive(tuple(guided.input_direction))
    plus, f_lat, tilt = drive((1.0, 0.0))
    minus, _, _ = drive((-1.0, 0.0))
    return CrossAxis(float(imposed_travel_mm), axial, (plus, minus),
                     100.0 * max(abs(plus), abs(minus)) / abs(axial), f_lat, f_ax, tilt)
