"""Line models against independent references: Bergh-Tijdeman, Hagen-Poiseuille, L/c, limits."""
import math

import numpy as np
import pytest
from scipy.optimize import minimize_scalar
from scipy.signal import argrelmax

from sensor.errors import SensorError
from sensor.pneumatic.air import AIR, Air
from sensor.pneumatic.bergh_tijdeman import bergh_tijdeman
from sensor.pneumatic.choked_flow import isothermal_flow
from sensor.pneumatic.cylinder import FixedChambers
from sensor.pneumatic.lines import (
    DeadVolume,
    Distributed,
    RicherHurmuzlu,
    TwoVolume,
    attenuation_factor,
    make_line,
    tube_resistance,
)
from sensor.pneumatic.plant import Plant
from sensor.pneumatic.sensors import ideal_sensors
from sensor.pneumatic.simulate import constant_command, simulate
from sensor.pneumatic.unsteady import fitted_kernels, kernel_errors
from sensor.pneumatic.valve import ENFIELD_LH05, Valve

BORE = 0.004
END_VOLUME = 1.0e-5      # chamber-sized end volume (m^3), about a 16 mm cylinder at mid-stroke


def _fixed(line, volume=END_VOLUME, **kw):
    return Plant(line_1=line, line_2=line, actuator=FixedChambers(volume, volume), **kw).compile()


def _first_peak(response, f_lo, f_hi):
    """Frequency (Hz) of the first resonance peak of |response(f)|, refined by a bounded search."""
    f = np.linspace(f_lo, f_hi, 400)
    amp = np.abs(response(f))
    i = argrelmax(amp)[0][0]
    res = minimize_scalar(lambda x: -abs(response(np.array([x]))[0]), bounds=(f[i - 1], f[i + 1]),
                          method="bounded", options={"xatol": 1e-4})
    return res.x


@pytest.mark.parametrize("mean_pressure", [1.0e5, 5.0e5])
@pytest.mark.parametrize("length", [2.0, 7.25, 10.0])
def test_distributed_line_matches_bergh_tijdeman(length, mean_pressure):
    # Spec (issue 7): first resonance within 5 %, amplitude ratio within 10 % up to 80 % of it.
    model = _fixed(Distributed(length, BORE, segments=20)).linear_line_model(mean_pressure)

    def reference(f):
        return bergh_tijdeman(f, length, BORE, END_VOLUME, mean_pressure)

    f_hi = 3.0 * AIR.speed_of_sound / (4.0 * length)
    f_model = _first_peak(model, 0.2, f_hi)
    f_ref = _first_peak(reference, 0.2, f_hi)
    res_err = f_model / f_ref - 1.0
    f = np.linspace(0.05 * f_ref, 0.8 * f_ref, 60)
    amp_err = np.max(np.abs(np.abs(model(f)) / np.abs(reference(f)) - 1.0))
    print(f"L={length} P={mean_pressure:.0f}: f_res {f_model:.3f} vs {f_ref:.3f} Hz "
          f"({100 * res_err:+.2f} %), max amplitude error {100 * amp_err:.2f} %")
    assert abs(res_err) < 0.05
    assert amp_err < 0.10


def test_steady_friction_isothermal_line_misses_the_resonance():
    # Why the frequency-dependent terms are there: without them the 7.25 m line at 5 bar puts its
    # peak far too high (under-damped).
    length, p = 7.25, 5.0e5
    plain = _fixed(Distributed(length, BORE, segments=20, unsteady_friction=False, heat_transfer=False))
    f = np.linspace(1.0, 20.0, 400)
    h_plain = np.abs(plain.linear_line_response(f, p))
    h_ref = np.abs(bergh_tijdeman(f, length, BORE, END_VOLUME, p))
    assert h_plain.max() / h_ref.max() > 1.3


def test_bergh_tijdeman_reduces_to_the_lossless_tube():
    # Vanishing viscosity: p_end/p_in = 1 / (cos(th) - (V/Vt) (gamma/k) th sin(th)), th = w L / a0,
    # adiabatic gas (closed form of the acoustic tube ending in a volume).
    air = Air(viscosity_Pa_s=1e-9)
    length, f = 7.25, np.array([1.0, 3.0, 6.0])
    th = 2 * np.pi * f * length / air.speed_of_sound
    vt = math.pi * BORE**2 / 4 * length
    exact = 1 / (np.cos(th) - END_VOLUME / vt * air.gamma * th * np.sin(th))
    got = bergh_tijdeman(f, length, BORE, END_VOLUME, 1e5, air=air)
    assert np.allclose(got, exact, rtol=1e-2)


def test_kernel_fit_accuracy():
    # The fitted exponential kernels against the exact Bessel kernels (module docstring): < 1 %.
    ez, ey = kernel_errors(fitted_kernels())
    assert ez < 0.01 and ey < 0.01


