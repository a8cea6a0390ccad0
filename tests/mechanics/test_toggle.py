"""The next-to-the-toggle flag (sensor/mechanics/toggle.py) against the continuum table: it
marks every DACM whose full-scale k_out or A the beam model misses."""

import pytest

from geometry.params import design_from_dict
from geometry.topology import build_beam_model
from sensor.mechanics.solver import LINEAR_LIMIT_FRACTION, solve
from sensor.mechanics.toggle import StrokeChange, design_stroke_change, stroke_change, stroke_changes
from tests.mechanics.make_continuum_table import NONLINEAR
from tests.mechanics.test_continuum_table import (
    A_TOL_PCT,
    DESIGNS,
    ENTRIES,
    K_TOL_PCT,
    case_errors_pct,
    entry_errors_pct,
)


def _met(errors) -> bool:
    k_err, a_err = errors
    return abs(k_err) < K_TOL_PCT and abs(a_err) < A_TOL_PCT


def _dacm_rows():
    """(name, design, (k_out error %, A error %) at 1 mm, whether the linear limit meets both
    targets) of every DACM of the table with a stable continuum state at 1 mm: the drawn
    cases solved nonlinear and the cut entries."""
    rows = []
    for name in NONLINEAR:
        d = DESIGNS[name]
        if not d.is_basis:
            model = build_beam_model(d)
            lin = solve(model, target_output_mm=LINEAR_LIMIT_FRACTION)
            rows.append((name, d, case_errors_pct(name, solve(model, target_output_mm=1.0)),
                         _met(case_errors_pct(name, lin, nonlinear=False))))
    for name, row in sorted(ENTRIES.items()):
        d = design_from_dict(row["design"])
        if not d.is_basis and row["nonlinear_1mm"]["stable"]:
            model = build_beam_model(d)
            lin = solve(model, target_output_mm=LINEAR_LIMIT_FRACTION)
            rows.append((name, d, entry_errors_pct(name, solve(model, target_output_mm=1.0), nonlinear=True),
                         _met(entry_errors_pct(name, lin, nonlinear=False))))
    return rows


def test_the_flag_marks_every_dacm_the_beam_model_misses_at_full_scale():
    """Every DACM of the table the beam model misses at 1 mm (3 % on k_out, 1.5 % on A) is
    flagged: a classification against the continuum on the table's DACMs with a stable
    state at 1 mm whose linear limit the beam model meets (the two it misses there are a
    matter of the linear model; the limits were set on these, see the module's docstring).
    It was exact until the oblique root's coupling came into the model
    (geometry.topology.ROOT_COUPLING_PER_LEAN); since, five flagged bodies of phi2 8.9-10.6
    deg are met, a sixth (toggle-band-0, phi2 8.42 deg) since the members carry the axial
    force's second-order term, and since the hinges' axial spread and the input's contact
    (geometry.topology.axial_spread, INPUT_CONTACT_MM) all but one (thick-20-15, flagged by
    its A falling to 0.69 of its linear value), and since the contact was fitted on the plate
    alone (geometry.topology.contact_compliance) all but two (05-03-22-6 and like-4, phi2 6
    and 10.4 deg; thick-20-15 met), and since the members carry the material law's cubic
    term (St Venant-Kirchhoff's, as the continuum: solver.material_coefficients) all 15: on
    the safe side, and listed here so that a change is looked at."""
    rows = _dacm_rows()
    assert len(rows) >= 48
    assert [name for name, _, _, linear in rows if not linear] == []
    missed, flagged_met = {}, []
    for name, design, errors, linear in rows:
        if not linear:
            continue
        change = design_stroke_change(design, 1.0)
        if not change.near_toggle and not _met(errors):
            missed[name] = (design.phi2_deg, round(change.k_out_ratio, 3), round(change.amplification_ratio, 3),
                            "k {:+.2f} %, A {:+.2f} %".format(*errors))
        elif change.near_toggle and _met(errors):
            flagged_met.append(name)
    assert not missed, missed
    assert flagged_met == ["05-03-22-6", "03-03-28-6", "answer-proposed-10N", "answer-proposed-15N",
                           "like-4-delrin", "thick-20-15-0.9-0.6-L1.6", "toggle-band-0", "toggle-band-1", "toggle-band-3", "toggle-band-4", "toggle-band-5",
                           "toggle-band-k2.0-10N", "toggle-band-k2.0-15N", "toggle-band-k2.2-10N", "toggle-band-k2.2-15N"]


@pytest.mark.parametrize("k_ratio, a_ratio, phi2, near", [
    (2.21, 1.0, 20.0, True),    # stiffens past the limit
    (2.19, 0.81, 20.0, False),  # inside every limit
    (1.5, 0.79, 20.0, True),    # A falls past the limit
    (1.2, 1.0, 10.99, True),    # phi2 below its limit
    (1.2, 1.0, 11.0, False),
    (0.7, 1.0, None, False),    # the basis body softens: no toggle
])
def test_the_limits(k_ratio, a_ratio, phi2, near):
    change = StrokeChange(k_ratio, a_ratio, phi2)
    assert change.near_toggle is near
    assert bool(change.warning()) is near
    if near:
        assert f"{k_ratio:.2f} x" in change.warning() and "dacm verify --nonlinear" in change.warning()
    # the design search's constraints: the stroke's margins, phi2 held by a bound
    assert (min(change.log_margins) >= 0) is (k_ratio <= 2.2 and a_ratio >= 0.8)


def test_batched_stroke_changes_are_each_bodys_own():
    """:func:`stroke_changes` (the design search's, linear limits solved as one batch) against
    :func:`stroke_change` of each body alone: both converge each solve to 1e-9, so 1e-7."""
    designs = [DESIGNS[n] for n in ("sample-a", "sample-b", "05-03-22-6", "03-03-28-6")]
    models = [build_beam_model(d) for d in designs]
    results = [solve(m, target_output_mm=1.0) for m in models]
    phi2s = [d.phi2_deg for d in designs]
    for m, r, phi2, (batched, error) in zip(models, results, phi2s, stroke_changes(models, results, phi2s)):
        alone = stroke_change(m, r, phi2)
        assert error is None
        assert batched.k_out_ratio == pytest.approx(alone.k_out_ratio, rel=1e-7)
        assert batched.amplification_ratio == pytest.approx(alone.amplification_ratio, rel=1e-7)


def test_a_body_far_from_the_toggle_changes_little():
    """Sample A (phi2 34 deg) over its stroke: k_out -10 %, A +5 % (the table's continuum
    the same: -10 and +5 %); solved to a thousandth of full scale
    instead, its ratios are 1 to within the change over that thousandth (1e-4)."""
    model = build_beam_model(DESIGNS["sample-a"])
    full = stroke_change(model, solve(model, target_output_mm=1.0), 34.0)
    assert 0.85 < full.k_out_ratio < 0.95 and 1.0 < full.amplification_ratio < 1.1 and not full.near_toggle
    tiny = stroke_change(model, solve(model, target_output_mm=1e-3), 34.0)
    assert tiny.k_out_ratio == pytest.approx(1.0, abs=3e-4) and tiny.amplification_ratio == pytest.approx(1.0, abs=3e-4)
