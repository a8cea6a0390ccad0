"""The analytic steady-flow references (sensor.pneumatic.choked_flow) against published values
and limits, independent of the plant."""
import math

import pytest

from sensor.pneumatic.air import AIR
from sensor.pneumatic.choked_flow import _flstar, _p_over_pstar, darcy_friction, fanno_flow, isothermal_flow


def test_fanno_functions_match_the_published_table():
    # Fanno table, gamma = 1.4 (e.g. NACA 1135 / Shapiro Table B.3): M = 0.5: 4 f L*/D = 1.0691,
    # p/p* = 2.1381; M = 0.2: 14.533, 5.4554; M = 1: 0 and 1 (4-decimal table values)
    for mach, fl, pp in ((0.5, 1.0691, 2.1381), (0.2, 14.533, 5.4554), (1.0, 0.0, 1.0)):
        assert _flstar(mach, 1.4) == pytest.approx(fl, abs=1e-4 * max(1, fl))
        assert _p_over_pstar(mach, 1.4) == pytest.approx(pp, abs=1e-4 * pp)


def test_references_reproduce_the_issue_numbers():
    # 4 mm x 1 m from 6 bar into the atmosphere: Fanno with an isentropic entrance 9.65 g/s,
    # isothermal with the entrance loss 9.23 g/s (issue 25's independent figures), both choked
    fan, fan_choked = fanno_flow(6e5, 101325.0, 1.0, 0.004)
    iso, iso_choked = isothermal_flow(6e5, 101325.0, 1.0, 0.004)
    assert fan == pytest.approx(9.65e-3, abs=0.005e-3) and fan_choked
    assert iso == pytest.approx(9.23e-3, abs=0.005e-3) and iso_choked


def test_short_tube_tends_to_the_isentropic_nozzle():
    # f L/D -> 0: Fanno flow becomes the choked isentropic nozzle A p0 sqrt(gamma / R T0)
    # (2 / (gamma + 1))^((gamma + 1) / (2 (gamma - 1))) (0.0404 A p0 / sqrt(T0) for air)
    g = AIR.gamma
    area = math.pi * 0.004**2 / 4
    nozzle = area * 6e5 * math.sqrt(g / AIR.rt) * (2 / (g + 1)) ** ((g + 1) / (2 * (g - 1)))
    assert fanno_flow(6e5, 101325.0, 1e-5, 0.004)[0] == pytest.approx(nozzle, rel=2e-3)


def test_low_pressure_drop_tends_to_incompressible_pipe_flow():
    # a small drop: rho ~ const, dp = f (L/D) rho u^2 / 2 (Darcy-Weisbach) for both references
    p0, drop, length, bore = 2e5, 200.0, 7.25, 0.004
    area = math.pi * bore**2 / 4
    for fn in (isothermal_flow, fanno_flow):
        m, choked = fn(p0, p0 - drop, length, bore)
        rho = p0 / AIR.rt
        u = m / (rho * area)
        assert not choked
        assert darcy_friction(AIR.reynolds(m, bore)) * length / bore * rho * u**2 / 2 == pytest.approx(drop, rel=0.01)
