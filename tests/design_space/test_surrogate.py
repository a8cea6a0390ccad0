"""The response surface of a drawing's parts against the Monte Carlo that solves every part,
its mirror bookkeeping against direct solves, and its draws."""

import numpy as np
import pytest

from geometry.params import Design
from geometry.process import WATER_JET, Process
from sensor.design_space.optimise import DesignProblem
from sensor.design_space.scatter import as_cut
from sensor.design_space.surrogate import mirror_of, response_surface, surface_draws
from sensor.design_space.tolerance import draws_z, part_statistics
from sensor.mechanics.stress import hinge_stresses

#: The 10 N nominal answer of the model before this module (next to the toggle, phi2 12 deg:
#: a part thinner on one side sways, so its peak stress grows with |left - right| and about
#: 40 % of the parts pass the allowable stress: the hardest case for a smooth surface).
NEAR_TOGGLE = Design(phi1_deg=27.88, phi2_deg=12.0,
                     hinge_thickness_mm=(0.475, 0.3, 0.309, 0.8, 0.8, 0.309, 0.3, 0.475, 0.3, 0.3, 0.3, 0.3))
#: A body off the toggle (the 5 N optimum of an earlier model).
OFF_TOGGLE = Design(phi1_deg=28.36, phi2_deg=18.0,
                    hinge_thickness_mm=(0.3, 0.3, 0.3, 0.5069, 0.5069, 0.3, 0.3, 0.3, 0.3, 0.3, 0.3, 0.3))
LAW = DesignProblem(5.0).law


@pytest.mark.parametrize("design", [NEAR_TOGGLE, OFF_TOGGLE], ids=["near-toggle", "off-toggle"])
def test_surface_reads_the_parts_as_the_monte_carlo_solves_them(design):
    """On the same 400 draws: the range's 5th, 50th and 95th percentiles within 1.5 % (the
    surface keeps the range's curvature in each hinge but not the cross terms; measured 0.7 %
    at most), the median H within 2 % and P(stress > allowable) within 0.05 (of 400 parts:
    one binomial SD at 40 % is 0.025; measured 0.03 at most)."""
    z = draws_z(400, 11)
    mc = part_statistics(as_cut(design, z, WATER_JET.sd_mm, WATER_JET.offset_mm), LAW)
    sf = response_surface(design, WATER_JET, 1.0).parts(z, LAW)
    for q in (5, 50, 95):
        assert np.percentile(sf["range_N"], q) == pytest.approx(np.percentile(mc["range_N"], q), rel=0.015), q
    assert np.median(sf["hysteresis"]) == pytest.approx(np.median(mc["hysteresis"]), rel=0.02)
    assert np.mean(sf["utilisation"] > 1) == pytest.approx(np.mean(mc["utilisation"] > 1), abs=0.05)


def test_zero_scatter_gives_the_part_cut_at_the_offset():
    """SD -> 0: every part is the drawing cut at the offset (a direct solve of it)."""
    process = Process(offset_mm=0.012, sd_mm=1e-7)
    parts = response_surface(OFF_TOGGLE, process, 1.0).parts(draws_z(50, 0), LAW)
    one = part_statistics(as_cut(OFF_TOGGLE, np.zeros((1, 12)), 0.0, 0.012), LAW)
    assert np.allclose(parts["range_N"], one["range_N"][0], rtol=1e-5)
    assert np.allclose(parts["utilisation"], one["utilisation"][0], rtol=1e-5)


def test_a_right_hand_hinge_moves_as_its_mirror_image():
    """The surface solves only left-hand moves: its columns for the right-hand hinges (each
    hinge's utilisation when the twin moves) equal the central differences of direct solves
    of the right-hand moves, to 1e-6 (the layout is mirrored exactly; solver tolerance)."""
    s = response_surface(NEAR_TOGGLE, WATER_JET, 1.0)
    used = list(NEAR_TOGGLE.used_hinges)
    allow = NEAR_TOGGLE.material.allowable_stress_MPa
    for right in (8, 11):
        z = np.zeros((2, 12))
        z[0, right - 1], z[1, right - 1] = 1.0, -1.0
        cut = as_cut(NEAR_TOGGLE, z, WATER_JET.sd_mm, WATER_JET.offset_mm)
        up, down = ([hinge_stresses(m, r)[h].peak_MPa / allow for h in used] for m, r in zip(cut.models, cut.results))
        assert np.allclose(s.utilisation[1][:, right - 1], (np.array(up) - np.array(down)) / 2, atol=1e-6)
        direct = np.log([r.input_force_N for r in cut.results])
        assert s.log_range[1][right - 1] == pytest.approx((direct[0] - direct[1]) / 2, abs=1e-6)
    assert mirror_of(NEAR_TOGGLE)[8] == 1 and mirror_of(Design(phi2_deg=None))[4] == 5


def test_surface_draws_are_fixed_standard_normal_deviates():
    """The same for every call; mean 0 and SD 1 per hinge within 0.01 (a scrambled Sobol set
    of 4096 is far closer than random draws' 0.016)."""
    a, b = surface_draws(4096), surface_draws(4096)
    assert np.array_equal(a, b) and a.shape == (4096, 12)
    assert np.abs(a.mean(axis=0)).max() < 0.01 and np.abs(a.std(axis=0) - 1).max() < 0.01
