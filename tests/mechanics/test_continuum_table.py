"""The beam model against the stored continuum FE reference (DESIGN sections 14 and 16).

tests/mechanics/data/continuum_table.json holds two references; tests/mechanics/
make_continuum_table.py regenerates them (resumably: runs are slow).

``cases``: the drawn profile (kerf 0, sharp roots) of six presets and twelve sweep cells
(both hinge sets, phi1 from 8 to 31 deg, cells next to the toggle), each
Richardson-extrapolated from meshes with 6, 8.5 and 12 quadratic elements across each
hinge (estimated mesh error under 0.5 %), plus nonlinear solves at 1 mm output for six of
them (about 30 min).

``entries``: the part as cut (root fillets r = kerf / 2; kerf 0, 0.4, 0.8 and 1.2 mm) of the
thesis specimens, ``dacm design`` outputs, thick hinges (t / L up to 0.69), the basis family
(hinges 1-8 from 0.3 to 1.25 mm), ``dacm design``-like bodies of both materials, the
seven answers of the README's design table, fourteen bodies next to the toggle and ``dacm
design --off-toggle``'s two answers, linear from 3, 4.24 and 6 elements across each hinge
(6, 8.5 and 12 where those do not converge within 1 %; Richardson) and nonlinear at 1 mm
output on the 3-across mesh; held out of any fit by a fixed rule: every third entry of a
family, and the last three families (added after the fits) all.

Targets of the issue: k_out within 3 %, A within 1.5 % of the converged continuum, hinge
stress within 15 %. The root rule's constants are fitted to the entries that are not held
out (tests/mechanics/test_root_rule.py refits them).

At 1 mm the continuum's state must also be stable (the tangent stiffness positive definite
with the punch held; entries store it): where it is not, the part sways sideways before
1 mm, and the travel where that starts is compared instead: it must lie between the beam
model's with the input's rotation free and with it held (the punch holds it partly).

Known disagreements would be kept as strict expected failures with their numbers
(CUT_MISSES, CUT_MISSES_1MM, LINEAR_MISSES, NONLINEAR_MISSES): there are none. All 73
cut-part entries and all 18 drawn cases meet both targets, linear and at 1 mm (the 6 drawn
cases solved there), held-out entries included.
"""

import dataclasses
import json
from pathlib import Path

import pytest

from geometry.params import design_from_dict
from geometry.topology import build_beam_model
from sensor.design_space.optimise import ANGLE_QUANTUM, THICKNESS_QUANTUM
from sensor.errors import ConvergenceError, InstabilityError
from sensor.mechanics.continuum import LINEAR_LIMIT_FRACTION
from sensor.mechanics.solver import solve
from sensor.mechanics.stress import hinge_stresses
from tests.mechanics.make_continuum_table import (
    CONVERGED_PCT,
    DESIGN_TABLE,
    HELD_OUT_FAMILIES,
    NONLINEAR,
    OFF_TOGGLE,
    cases,
    entries,
)

_DATA = json.loads((Path(__file__).with_name("data") / "continuum_table.json").read_text())
TABLE = _DATA["cases"]
DESIGNS = cases()
#: The cut-part entries computed so far (the script fills the table entry by entry).
ENTRIES = _DATA.get("entries", {})
#: The issue's targets (percent).
K_TOL_PCT, A_TOL_PCT, STRESS_TOL_PCT = 3.0, 1.5, 15.0


def beam_linear(name):
    model = build_beam_model(DESIGNS[name])
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


LINEAR_MISSES: dict[str, str] = {}
#: None at 1 mm since the members carry the material law's cubic term (St Venant-Kirchhoff's,
#: the continuum's: solver.material_coefficients): 05-03-22-6 (drawn, sharp roots, phi2 6
#: deg; its A falls from 6.03 to 1.78 over the stroke) missed before, A -1.95 %, now -1.01 %.
NONLINEAR_MISSES: dict[str, str] = {}
#: Cut-part entries the beam model misses (the issue's targets, 3 % on k_out and 1.5 % on
#: A; strict: they fail if the model comes to meet them): none of the 73, linear or at 1 mm.
#: like-4 at 1 mm (phi2 10.4 deg, its A falls by 28 % over the stroke, its continuum peak 71
#: MPa, at delrin's 60-70 MPa yield) missed until the material law's cubic term came in:
#: k +1.85 %, A -1.84 %, now +0.58 %, -1.04 %. Before the input's contact was fitted on the
#: plate alone (geometry.topology.contact_compliance) like-11 and toggle-band-2 missed
#: linear (A +2.06 and +2.04 %) and thick-20-15 at 1 mm (A +2.61 %).
CUT_MISSES: dict[str, str] = {}
CUT_MISSES_1MM: dict[str, str] = {}


