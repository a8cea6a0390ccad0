"""Valve flow against the ISO 6358 limits (eq 14, Appendix A eq 88 as corrected in DESIGN 12)."""
import math

import numpy as np
import pytest

from sensor.errors import SensorError
from sensor.pneumatic.air import AIR
from sensor.pneumatic.valve import ENFIELD_LH05, FESTO_MPYE, LAMINAR_RATIO, Valve

C = 1.0e-8
PU = 6.0e5
K_REF = AIR.rho0_kg_m3 * math.sqrt(AIR.t0_K / AIR.temperature_K)


def test_choked_branch_is_iso_6358_sonic_flow():
    # ISO 6358: for P_d / P_u <= b the flow is C rho0 sqrt(T0/T) P_u, independent of P_d (exact).
    b = FESTO_MPYE.critical_ratio
    flows = FESTO_MPYE.orifice(C, PU, np.array([0.0, 0.1, b]) * PU)
    assert np.allclose(flows, C * K_REF * PU, rtol=1e-12)


def test_subsonic_branch_is_the_ellipse():
    # Independent evaluation of the corrected eq 88 at a ratio between b and r_lam.
    b = FESTO_MPYE.critical_ratio
    r = 0.7
    expected = C * K_REF * PU * math.sqrt(1 - ((r - b) / (1 - b)) ** 2)
    assert FESTO_MPYE.orifice(C, PU, r * PU) == pytest.approx(expected, rel=1e-12)


def test_flow_continuous_monotonic_and_zero_at_equal_pressures():
    pd = np.linspace(0.0, 2.0 * PU, 20001)
    m = FESTO_MPYE.orifice(C, PU, pd)
    assert FESTO_MPYE.orifice(C, PU, PU) == 0.0
    assert np.all(np.diff(m) <= 0.0)                       # monotonic in P_d
    # continuity: the largest jump between neighbours is bounded by the laminar slope times the
    # grid step (the steepest part of the curve), i.e. no discontinuity anywhere
    b = FESTO_MPYE.critical_ratio
    s = (LAMINAR_RATIO - b) / (1 - b)
    slope = C * K_REF * math.sqrt(1 - s * s) / (1 - LAMINAR_RATIO)
    assert np.max(np.abs(np.diff(m))) <= slope * (pd[1] - pd[0]) * 1.0001
    # reversed flow is the mirror image
    assert FESTO_MPYE.orifice(C, 4e5, 5e5) == pytest.approx(-FESTO_MPYE.orifice(C, 5e5, 4e5), rel=1e-12)


def test_four_way_ports_have_opposite_areas():
    sup = 6e5
    for valve in (FESTO_MPYE, ENFIELD_LH05):
        for u in (0.3, 1.0):
            assert valve.mass_flow(u, sup, 3e5, port=1) > 0 > valve.mass_flow(u, sup, 3e5, port=2)
            assert valve.mass_flow(-u, sup, 3e5, port=1) < 0 < valve.mass_flow(-u, sup, 3e5, port=2)
    # overlapped Enfield: both orifices shut at the centre; underlapped Festo leaks <= 1.5 % (Appendix A)
    assert ENFIELD_LH05.conductances(0.0) == (0.0, 0.0)
    cs, ce = FESTO_MPYE.conductances(0.0)
    assert 0 < cs <= 0.015 * max(FESTO_MPYE.supply_conductance) and cs == ce


def test_inverse_calibration_round_trip():
    for c in (0.0, 2e-9, 7e-9, 1.4e-8):
        u = FESTO_MPYE.command_for_conductance(c)
        assert FESTO_MPYE.conductances(u)[0] == pytest.approx(c, rel=1e-9, abs=1e-20)


@pytest.mark.parametrize("kwargs, word", [
    (dict(command=(0.0, 0.0)), "command grid"),
    (dict(supply_conductance=(-1.0, 1e-8)), "supply_conductance"),
    (dict(critical_ratio=0.9995), "critical_ratio"),
])
def test_bad_valve_tables(kwargs, word):
    base = dict(name="x", command=(-1.0, 1.0), supply_conductance=(0.0, 1e-8), exhaust_conductance=(1e-8, 0.0))
    base.update(kwargs)
    with pytest.raises(SensorError, match=word):
        Valve(**base)


@pytest.mark.parametrize("u", [1.5, -1.01, float("nan")])
def test_valve_commands_outside_full_travel_are_errors(u):
    from sensor.errors import SensorError
    with pytest.raises(SensorError, match="valve command u"):
        FESTO_MPYE.mass_flow(u, 6e5, 3e5)
    with pytest.raises(SensorError, match="valve command u"):
        FESTO_MPYE.conductances(u)
