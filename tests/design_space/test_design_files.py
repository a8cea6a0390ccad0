"""The text lines of a `dacm design` body (sensor/design_space/design_files.py)."""

from geometry.params import design_to_dict, preset
from sensor.design_space.design_files import body_lines
from sensor.mechanics.toggle import STIFFENING_LIMIT


def _body(k_ratio: float) -> dict:
    return {"design": design_to_dict(preset("sample-b")), "range_N": 5.0, "hysteresis": 0.02, "resolution_N": 1e-3,
            "amplification": 4.0, "k_out_N_per_mm": 1.2, "strain_energy_mJ": 1.0, "stress_utilisation": 0.9,
            "k_out_stroke_ratio": k_ratio, "amplification_stroke_ratio": 1.0}


def test_a_body_next_to_the_toggle_gets_one_warning_line_and_others_none():
    calm, near = body_lines("DACM", _body(STIFFENING_LIMIT - 0.1)), body_lines("DACM", _body(STIFFENING_LIMIT + 0.1))
    assert len(calm) == 2 and not any("warning" in line for line in calm)
    assert len(near) == 3 and near[0] == calm[0]
    assert "warning: next to the toggle" in near[2] and f"{STIFFENING_LIMIT + 0.1:.2f} x" in near[2]
