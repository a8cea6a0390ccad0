"""The beam model against the stored continuum FE reference (DESIGN section 14).

tests/mechanics/data/continuum_table.json holds the continuum FE of the drawn profile of six
presets and twelve sweep cells (both hinge sets, phi1 from 8 to 31 deg, cells next to the
toggle), each Richardson-extrapolated from meshes with 6, 8.5 and 12 quadratic elements
across each hinge (estimated mesh error under 0.5 %), plus nonlinear solves at 1 mm output
for six of them. tests/mechanics/make_continuum_table.py regenerates it (about 30 min).

Targets of the issue: k_out within 3 %, A within 1.5 % of the converged continuum, hinge
stress within 15 %. The beam model's one calibrated parameter, the root depth, is the
least-squares fit of k_out to this table (the test refits it).

Known disagreements, kept as strict expected failures with their numbers: next to the toggle
(phi2 = 4-6 deg) amplification is so sensitive to where the middle links' effective pivots
sit (at phi2 = 6 deg a pivot 0.02 mm higher changes A by about 2 %) that the simple root
model misses the 1.5 % target on two 03-03 cells in the linear limit (A -1.65 % at 12/4,
+1.81 % at 28/6) and on both toggle cells at 1 mm (05-03 22/6: k +4.4 %, A -2.6 %; 03-03
28/6: A +2.8 %); every other case meets both targets.
"""

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from geometry.topology import ROOT_DEPTH_PER_THICKNESS, build_beam_model
from sensor.mechanics.continuum import LINEAR_LIMIT_FRACTION
from sensor.mechanics.solver import solve
from sensor.mechanics.stress import hinge_stresses
from tests.mechanics.make_continuum_table import NONLINEAR, cases

TABLE = json.loads((Path(__file__).with_name("data") / "continuum_table.json").read_text())["cases"]
DESIGNS = cases()
#: The issue's targets (percent).
K_TOL_PCT, A_TOL_PCT, STRESS_TOL_PCT = 3.0, 1.5, 15.0


def beam_linear(name, root_depth=ROOT_DEPTH_PER_THICKNESS):
    model = build_beam_model(DESIGNS[name], root_depth_per_thickness=root_depth)
    return model, solve(model, target_output_mm=LINEAR_LIMIT_FRACTION)


def fe(name, q):
    return TABLE[name]["linear"][q]["extrapolated"]


def test_table_covers_presets_and_twelve_cells_of_both_hinge_sets():
    assert set(TABLE) == set(DESIGNS)
    cells = [n for n in TABLE if n[:5] in ("05-03", "03-03")]
    assert len(cells) >= 12 and {n[:5] for n in cells} == {"05-03", "03-03"}
    # every reference is mesh-converged: estimated error of the finest mesh under 1 %
    for name, row in TABLE.items():
        for q in ("amplification", "k_out_N_per_mm"):
            assert row["linear"][q]["error_pct"] < 1.0, (name, q)


LINEAR_MISSES = {"03-03-12-4": "A -1.65 %", "03-03-28-6": "A +1.81 %"}
NONLINEAR_MISSES = {"05-03-22-6": "k +4.4 %, A -2.6 %", "03-03-28-6": "A +2.8 %"}


def _cases(names, misses):
    return [pytest.param(n, marks=pytest.mark.xfail(strict=True, reason=f"near the toggle: {misses[n]}"))
            if n in misses else n for n in names]


@pytest.mark.parametrize("name", _cases(sorted(DESIGNS), LINEAR_MISSES))
def test_beam_model_matches_continuum_in_the_linear_limit(name):
    _, r = beam_linear(name)
    k_err = 100 * (r.k_out_N_per_mm / fe(name, "k_out_N_per_mm") - 1)
    a_err = 100 * (r.amplification / fe(name, "amplification") - 1)
    assert abs(k_err) < K_TOL_PCT, f"k_out {k_err:+.2f} %"
    assert abs(a_err) < A_TOL_PCT, f"A {a_err:+.2f} %"


@pytest.mark.parametrize("name", _cases(NONLINEAR, NONLINEAR_MISSES))
def test_beam_model_matches_continuum_at_1mm(name):
    """Nonlinear FE (total Lagrangian, default mesh: about 0.5 % softer than converged, so
    the same targets apply) against the nonlinear beam solve at 1 mm output."""
    ref = TABLE[name]["nonlinear_1mm_default_mesh"]
    r = solve(build_beam_model(DESIGNS[name]), target_output_mm=1.0)
    assert abs(100 * (r.k_out_N_per_mm / ref["k_out_N_per_mm"] - 1)) < K_TOL_PCT
    assert abs(100 * (r.amplification / ref["amplification"] - 1)) < A_TOL_PCT


@pytest.mark.parametrize("name", sorted(DESIGNS))
def test_hinge_stress_matches_continuum(name):
    """Axial plus bending stress one thickness inside each neck (away from the roots'
    singular corners, where the FE converges) against the FE's peak there, for the hinges
    carrying at least a fifth of the design's largest stress."""
    model, r = beam_linear(name)
    scale = 1.0 / r.output_travel_mm
    beam = {h: s.neck_MPa * scale for h, s in hinge_stresses(model, r).items()}
    ref = {int(h): v for h, v in TABLE[name]["hinge_neck_stress_MPa"].items()}
    top = max(ref.values())
    for h, v in ref.items():
        if v > 0.2 * top:
            assert beam[h] == pytest.approx(v, rel=STRESS_TOL_PCT / 100), f"hinge {h}"


def test_root_depth_is_the_least_squares_fit_to_the_table():
    """The one calibrated parameter: refit to the table's linear k_out, it lands within 0.01
    of the stored constant."""
    def cost(k):
        err = [beam_linear(n, k)[1].k_out_N_per_mm / fe(n, "k_out_N_per_mm") - 1 for n in DESIGNS]
        return float(np.sum(np.square(err)))

    best = minimize_scalar(cost, bounds=(0.0, 1.0), method="bounded", options={"xatol": 1e-3}).x
    assert best == pytest.approx(ROOT_DEPTH_PER_THICKNESS, abs=0.01)
