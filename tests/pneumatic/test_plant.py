"""Plant and harness: conservation laws, thermodynamic limits, integrator vs scipy Radau, errors."""
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from sensor.errors import SensorError
from sensor.pneumatic.cylinder import (
    Cylinder,
    FixedChambers,
    mass_spring_damper,
    spring_contact,
)
from sensor.pneumatic.lines import DeadVolume, Distributed, TwoVolume
from sensor.pneumatic.plant import Plant
from sensor.pneumatic.sensors import Encoder, NoisyQuantised, Sensors, ideal_sensors
from sensor.pneumatic.simulate import MEASUREMENT_KEYS, constant_command, simulate
from sensor.pneumatic.valve import ENFIELD_LH05


def test_closed_system_conserves_mass():
    # Valve shut (overlapped spool at u = 0), unequal sides: the piston moves, gas leaks across
    # it and waves run in both distributed lines, yet the total gas mass stays constant.
    cp = Plant(valve=ENFIELD_LH05, line_1=Distributed(2.0, segments=20), line_2=Distributed(2.0, segments=20),
               environment=spring_contact(2000.0, 0.03)).compile()
    x0 = cp.initial_state(3.0e5, 1.5e5, 0.02)
    ds = simulate(cp, constant_command(0.0), 0.3, initial_state=x0, sensors=ideal_sensors())
    masses = np.array([cp.gas_mass(x) for x in ds.states.values])
    assert np.ptp(ds.piston_position.values) > 1e-3            # something really happened
    assert np.max(np.abs(masses / masses[0] - 1.0)) < 1e-10   # round-off only


def test_isothermal_chambers_at_rest_hold_their_pressure():
    cp = Plant(valve=ENFIELD_LH05, line_1=Distributed(7.25), line_2=TwoVolume(7.25),
               actuator=FixedChambers()).compile()
    ds = simulate(cp, constant_command(0.0), 0.5, initial_state=cp.initial_state(4e5, 2e5),
                  sensors=ideal_sensors())
    p = ds.pressure_chamber.values
    assert np.allclose(p[:, 0], 4e5, rtol=1e-12) and np.allclose(p[:, 1], 2e5, rtol=1e-12)


@pytest.mark.parametrize("r", [1.0, 1.4])
def test_closed_chambers_follow_the_polytrope(r):
    # No leak, valve shut, zero-length lines: eq 15 integrates to P V^r = const in each chamber
    # (isothermal r = 1, adiabatic r = 1.4), while the piston oscillates on a spring.
    cyl = Cylinder(leak_kg_s_Pa=0.0, polytropic=r, coulomb_N=0.0)
    cp = Plant(valve=ENFIELD_LH05, line_1=DeadVolume(0.0), line_2=DeadVolume(0.0), actuator=cyl,
               environment=mass_spring_damper(0.1, 3000.0, 0.0, 0.025)).compile()
    ds = simulate(cp, constant_command(0.0), 0.2, initial_state=cp.initial_state(2.5e5, 1.2e5, 0.025),
                  sensors=ideal_sensors())
    z = ds.piston_position.values
    v1, v2 = cyl.volumes(z)
    p = ds.pressure_chamber.values
    assert np.ptp(z) > 5e-3
    for pv in (p[:, 0] * v1**r, p[:, 1] * v2**r):
        assert np.max(np.abs(pv / pv[0] - 1.0)) < 1e-3   # first-order stepping, h = 0.1 ms


def _radau(cp, u, duration, times):
    x0 = cp.initial_state()
    sol = solve_ivp(lambda t, x: cp.derivative(x, u), (0, duration), x0, method="Radau", rtol=1e-8,
                    atol=1e-10 * np.maximum(1.0, np.abs(x0)), t_eval=times)
    return sol.y.T


