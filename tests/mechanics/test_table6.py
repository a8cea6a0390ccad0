"""The model against thesis Table 6 (section 6.2.4): one parameter calibrated on the basis,
samples A and B predicted without retuning."""

import pytest

from geometry.params import Design
from sensor.mechanics.table6 import calibrate_hinge_length, table6_comparison

# Tolerance of the issue: within 25 % of the thesis' analytic values (its own model error
# against the specimens is about 20 %).
TOL = 0.25


@pytest.fixture(scope="module")
def rows():
    return {r.specimen: r for r in table6_comparison()}


def test_default_hinge_length_is_the_basis_calibration():
    """The default hinge length is what calibrating on the basis specimen (Table 7 hinges,
    E = 2.3 GPa) to its analytic sensitivity 0.202 mm/N gives, within 1 %."""
    assert calibrate_hinge_length() == pytest.approx(Design().hinge_length_mm, rel=0.01)


# The thesis' own model error against the specimens is about 20 %; measured here: sample A
# A +7 %, sensitivity +24 %, SE -24 %; sample B A +7 %, sensitivity -16 %, SE -7 %.


@pytest.mark.parametrize("specimen", ["sample-a", "sample-b"])
@pytest.mark.parametrize("quantity", ["amplification", "sensitivity", "strain_energy"])
def test_predictions_within_25_percent_of_thesis_model(rows, specimen, quantity):
    r = rows[specimen]
    model = {"amplification": r.amplification, "sensitivity": r.sensitivity_mm_per_N,
             "strain_energy": r.strain_energy_mJ}[quantity]
    thesis = {"amplification": r.amplification_thesis, "sensitivity": r.sensitivity_thesis,
              "strain_energy": r.strain_energy_thesis}[quantity]
    assert model == pytest.approx(thesis, rel=TOL)


def test_orderings_of_table6(rows):
    b, a, s = rows["basis"], rows["sample-a"], rows["sample-b"]
    assert b.strain_energy_mJ > a.strain_energy_mJ > s.strain_energy_mJ
    assert a.sensitivity_mm_per_N > b.sensitivity_mm_per_N > s.sensitivity_mm_per_N
    assert s.amplification > a.amplification > b.amplification
    # quality (sensitivity / predicted hysteresis): A best, then B, basis last, as measured
    assert a.quality_predicted > s.quality_predicted > b.quality_predicted


def test_amplification_at_1mm_is_below_the_kinematic_limit(rows):
    """Compliance costs amplification: the thesis' analytic values imply 9 % below A_kin for
    both samples; the model loses 2 % (A) and 2 % (B) at 1 mm, after the middle links'
    flattening has given some back."""
    from geometry.layout import kinematic_amplification
    assert rows["sample-a"].amplification < kinematic_amplification(21, 34)
    assert rows["sample-b"].amplification < kinematic_amplification(22, 17.2)


def test_calibration_target_out_of_reach_is_a_clear_error():
    from sensor.errors import SensorError
    with pytest.raises(SensorError, match="no hinge length in 0.5-6 mm reaches it"):
        calibrate_hinge_length(5.0)
