"""The model against thesis Table 6 (section 6.2.4): the beam model's one calibrated
parameter (the hinge roots' depth) is fitted to the continuum FE, not to the thesis; the
drawn hinge length reproduces the basis specimen's measured sensitivity; samples A and B are
predicted without retuning."""

import pytest

from geometry.params import Design
from sensor.mechanics.hysteresis import TABLE6
from sensor.mechanics.table6 import calibrate_hinge_length, table6_comparison

# Tolerance of the issue: within 25 % of the thesis' analytic values (its own model error
# against the specimens is about 20 %).
TOL = 0.25


@pytest.fixture(scope="module")
def rows():
    return {r.specimen: r for r in table6_comparison()}


def test_default_hinge_length_reproduces_the_measured_basis():
    """Calibrating the hinge length on the basis specimen (Table 7 hinges, E = 2.3 GPa) to
    its measured sensitivity 0.227 mm/N gives the default 2.82 mm within 1 % (2.80 mm).
    (Before the hinge roots were elastic, the default was fitted to the analytic 0.202.)"""
    assert calibrate_hinge_length() == pytest.approx(Design().hinge_length_mm, rel=0.01)


# The thesis' own model error against the specimens is about 20 %; measured here against
# the thesis' analytic column: sample A A +8 %, sensitivity +37 %, SE -31 %; sample B A +9 %,
# sensitivity -7 %, SE -17 %. With rigid hinge roots (before the continuum check) sample A
# was +24 % / -24 %: the elastic roots, which the continuum FE demands (k_out 10-12 % softer
# on every preset), take sample A further from the thesis' analytic model. That model has
# rigid roots too, so sample A's sensitivity and SE disagree with it by more than 25 %.
ANALYTIC_MISSES = {("sample-a", "sensitivity"): "+37 %", ("sample-a", "strain_energy"): "-31 %"}


@pytest.mark.parametrize("specimen,quantity", [
    pytest.param(s, q, marks=pytest.mark.xfail(
        strict=True, reason=f"disagrees with the thesis' analytic model: {ANALYTIC_MISSES[s, q]}"))
    if (s, q) in ANALYTIC_MISSES else (s, q)
    for s in ("sample-a", "sample-b") for q in ("amplification", "sensitivity", "strain_energy")])
def test_predictions_within_25_percent_of_thesis_model(rows, specimen, quantity):
    r = rows[specimen]
    model = {"amplification": r.amplification, "sensitivity": r.sensitivity_mm_per_N,
             "strain_energy": r.strain_energy_mJ}[quantity]
    thesis = {"amplification": r.amplification_thesis, "sensitivity": r.sensitivity_thesis,
              "strain_energy": r.strain_energy_thesis}[quantity]
    assert model == pytest.approx(thesis, rel=TOL)


@pytest.mark.parametrize("specimen", ["basis", "sample-a", "sample-b"])
@pytest.mark.parametrize("quantity", ["sensitivity", "strain_energy"])
def test_predictions_within_25_percent_of_the_measured_specimens(rows, specimen, quantity):
    """Against the thesis' measured column (its own model is about 20 % off it): basis
    +0.4 % / +10 %, sample A +17 % / -21 %, sample B -19 % / +4 % (sensitivity / SE)."""
    r, t = rows[specimen], TABLE6[specimen]
    model = {"sensitivity": r.sensitivity_mm_per_N, "strain_energy": r.strain_energy_mJ}[quantity]
    measured = {"sensitivity": t.sensitivity_mm_per_N, "strain_energy": t.strain_energy_mJ}[quantity]
    assert model == pytest.approx(measured, rel=TOL)


def test_orderings_of_table6(rows):
    b, a, s = rows["basis"], rows["sample-a"], rows["sample-b"]
    assert b.strain_energy_mJ > a.strain_energy_mJ > s.strain_energy_mJ
    assert a.sensitivity_mm_per_N > b.sensitivity_mm_per_N > s.sensitivity_mm_per_N
    assert s.amplification > a.amplification > b.amplification
    # quality (sensitivity / predicted hysteresis): A best, then B, basis last, as measured
    assert a.quality_predicted > s.quality_predicted > b.quality_predicted


def test_amplification_at_1mm_is_below_the_kinematic_limit(rows):
    """Compliance costs amplification: the thesis' analytic values imply 9 % below A_kin for
    both samples; the model loses 1 % (A and B) at 1 mm, after the middle links'
    flattening has given some back."""
    from geometry.layout import kinematic_amplification
    assert rows["sample-a"].amplification < kinematic_amplification(21, 34)
    assert rows["sample-b"].amplification < kinematic_amplification(22, 17.2)


def test_calibration_target_out_of_reach_is_a_clear_error():
    from sensor.errors import SensorError
    with pytest.raises(SensorError, match="no hinge length in 0.5-6 mm reaches it"):
        calibrate_hinge_length(5.0)