# the chamber-mass and spool states do not feed back with isothermal chambers and an ideal spool:
# their zero Jacobian columns make scipy's numerical Jacobian grow its step until it overflows (harmless)
@pytest.mark.filterwarnings("ignore:overflow encountered in multiply:RuntimeWarning")
@pytest.mark.parametrize("line", [TwoVolume(7.25), Distributed(2.0, segments=2)], ids=["two-volume", "distributed"])
def test_stepper_agrees_with_scipy_radau(line):
    # Same physics, two integrators: the fixed-rate stepper (default substep) against Radau at tight
    # tolerance, for a full-open valve filling chamber 1 and venting chamber 2 against a spring.
    # Tolerance: 1.5 % of the pressure swing and 1 mm of piston travel (first-order stepper); halving
    # the substep must shrink the error (convergence).
    cp = Plant(line_1=line, line_2=line, environment=spring_contact(3000.0, 0.03)).compile()
    duration = 0.06
    ds = simulate(cp, constant_command(0.6), duration, sensors=ideal_sensors())
    ref = _radau(cp, 0.6, duration, ds.time.values)
    ends = [cp.pressure_slice(s).stop - 1 for s in (0, 1)]
    err_p = np.max(np.abs(ds.pressure_chamber.values - ref[:, ends])) / np.ptp(ref[:, ends])
    err_z = np.max(np.abs(ds.piston_position.values - ref[:, 0]))
    fine = simulate(cp, constant_command(0.6), duration, sensors=ideal_sensors(), substep_s=ds.attrs["substep_s"] / 2)
    err_fine = np.max(np.abs(fine.pressure_chamber.values - ref[:, ends])) / np.ptp(ref[:, ends])
    assert err_p < 0.015 and err_z < 1e-3
    assert err_fine < 0.75 * err_p


def test_harness_calls_controller_at_fixed_rate_with_pluggable_force_sensor():
    calls, reads = [], []

    class RecordingForce:
        def read(self, force_N, t):
            reads.append((t, force_N))
            return force_N

    def controller(t, m):
        calls.append((t, dict(m)))
        return 0.5 if t < 0.05 else -0.5

    sensors = ideal_sensors()
    sensors.force = RecordingForce()
    sensors.position = Encoder(1e-5)
    cp = Plant(line_1=TwoVolume(2.0), line_2=TwoVolume(2.0), environment=spring_contact(2000.0, 0.026)).compile()
    ds = simulate(cp, controller, 0.1, rate_Hz=500.0, sensors=sensors)
    times = np.array([t for t, _ in calls])
    assert np.allclose(np.diff(times), 1 / 500.0) and len(calls) == 50
    assert set(calls[0][1]) == set(MEASUREMENT_KEYS)
    assert len(reads) == 51 and max(f for _, f in reads) > 0.5        # the spring was pushed
    enc = ds.measured_position_m.values
    assert np.allclose(enc / 1e-5, np.round(enc / 1e-5))               # encoder counts
    assert ds.states.sizes["state"] == cp.n_states and "side1_flow_0" in ds.state.values
    assert np.all(ds.command.values[:-1] == np.where(times < 0.05, 0.5, -0.5))
    assert ds.environment_force.attrs["units"] == "N"


def test_default_sensors_are_noisy_and_quantised():
    cp = Plant(line_1=TwoVolume(2.0), line_2=TwoVolume(2.0), actuator=FixedChambers()).compile()
    ds = simulate(cp, constant_command(0.0), 0.05, sensors=Sensors())
    err = ds.measured_pressure_chamber_1_Pa.values - ds.pressure_chamber.sel(side=1).values
    assert 50.0 < np.std(err) < 500.0
    assert np.allclose(ds.measured_pressure_chamber_1_Pa.values / 50.0,
                       np.round(ds.measured_pressure_chamber_1_Pa.values / 50.0))


def test_compiled_sensor_readings_equal_the_sensor_objects_reads():
    # Plain NoisyQuantised / Encoder sensors are read inside the compiled loop from noise drawn
    # in one batch; subclasses (the same read methods, but not the exact types) take the Python
    # reads.  Both must give identical readings, commands and states - no tolerance, the same
    # arithmetic on the same noise stream - and leave the streams where the reads leave them: a
    # second run with the same sensor objects continues identically, and so does a run stopped
    # by the controller after 5 periods.
    class Pot(NoisyQuantised):
        pass

    class Enc(Encoder):
        pass

    def sensor_set(noisy, encoder):
        # force, then pressures at the valve ports and chambers; position from the encoder
        s = Sensors(encoder(1e-5), *(noisy(noise, resolution, seed) for noise, resolution, seed in
                                     ((0.02, 0.005, 2), (200.0, 50.0, 3), (200.0, 0.0, 4), (0.0, 50.0, 5),
                                      (100.0, 50.0, 6))))
        return s

    def pi(t, m):
        return 0.002 * (5.0 - m["force_N"]) + 0.1 * m["velocity_m_s"]

    def stop_after_5(t, m):
        if t > 0.0045:
            raise RuntimeError("stop")
        return 0.3

    cp = Plant(line_1=TwoVolume(2.0), line_2=Distributed(2.0, segments=4),
               environment=spring_contact(2000.0, 0.026)).compile()
    runs = []
    for sensors in (sensor_set(NoisyQuantised, Encoder), sensor_set(Pot, Enc)):
        first = simulate(cp, pi, 0.05, sensors=sensors)
        with pytest.raises(RuntimeError, match="stop"):
            simulate(cp, stop_after_5, 0.05, sensors=sensors)
        runs.append((first, simulate(cp, pi, 0.03, sensors=sensors)))
    for a, b in zip(*runs):
        for var in a.data_vars:
            assert np.array_equal(a[var].values, b[var].values, equal_nan=True), var
    assert np.std(runs[0][0].measured_force_N.values - runs[0][0].environment_force.values) > 0.005