def _cases(names, misses):
    return [pytest.param(n, marks=pytest.mark.xfail(strict=True, reason=f"disagrees: {misses[n]}"))
            if n in misses else n for n in names]


@pytest.mark.parametrize("name", _cases(sorted(DESIGNS), LINEAR_MISSES))
def test_beam_model_matches_continuum_in_the_linear_limit(name):
    k_err, a_err = case_errors_pct(name, beam_linear(name)[1], nonlinear=False)
    assert abs(k_err) < K_TOL_PCT, f"k_out {k_err:+.2f} %"
    assert abs(a_err) < A_TOL_PCT, f"A {a_err:+.2f} %"


@pytest.mark.parametrize("name", _cases(NONLINEAR, NONLINEAR_MISSES))
def test_beam_model_matches_continuum_at_1mm(name):
    """Nonlinear FE (total Lagrangian, default mesh: about 0.5 % softer than converged, so
    the same targets apply) against the nonlinear beam solve at 1 mm output."""
    k_err, a_err = case_errors_pct(name, solve(build_beam_model(DESIGNS[name]), target_output_mm=1.0))
    assert abs(k_err) < K_TOL_PCT
    assert abs(a_err) < A_TOL_PCT


def case_errors_pct(name, result, nonlinear: bool = True) -> tuple[float, float]:
    """The beam model's errors in k_out and A (percent; ``result`` solved to 1 mm, or to the
    linear limit) against the drawn case: its nonlinear solve at 1 mm, or its linear limit."""
    ref = TABLE[name]["nonlinear_1mm_default_mesh"] if nonlinear else {
        q: fe(name, q) for q in ("k_out_N_per_mm", "amplification")}
    return (100 * (result.k_out_N_per_mm / ref["k_out_N_per_mm"] - 1),
            100 * (result.amplification / ref["amplification"] - 1))


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


# --- the part as cut (entries) ---------------------------------------------------------


@pytest.mark.parametrize("name", sorted(n for n, row in ENTRIES.items() if row["kerf_mm"] > 0))
def test_neck_stress_of_the_cut_part_matches_continuum(name):
    """Axial plus bending stress one thickness inside each uniform neck (past the root
    fillets, the same stations in both models) within the issue's 10 % of the FE on every
    hinge carrying at least half the body's largest (the hinges the stress rule is about;
    a lighter one's moment can pass through zero along its neck). The peak at the fillets
    is checked in tests/mechanics/test_root_rule.py."""
    row = ENTRIES[name]
    model = build_beam_model(design_from_dict(row["design"]))
    r = solve(model, target_output_mm=LINEAR_LIMIT_FRACTION)
    beam = {h: s.neck_MPa / r.output_travel_mm for h, s in hinge_stresses(model, r).items()}
    ref = {int(h): v for h, v in row["hinge_neck_stress_MPa"].items()}
    top = max(ref.values())
    misses = {h: f"{100 * (beam[h] / v - 1):+.1f} %" for h, v in ref.items()
              if v >= 0.5 * top and abs(beam[h] / v - 1) > 0.10}
    assert not misses, misses


def test_entries_are_the_scripts_bodies_with_the_held_out_rule_and_converged():
    """Every stored entry is a body of the script (the same design, kerf included), held out
    by the script's fixed rules (every third of its family; every entry of a family of
    HELD_OUT_FAMILIES), and mesh-converged as stated
    (Richardson error of the finest mesh under 1 % on k_out and A)."""
    bodies = entries()
    assert ENTRIES, "no cut-part entries yet: run tests/mechanics/make_continuum_table.py"
    for name, row in ENTRIES.items():
        family, held_out, design = bodies[name]
        assert design_from_dict(row["design"]) == design and row["kerf_mm"] == design.kerf_mm
        assert (row["family"], row["held_out"]) == (family, held_out)
        assert row["converged"]["ok"], (name, row["converged"]["error_pct"])
        assert isinstance(row["nonlinear_1mm"]["stable"], bool), name
        for q in ("k_out_N_per_mm", "amplification"):
            assert row["linear"][q]["error_pct"] < CONVERGED_PCT, (name, q)
    ruled = [held for family, held, _ in bodies.values() if family not in HELD_OUT_FAMILIES]
    assert 0.25 < sum(ruled) / len(ruled) < 0.4
    assert all(held for family, held, _ in bodies.values() if family in HELD_OUT_FAMILIES)


