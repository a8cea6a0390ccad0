"""The reachable range of a design problem (sensor.design_space.reach): it brackets every
feasible equal-hinge body of a dense scan, its ends are feasible, a family's bodies are found
once, and a range past the hysteresis law's domain is out of reach."""

import math
import re

import numpy as np
import pytest

from sensor.design_space.optimise import DesignProblem, accept, describe, evaluate, feasible, optimise
from sensor.design_space.reach import feasible_bodies, reachable_range
from sensor.errors import DesignError
from sensor.mechanics.hysteresis import H_LIMIT


def test_reach_brackets_every_feasible_equal_hinge_body_and_its_ends_are_feasible():
    """The reachable interval of the proposed body in delrin: no feasible equal-hinge body of
    a dense scan (2-degree angles, 30 thicknesses of 0.3-2 mm) lies outside it (1e-3 for the
    search's convergence), and a range just inside each end gets a body while one 5 % outside
    gets the one-line refusal naming the interval."""
    p = DesignProblem(1.0)
    lo, hi = reachable_range(p)
    axes = [np.arange(a, b, 2.0) for a, b in zip(p.lower[:2], p.upper[:2])]
    angles = np.array(np.meshgrid(*axes, indexing="ij")).reshape(2, -1).T
    ranges = []
    for t in np.geomspace(p.hinge_min_mm, p.hinge_max_mm, 30):
        Z = np.hstack([angles, np.full((len(angles), 6), math.log(t))])
        ranges += [math.exp(pt.log_range_error) for pt in evaluate(p, Z)
                   if feasible(p, pt, slack=0.005, in_range=False)]
    assert min(ranges) >= lo * (1 - 1e-3) and max(ranges) <= hi * (1 + 1e-3), (lo, hi, min(ranges), max(ranges))
    for r in (lo * 1.002, hi * 0.998):
        res = optimise(DesignProblem(r), n_starts=4)
        assert accept(DesignProblem(r), res.design)[0]
    for r in (lo * 0.95, hi * 1.05):
        with pytest.raises(DesignError, match=r"the reachable interval is [\d.]+ to [\d.]+ N"):
            optimise(DesignProblem(r), n_starts=4)


def test_a_familys_reach_is_found_once_and_families_do_not_share_it():
    """The reach's bodies depend on the family, not the range: a second range of the same
    family gets the very bodies found for the first (no search), a family that differs in one
    field (the hinges' upper bound) its own, and reachable_range reads them for each range."""
    first = feasible_bodies(DesignProblem(1.0))
    assert feasible_bodies(DesignProblem(7.0)) is first
    other = feasible_bodies(DesignProblem(1.0, hinge_max_mm=0.6))
    assert other is not first and max(pt.log_range_error for pt in other) < max(pt.log_range_error for pt in first)
    lo, hi = reachable_range(DesignProblem(7.0))
    assert (lo, hi) == (float(np.exp(first[0].log_range_error)), float(np.exp(first[-1].log_range_error)))


def test_a_range_past_the_hysteresis_laws_domain_is_out_of_reach():
    """40 N at 1 mm: the stiffest bodies the stress allows store about 16 mJ, where the
    strain-energy law would predict H near 1, past its domain (H_LIMIT = 0.5: 8.1 mJ with the
    basis calibration). `dacm design --range 40` returned such a body and then stopped in the
    sensor model. Now the range is out of reach, the message names the rule and the interval,
    and the interval's top is a body the law and the sensor model accept, as is the robust
    design from it."""
    from sensor.design_space.robust import robust

    with pytest.raises(DesignError, match=f"H < {H_LIMIT:g} reaches it") as err:
        optimise(DesignProblem(40.0), n_starts=2)
    top = float(re.search(r"reachable interval is [\d.]+ to ([\d.]+) N", str(err.value)).group(1))
    assert 20.0 < top < 40.0
    res = optimise(DesignProblem(round(0.98 * top, 2)), n_starts=2)
    assert res.hysteresis < H_LIMIT
    describe(res.design, res.problem)          # the sensor model accepts it
    # the robust search from it keeps to the domain too: `--robust` at 35 N stopped in the
    # sensor model (its drawing's H was 0.66); its parts' median H and its own are inside
    rob = robust(res.problem, res.design)
    assert rob.tolerance.hysteresis_fraction_p50 < H_LIMIT
    assert describe(rob.design, res.problem)["hysteresis"] < H_LIMIT


@pytest.mark.parametrize("range_N,beyond", [(1000.0, True), (0.1, True), (5.0, False), (36.0, False)])
def test_a_range_far_outside_the_bounds_is_refused_by_the_reach_without_a_search(range_N, beyond, monkeypatch):
    """Every start scaled to 1000 N needs hinges past hinge_max, and to 0.1 N past hinge_min
    (or does not solve): no search can end at the range inside the bounds, so ``optimise``
    skips it and the reach refuses (`dacm design --range 1000`: 58-65 s to 38 s, the search's
    24 s saved). At 5 N and at the reach's top, 36 N, some start lies inside the bounds and
    the search runs as before."""
    import sensor.design_space.optimise as optimise_module
    from sensor.design_space.optimise import beyond_bounds, starts

    p = DesignProblem(range_N)
    assert beyond_bounds(p, starts(p, 4)) is beyond
    if beyond:
        searched = []
        monkeypatch.setattr(optimise_module, "_search", lambda *a: searched.append(a) or (None, 0, []))
        with pytest.raises(DesignError, match=r"the reachable interval is [\d.]+ to [\d.]+ N"):
            optimise(p, n_starts=4)
        assert not searched