def test_compiled_reads_of_a_shared_sensor_and_of_a_fine_resolution_equal_the_python_reads():
    # one sensor object in both valve slots takes alternate draws of its one stream (so it is
    # read in Python), and a resolution far below the value (value / resolution > 2^63, where
    # an integer floor would overflow) keeps the Python arithmetic in the compiled reads
    class Pot(NoisyQuantised):
        pass

    cp = Plant(line_1=TwoVolume(2.0), line_2=TwoVolume(2.0)).compile()
    runs = []
    for kind in (NoisyQuantised, Pot):
        shared = kind(200.0, 0.0, 3)
        fine = Sensors(Encoder(1e-5), kind(0.0, 1e-18, 2), shared, shared, kind(0.0, 1e-15, 5), kind(100.0, 50.0, 6))
        runs.append(simulate(cp, lambda t, m: 0.2, 0.02, sensors=fine))
    for var in runs[0].data_vars:
        assert np.array_equal(runs[0][var].values, runs[1][var].values, equal_nan=True), var
    valve_1, valve_2 = runs[0].measured_pressure_valve_1_Pa.values, runs[0].measured_pressure_valve_2_Pa.values
    assert np.all(valve_1 != valve_2)      # two different draws, not one draw twice
    # the finely resolved chamber reading is the chamber pressure itself (at least the atmosphere)
    assert np.all(runs[0].measured_pressure_chamber_1_Pa.values > 1e5)


def test_non_finite_command_and_runaway_states_stop_with_a_named_error():
    cp = Plant(line_1=TwoVolume(2.0), line_2=TwoVolume(2.0)).compile()
    with pytest.raises(SensorError, match=r"controller returned command nan at t = 0\.002"):
        simulate(cp, lambda t, m: float("nan") if t > 0.0015 else 0.0, 0.01)
    x0 = cp.initial_state()
    x0[cp.labels.index("side2_flow_0")] = math.nan
    with pytest.raises(SensorError, match=r"t = 0 s: state side2_flow_0 = nan"):
        simulate(cp, constant_command(0.0), 0.01, initial_state=x0)
    # a state that runs away during the run: the highest supply a plant accepts (1e8 Pa) overshoots
    # in the two-volume line past the 1e8 Pa sanity bound; the error names the state and a time
    # after the start
    wild = Plant(supply_Pa=1e8, line_1=TwoVolume(2.0), line_2=TwoVolume(2.0)).compile()
    with pytest.raises(SensorError, match=r"stopped at t = 0\.0\d+ s: state side1_pressure_1 = "):
        simulate(wild, constant_command(1.0), 0.5)


@pytest.mark.parametrize("kwargs, word", [
    (dict(duration_s=0.0), "duration_s"),
    (dict(duration_s=0.1, rate_Hz=-1.0), "rate_Hz"),
    (dict(duration_s=0.1, initial_state=np.zeros(3)), "initial_state"),
])
def test_bad_simulation_input(kwargs, word):
    cp = Plant(line_1=TwoVolume(2.0), line_2=TwoVolume(2.0)).compile()
    with pytest.raises(SensorError, match=word):
        simulate(cp, constant_command(0.0), **kwargs)


@pytest.mark.parametrize("make, word", [
    (lambda: Cylinder(bore_m=0.0), "bore_m"),
    (lambda: Cylinder(rod_m=0.02), "rod_m"),
    (lambda: Cylinder(polytropic=1.6), "polytropic"),
    (lambda: Plant().compile().initial_state(position_m=1.0), "position_m"),
])
def test_bad_actuator_input(make, word):
    with pytest.raises(SensorError, match=word):
        make()


def test_progress_counts_every_control_period_up_to_the_end():
    cp = Plant(line_1=TwoVolume(2.0), line_2=TwoVolume(2.0)).compile()
    seen = []
    simulate(cp, constant_command(0.2), 2.5, progress=lambda done, total: seen.append((done, total)))
    # every PROGRESS_PERIODS (1000) control periods from 0, and the last of the 2500
    assert seen == [(0, 2500), (1000, 2500), (2000, 2500), (2500, 2500)]
