"""The studies' structure on a small grid: the plant-physics variants reach the plant, every
row carries its status, and the tables and verdicts render with their criteria."""
import math

import pytest

from sensor.pneumatic.studies import PLANT_PHYSICS, controller_study, plant_physics_study
from sensor.pneumatic.tuning import tune
from sensor.pneumatic.verdicts import controller_tables, plant_physics_tables


@pytest.fixture(scope="module")
def tuned():
    return {5.0: tune(5.0, segments=4)}


def test_plant_physics_study_varies_one_thing_at_a_time(tuned):
    res = plant_physics_study(duration_s=3.0, segments=4, lengths=(5.0,), references=("sine:2Hz",), tuned=tuned)
    assert set(res["rows"]) == {"baseline", *PLANT_PHYSICS}
    base = res["rows"]["baseline"][0]
    for name in PLANT_PHYSICS:
        row = res["rows"][name][0]
        for key in ("smc", "line_model_thesis"):
            assert row[key]["gains"] == pytest.approx(base[key]["gains"])      # gains held
            assert isinstance(row[key]["limit_cycle"], bool) and math.isfinite(row[key]["mse1_N2"])
            assert row[key]["mse1_N2"] != base[key]["mse1_N2"]                  # the plant changed
    text = plant_physics_tables(res)
    assert "stiction 0.25 N (thesis 4.3)" in text and "baseline" in text and "x) |" in text


def test_controller_tables_print_the_tuning_beside_the_gains(tuned):
    res = controller_study(duration_s=3.0, segments=4, lengths=(5.0,), references=("sine:2Hz",), tuned=tuned)
    # the plant-physics study can take this study's primary rows as its baseline: the same numbers
    # as running them again (deterministic runs), fewer runs
    again = plant_physics_study(duration_s=3.0, segments=4, lengths=(5.0,), references=("sine:2Hz",), tuned=tuned)
    reused = plant_physics_study(duration_s=3.0, segments=4, lengths=(5.0,), references=("sine:2Hz",), baseline=res)
    for key in ("smc", "line_model_thesis"):
        assert reused["rows"]["baseline"][0][key]["mse1_N2"] == again["rows"]["baseline"][0][key]["mse1_N2"]
        assert reused["rows"]["energy"][0][key]["mse1_N2"] == again["rows"]["energy"][0][key]["mse1_N2"]
    text = controller_tables(res)
    assert "Gains by the thesis' tuning rule" in text and "t_s(2 %)" in text and "overshoot" in text
    assert "Against the thesis, its controllers tuned by its rule (primary)" in text
    assert "The same claims with the fixed gain rules" in text
