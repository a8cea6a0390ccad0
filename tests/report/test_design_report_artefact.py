"""Section 8 of the design report: the predicted MRI artefact states what
:func:`sensor.artefact.prediction.predict` gives for the design."""

from geometry.params import preset
from sensor.artefact.prediction import Protocol, predict
from sensor.report.design_report import artefact_section


def test_section_states_the_prediction():
    design = preset("basis")
    section = artefact_section(design)
    direct = predict(design, Protocol()).summary()
    assert section.data == direct          # same deterministic computation
    values = [r.value for r in section.rows]
    for row in direct["surface_offsets"]:
        assert f"{row['ppm']:.3g}" in values
    assert f"{direct['gradient_echo']['extent_mm']:.1f}" == values[-1]
    assert section.field.src.startswith("data:image/png;base64,")
    assert section.image.src.startswith("data:image/png;base64,")
