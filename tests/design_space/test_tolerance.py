"""The tolerance report and the robust design against independent estimates: the range
sensitivities against a regression over the Monte Carlo draws, the yield against its exact
value, the zero-scatter limit, and the robust design's chance constraints on fresh draws."""

from functools import lru_cache

import numpy as np
import pytest
from scipy.stats import norm

from geometry.params import Design
from geometry.process import WATER_JET, Process
from sensor.design_space.optimise import DesignProblem, optimise
from sensor.design_space.robust import BAND, STRESS_PROBABILITY, robust
from sensor.design_space.scatter import as_cut
from sensor.design_space.tolerance import draws_z, part_statistics, range_sensitivity, tolerance

#: The 5 N optimum of the current model (any body of 0.3-0.5 mm hinges serves).
DESIGN = Design(phi1_deg=28.36, phi2_deg=12.97,
                hinge_thickness_mm=(0.3, 0.3, 0.3, 0.5069, 0.5069, 0.3, 0.3, 0.3, 0.3, 0.3, 0.3, 0.3))


def test_zero_scatter_gives_the_nominal_part():
    t = tolerance(DESIGN, Process(offset_mm=0.0, sd_mm=1e-9), draws=20)
    from sensor.design_space.optimise import solve_designs
    _, r = solve_designs([DESIGN], 1.0)[0]
    assert t.range_N_p5 == pytest.approx(r.input_force_N, rel=1e-6)
    assert t.range_N_p95 == pytest.approx(r.input_force_N, rel=1e-6)
    assert t.yield_fraction == 1.0


def test_range_sensitivity_matches_a_regression_over_the_draws():
    """Small scatter (SD 0.005 mm, linear regime): the least-squares slope of range on each
    pair's mean deviation over 400 draws equals the central-difference sensitivity within
    10 % of the largest sensitivity (regression noise of 400 draws)."""
    sd = 0.005
    z = draws_z(400, 3)
    cut = as_cut(DESIGN, z, sd)
    rng = part_statistics(cut)["range_N"]
    sens = range_sensitivity(DESIGN)
    pairs = [(int(a), int(b)) for a, b in (k.split("-") for k in sens)]
    X = np.column_stack([sd * (z[:, a - 1] + z[:, b - 1]) / 2 for a, b in pairs] + [np.ones(len(z))])
    slope = np.linalg.lstsq(X, rng, rcond=None)[0][:-1] * 0.01   # N per 0.01 mm of the pair (mean)
    big = max(abs(v) for v in sens.values())
    for (k, v), s in zip(sens.items(), slope):
        assert s == pytest.approx(v, abs=0.1 * big), (k, s, v)


def test_yield_matches_its_exact_value():
    """P(every used hinge >= min_feature) = prod Phi((t + offset - f) / SD): the Monte Carlo
    yield of 2000 draws within 3 binomial SDs."""
    t = tolerance(DESIGN, WATER_JET, draws=2000, seed=5)
    th = np.array(DESIGN.used_thickness_mm)
    exact = float(np.prod(norm.cdf((th + WATER_JET.offset_mm - DESIGN.min_feature_mm) / WATER_JET.sd_mm)))
    assert t.yield_fraction == pytest.approx(exact, abs=3 * np.sqrt(exact * (1 - exact) / 2000))


@lru_cache(maxsize=None)
def robust_answer(range_N: float, off_toggle: bool = False):
    """(nominal answer, robust result) of ``dacm design --range range_N --robust``."""
    p = DesignProblem(range_N, off_toggle=off_toggle)
    nominal = optimise(p).design
    return nominal, robust(p, nominal)


@pytest.mark.parametrize("range_N", [5.0, 15.0])
def test_robust_design_keeps_its_chance_constraints_on_fresh_draws(range_N):
    """The robust 5 and 15 N designs, re-cut with 1000 draws of another seed: P(stress >
    allowable) at most 5 % + 2 binomial SDs (1.4 %), the range band inside +-10 % (+1 % for
    the percentiles' sampling), yield >= 0.9; and the median H no lower than the nominal
    design's (robustness has a price, never a gain). The search holds the constraints for
    the process (robust.SEARCH_BAND, SEARCH_STRESS_PROBABILITY on the response surface's
    4096 draws), so other parts than the report's keep them too."""
    nominal, rob = robust_answer(range_N)
    fresh = tolerance(rob.design, draws=1000, seed=99)
    assert fresh.p_over_stress <= STRESS_PROBABILITY + 0.014
    assert fresh.range_N_p5 >= (1 - BAND - 0.01) * range_N and fresh.range_N_p95 <= (1 + BAND + 0.01) * range_N
    assert fresh.yield_fraction >= 0.9
    assert fresh.hysteresis_fraction_p50 >= tolerance(nominal, draws=1000, seed=99).hysteresis_fraction_p50


@pytest.mark.parametrize("range_N", [5.0, 15.0])
def test_robust_design_keeps_its_chance_constraints_for_the_process(range_N):
    """``met`` covers the process, not only the report's 200 parts: on the response
    surface's 4096 draws the robust design's band is inside +-10 % and P(stress) at most 5 %
    (robust._process_misses finds nothing), where the nominal answer's parts miss (control:
    the check can fail; its band sits above the range)."""
    from sensor.design_space.robust import _process_misses

    nominal, rob = robust_answer(range_N)
    p = DesignProblem(range_N)
    assert rob.met and not _process_misses(p, rob.design)
    assert any("range band" in why for why in _process_misses(p, nominal))


