"""The pair pruning of the feasibility checks keeps their answers: on a grid of designs
(both hinge sets, phi1 x phi2 around and beyond the feasible region) the pruned pairs hold
the same smallest gap, the same first overlapping pair and the same closest pair as all pairs;
checking designs together (one vectorised pass per topology) gives each one's own report."""

import numpy as np
import pytest

from geometry.checks import _free_pairs, _free_polygons, _near_pairs, _pair_distances, check_design, check_designs
from geometry.layout import make_layout, make_parts
from geometry.params import make_design


@pytest.mark.parametrize("hinges", ["05-03", "03-03"])
def test_near_pairs_hold_the_closest_and_overlapping_pairs(hinges):
    kept = []
    for phi1 in np.linspace(6, 31, 6):
        for phi2 in np.linspace(4, 56, 6):
            parts = make_parts(make_layout(make_design(phi1, phi2, hinges)))
            poly = _free_polygons(parts)
            I, J = _free_pairs(tuple(p.name for p in parts), tuple(p.kind for p in parts),
                               tuple(p.hinge for p in parts), tuple(p.body for p in parts))
            dist, overlap = _pair_distances(poly[I], poly[J])
            near = _near_pairs(poly[None], I, J)[0]
            assert near[overlap].all()
            gaps = np.where(overlap, np.inf, dist)
            assert near[int(np.argmin(gaps))]
            assert np.min(gaps[near]) == np.min(gaps)
            kept.append(near.mean())
    assert max(kept) < 0.3   # the pruning is worth doing (measured 9-16 % of the pairs kept)


def test_designs_checked_together_get_their_own_reports():
    # basis and proposed bodies (two topologies) of both hinge sets, feasible and not, mixed
    designs = [make_design(phi1, phi2, hinges) for hinges in ("05-03", "03-03")
               for phi1 in (8.0, 22.0, 31.0, 33.0) for phi2 in (None, 4.0, 17.2, 51.5)]
    together = check_designs(designs)
    alone = [check_design(d) for d in designs]
    assert together == alone
    assert {r.feasible for r in alone} == {True, False}
    assert {r.first_failure.rule for r in alone if not r.feasible} == {"angle_limits", "kerf_gap", "no_crossing"}