def test_the_design_table_family_is_the_readmes_answers():
    """The entries of the design table's answers (nominal, and off the toggle where the
    nominal one is next to it) are the bodies docs/design-table.json (the README's design
    table, examples/design_table.py) holds now: a regenerated table with new answers needs
    their continuum entries recomputed (make_continuum_table.py, about 10 min). Within one
    quantum of the written values: a table made on another machine can land one quantum
    apart (the 15 N answer's hinges 1 and 4 moved by 0.1 um between two sessions' machines,
    under 0.1 % of its k_out)."""
    answers = json.loads((Path(__file__).parents[2] / "docs" / "design-table.json").read_text())
    for column, prefix, family in (("nominal", "answer-", DESIGN_TABLE), ("off_toggle", "off-toggle-", OFF_TOGGLE)):
        found = {}
        for key, row in answers.items():
            if column in row:
                body, range_N = key.split("-")
                name = f"{prefix}{body}-{range_N}N" if column == "nominal" else f"{prefix}{range_N}N"
                found[name] = (row[column]["angles"], row[column]["hinges_mm"])
        assert set(found) == set(family), column
        for name, (angles, hinges) in found.items():
            phi1, phi2, stored = family[name]
            written = [float(a) for a in angles.split("/")]
            assert written == pytest.approx([phi1] + ([] if phi2 is None else [phi2]), abs=1.01 * ANGLE_QUANTUM), name
            assert hinges == pytest.approx(stored[:len(hinges)], abs=1.01 * THICKNESS_QUANTUM), name


def _beam_stable_to_mm(model, steps: int = 12) -> float:
    """The output travel (mm, within 0.5 um) up to which the beam model's path is stable
    (its Newton iterations also fail just past the bifurcation: a ConvergenceError)."""
    lo, hi = 0.0, 2.0
    for _ in range(steps):
        mid = (lo + hi) / 2
        try:
            solve(model, target_output_mm=mid)
            lo = mid
        except (InstabilityError, ConvergenceError):
            hi = mid
    return lo


def _sway_is_bracketed(model, onset):
    """The continuum's punch (0.5 mm wide, flat, held sideways) restrains the input's
    rotation only partly, the beam model's guide fully: the continuum must start to sway
    between the beam model with the input's rotation free and with it held (the fixture's
    rotational stiffness decides where in that interval a real part sways)."""
    free = dataclasses.replace(model, supports=tuple(
        (node, ("x",) if node == model.input_node else dofs) for node, dofs in model.supports))
    lower, upper = _beam_stable_to_mm(free), _beam_stable_to_mm(model)
    assert 0 < lower < 1.99 and 0 < upper < 1.99, (lower, upper)  # both sway within the search
    assert lower <= onset[1] and onset[0] <= upper, (lower, onset, upper)


def _beam_vs(name, nonlinear):
    row = ENTRIES[name]
    model = build_beam_model(design_from_dict(row["design"]))
    if nonlinear and not row["nonlinear_1mm"]["stable"]:
        # the continuum's state at 1 mm is unstable (the part sways sideways before it): no
        # numbers to compare; where the sway starts is compared instead (see below)
        _sway_is_bracketed(model, row["nonlinear_1mm"]["stability_onset_mm"])
        return
    r = solve(model, target_output_mm=1.0 if nonlinear else LINEAR_LIMIT_FRACTION)
    k_err, a_err = entry_errors_pct(name, r, nonlinear)
    assert abs(k_err) < K_TOL_PCT and abs(a_err) < A_TOL_PCT, f"k_out {k_err:+.2f} %, A {a_err:+.2f} %"


def entry_errors_pct(name, result, nonlinear: bool) -> tuple[float, float]:
    """The beam model's errors in k_out and A (percent; ``result`` solved to 1 mm, or to the
    linear limit) against the cut-part entry: at 1 mm its 3-across nonlinear solve, less the
    mesh error its linear solve shows there."""
    row = ENTRIES[name]
    if nonlinear:
        nl, same = row["nonlinear_1mm"], row["nonlinear_1mm"]["linear_same_mesh"]
        ref = {q: nl[q] * row["linear"][q]["extrapolated"] / same[q]
               for q in ("k_out_N_per_mm", "amplification")}
    else:
        ref = {q: row["linear"][q]["extrapolated"] for q in ("k_out_N_per_mm", "amplification")}
    return (100 * (result.k_out_N_per_mm / ref["k_out_N_per_mm"] - 1),
            100 * (result.amplification / ref["amplification"] - 1))


@pytest.mark.parametrize("name", _cases(sorted(ENTRIES), CUT_MISSES))
def test_beam_model_matches_the_cut_part_in_the_linear_limit(name):
    """The beam model of the part as cut against the entry (see the module docstring)."""
    _beam_vs(name, nonlinear=False)


@pytest.mark.parametrize("name", _cases(sorted(ENTRIES), CUT_MISSES_1MM))
def test_beam_model_matches_the_cut_part_at_1mm(name):
    """The beam model of the part as cut against the entry (see the module docstring)."""
    _beam_vs(name, nonlinear=True)