def test_robust_drawing_moves_with_the_seed_only_where_its_report_misses():
    """The first pass reads the process off the response surface's fixed draws, not the
    report's parts; where a seed's report misses at its end, the second pass moves the
    drawing. At 5 N seed 0's report keeps the constraints at the first end (32.80/17.38,
    median H 0.0377) and seed 2's misses there: its 200 parts sit about 1 % below the
    process, and the second pass narrows the band to keep both (32.80/19.43, H 0.0437).
    Both are met, for the process too, and within 20 % in H (measured 15.9 %: the price of
    a band narrow enough for an unlucky sample too; 8 % on the search before stop 58). (The
    Monte Carlo search it replaced, which read 64 of the report's parts, ended 38 % apart in
    H at 10 N between seeds.)"""
    from sensor.design_space.robust import _process_misses

    nominal, rob0 = robust_answer(5.0)
    rob2 = robust(DesignProblem(5.0), nominal, seed=2)
    assert rob0.met and rob2.met and not _process_misses(DesignProblem(5.0), rob2.design)
    h0, h2 = rob0.tolerance.hysteresis_fraction_p50, rob2.tolerance.hysteresis_fraction_p50
    assert max(h0, h2) <= 1.20 * min(h0, h2), (h0, h2)


@pytest.mark.parametrize("shift_deg", [-0.01, 0.01])
def test_robust_answer_does_not_hang_on_a_quantum_of_its_start(shift_deg):
    """The 5 N search started from the nominal answer with phi2 one written quantum (0.01
    deg) off ends within 1 % of the median H it ends at from the answer itself (measured
    0.4 %). With sample percentiles and a phase one to the deepest point inside the
    constraints, these starts ended at H 0.0397 and 0.0575 against 0.0419 (stop 57): the
    search ran out its boxes wherever its start's jumps took it."""
    nominal, rob = robust_answer(5.0)
    moved = robust(DesignProblem(5.0), nominal.replace(phi2_deg=round(nominal.phi2_deg + shift_deg, 2)))
    h, h_moved = rob.tolerance.hysteresis_fraction_p50, moved.tolerance.hysteresis_fraction_p50
    assert moved.met and h_moved == pytest.approx(h, rel=0.01)


def test_robust_answer_next_to_the_toggle_is_no_worse_than_off_it():
    """Keeping off the toggle narrows the problem, so the default robust answer can only be
    as good or better: at 15 N the nominal answer is next to the toggle (phi2 7.67 deg). On
    the model before the oblique root's coupling the search from it alone ended at median H
    0.1598, against 0.1143 for `--robust --off-toggle`; starting from the off-toggle answer
    too (robust._starts), it ended at that drawing (0.1142; within 1 % allows for one
    quantum of the written drawing)."""
    _, rob = robust_answer(15.0)
    _, off = robust_answer(15.0, off_toggle=True)
    assert rob.met and off.met
    assert rob.tolerance.hysteresis_fraction_p50 <= 1.01 * off.tolerance.hysteresis_fraction_p50


def test_robust_answer_does_not_depend_on_where_the_searches_run():
    """At 15 N the robust search runs from two starts (the nominal answer is next to the
    toggle); on two worker processes, side by side, it writes the same design with the
    same report as in this process (each start's search runs BLAS on one thread). On a
    machine of one core the pool is this process (execution.local_workers caps it), and
    this test checks nothing more than the others."""
    from sensor.design_space.execution import task_pool

    nominal, here = robust_answer(15.0)
    with task_pool(2) as pool:
        there = robust(DesignProblem(15.0), nominal, pool=pool)
    assert there.design == here.design and there.tolerance == here.tolerance and there.met == here.met


def test_centring_brings_a_narrow_off_centre_band_inside():
    """An equal-hinge basis body (0.5 mm) asked for its drawn range: its parts come out about
    7 % stiffer (the process' +0.012 mm on 0.5 mm, cubed), so the band sits high; eight
    hinges of 0.5 mm with SD 0.025 mm make it about 1.19 wide (p95/p5), inside the allowed
    1.1/0.9 = 1.22, so centring alone must bring it inside, every hinge scaled by one
    factor (their ratios kept within the written 0.1 um), for the process too."""
    from sensor.design_space.optimise import solve_designs, written
    from sensor.design_space.robust import _centred, _process_violation, _violation

    body = Design(phi1_deg=30.0, phi2_deg=None, hinge_thickness_mm=(0.5,) * 12)
    _, r = solve_designs([body], 1.0)[0]
    p = DesignProblem(r.input_force_N, body="basis")
    d = written(p, body, "off-centre")
    tol = tolerance(d)
    assert _violation(p, tol) > 0 and tol.range_N_p95 / tol.range_N_p5 < 1.1 / 0.9
    centred, ctol, read = _centred(p, d, tol, 200, 0, "centred")
    assert _violation(p, ctol) <= 0, (ctol.range_N_p5, ctol.range_N_p95, ctol.p_over_stress)
    assert _process_violation(p, read) <= 0, read
    t = np.array(centred.used_thickness_mm)
    assert np.ptp(t) <= 2e-4 and t[0] < 0.5