def test_distributed_line_converges_with_segments():
    # Differences to a 40-segment line shrink as N grows (relative to the peak |H|).
    f = np.linspace(1.0, 50.0, 50)
    ref = _fixed(Distributed(2.0, BORE, segments=40)).linear_line_response(f, 2e5)
    errors = [np.max(np.abs(_fixed(Distributed(2.0, BORE, segments=n)).linear_line_response(f, 2e5) - ref))
              / np.max(np.abs(ref)) for n in (5, 10, 20)]
    assert errors[0] > errors[1] > errors[2]
    assert errors[-1] < 0.05   # 20 vs 40 segments: within 5 % of the peak, resonance included


def _step(line, duration=0.3, volume=4.5e-5):
    valve = Valve("weak", (-1.0, 1.0), (0.0, 2e-9), (2e-9, 0.0))
    cp = _fixed(line, volume, valve=valve)
    return simulate(cp, constant_command(1.0), duration, sensors=ideal_sensors())


def test_short_lines_approach_the_dead_volume_model():
    # L -> 0: every model's chamber pressure tends to the dead-volume model (eq 16).
    ref = _step(DeadVolume(0.05)).pressure_chamber.sel(side=1).values
    for line in (TwoVolume(0.05), Distributed(0.05, segments=2), RicherHurmuzlu(0.05)):
        got = _step(line).pressure_chamber.sel(side=1).values
        assert np.max(np.abs(got - ref)) / np.ptp(ref) < 0.02, type(line).__name__


def test_richer_hurmuzlu_delay_is_length_over_speed_of_sound():
    line = RicherHurmuzlu(7.25)
    assert line.delay_s(AIR.speed_of_sound) == pytest.approx(7.25 / 343.2, rel=2e-3)
    rate = 20000.0
    cp = _fixed(line)
    ds = simulate(cp, constant_command(1.0), 0.04, rate_Hz=rate, sensors=ideal_sensors())
    flow = ds.chamber_mass_flow.sel(side=1).values
    first = ds.time.values[np.argmax(flow > 0)]
    assert abs(first + 1 / rate - 7.25 / AIR.speed_of_sound) <= 1.5 / rate


def test_tube_resistance_and_attenuation_eq_4_5():
    mu = AIR.viscosity_Pa_s
    assert tube_resistance(1e-5, BORE, mu) == pytest.approx(32 * mu / BORE**2)
    m = 2e-3
    re = 4 * m / (math.pi * BORE * mu)
    assert tube_resistance(m, BORE, mu) == pytest.approx(0.158 * mu * re**0.75 / BORE**2)
    a = attenuation_factor(1e-5, 7.25, BORE, 2e5, AIR)
    assert a == pytest.approx(math.exp(-32 * mu / BORE**2 * AIR.rt * 7.25 / (2 * 2e5 * AIR.speed_of_sound)))


def test_steady_laminar_flow_matches_hagen_poiseuille():
    # Isothermal compressible Hagen-Poiseuille, p1^2 - p2^2 = G^2 R T (64/Re L/D + 2 ln(p1/p2)), i.e.
    # m = pi D^4 (p1^2 - p2^2) / (256 mu R T L) plus the acceleration term, from the static inlet
    # pressure p1 that the isentropic entrance leaves of the port node's pressure (the reference of
    # sensor.pneumatic.choked_flow; without the entrance the flow would be 3.9 % higher here).
    length = 2.0
    cp = _fixed(Distributed(length, BORE, segments=20), volume=1.0e-2,
                valve=Valve("weak", (-1.0, 1.0), (0.0, 1.0e-10), (1.0e-10, 0.0)))
    ds = simulate(cp, constant_command(1.0), 1.5, sensors=ideal_sensors())
    last = ds.states.isel(time=-1)
    p_in = float(last.sel(state="side1_pressure_0"))
    p_out = float(last.sel(state="side1_pressure_20"))
    m_mid = float(last.sel(state="side1_flow_10"))
    expected, choked = isothermal_flow(p_in, p_out, length, BORE)
    assert not choked and AIR.reynolds(m_mid, BORE) < 2300
    assert m_mid == pytest.approx(expected, rel=0.01)


@pytest.mark.parametrize("make, word", [
    (lambda: Distributed(0.0), "length_m"),
    (lambda: Distributed(-1.0), "length_m"),
    (lambda: TwoVolume(2.0, bore_m=0.0), "bore_m"),
    (lambda: DeadVolume(float("nan")), "length_m"),
    (lambda: Distributed(2.0, segments=0), "segments"),
    (lambda: make_line("pipe", 2.0), "line model"),
    (lambda: FixedChambers(0.0, 1e-5), "volume_1_m3"),
    (lambda: FixedChambers(1e-5, -1e-5), "volume_2_m3"),
    (lambda: Plant(supply_Pa=0.9e5), "supply_Pa"),
])
def test_bad_line_and_plant_input(make, word):
    with pytest.raises(SensorError, match=word):
        make()


def test_time_step_above_line_stability_is_refused():
    cp = _fixed(Distributed(2.0, segments=40))
    with pytest.raises(SensorError, match="stability limit"):
        simulate(cp, constant_command(0.0), 0.01, substep_s=1e-3)


def test_overlapped_valve_is_shut_at_centre():
    cp = _fixed(Distributed(2.0, segments=4), valve=ENFIELD_LH05)
    assert cp._shut_command() == 0.0
