"""``dacm design``: its files, --json keys, that ``dacm solve --config`` reproduces the
design, and one-line bad input. The search is shortened here (its answer is tested in
tests/design_space/test_optimise.py); the plumbing is what these tests check."""

import functools
import json

import pytest

import sensor.design_space.optimise as opt
from sensor.cli import main


@pytest.fixture
def quick(monkeypatch):
    monkeypatch.setattr(opt, "optimise", functools.partial(opt.optimise, n_starts=2))


def test_design_json_files_and_solve_reproduces_it(quick, tmp_path, capsys):
    assert main(["design", "--range", "3", "--hinge-max", "0.6", "--out", str(tmp_path), "--workers", "1",
                 "--draws", "20", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    for k in ("design", "range_N", "hysteresis_fraction", "resolution_N", "amplification", "k_out_N_per_mm",
              "strain_energy_mJ", "basis", "evaluations", "wall_s", "tolerance", "files"):
        assert k in out, k
    assert abs(out["range_N"] / 3 - 1) <= 0.01 and abs(out["basis"]["range_N"] / 3 - 1) <= 0.01
    for k in ("range_N_p5", "range_N_p50", "range_N_p95", "hysteresis_fraction_p10", "hysteresis_fraction_p50", "hysteresis_fraction_p90",
              "p_over_stress", "yield_fraction", "range_sensitivity_N_per_0p01mm"):
        assert k in out["tolerance"], k
    tol = json.loads((tmp_path / "design-tolerance.json").read_text())["tolerance"]
    assert tol == out["tolerance"]
    for name in ("design.toml", "design-datasheet.json", "design-tolerance.json", "design-profile.png",
                 "design-drawing.svg", "design-drawing.png", "design.dxf", "basis.toml"):
        assert (tmp_path / name).stat().st_size > 0, name
    assert main(["solve", "--config", str(tmp_path / "design.toml"), "--json"]) == 0
    solved = json.loads(capsys.readouterr().out)
    for k in ("range_N", "amplification", "k_out_N_per_mm", "strain_energy_mJ", "k_out_stroke_ratio",
              "amplification_stroke_ratio"):
        assert solved[k] == pytest.approx(out[k], rel=1e-6), k
    assert solved["near_toggle"] is out["near_toggle"] and out["basis"]["near_toggle"] is False
    assert solved["hysteresis_fraction"] == pytest.approx(out["hysteresis_fraction"], rel=1e-6)
    sheet = json.loads((tmp_path / "design-datasheet.json").read_text())
    assert sheet["resolution_N"] == pytest.approx(out["resolution_N"])


@pytest.mark.parametrize("argv,fragment", [
    (["--range", "1000"], "the reachable interval is"),
    (["--range", "3", "--kerf", "-1"], "--kerf = -1"),
    (["--range", "3", "--min-yield", "1.5"], "--min-yield = 1.5"),
    (["--range", "-1"], "--range = -1.0"),
    (["--range", "nan"], "--range = nan"),
    (["--range", "3", "--hinge-min", "0.5", "--hinge-max", "0.3"], "--hinge-max = 0.3"),
])
def test_bad_input_is_one_line_exit_2_and_writes_nothing(tmp_path, capsys, argv, fragment):
    assert main(["design", *argv, "--out", str(tmp_path / "out"), "--workers", "1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("dacm design: error:") and fragment in err[0]
    assert not (tmp_path / "out").exists()


def test_dxf_is_the_kerf_compensated_path(quick, tmp_path, capsys):
    """--kerf 0.8 writes the jet's centre path: its outline encloses the drawn outline grown
    by half the kerf, so its bounding box is the footprint plus 0.8 mm each way (0.01 mm)."""
    import ezdxf
    import numpy as np

    assert main(["design", "--range", "3", "--out", str(tmp_path), "--workers", "1", "--draws", "20",
                 "--kerf", "0.8", "--json"]) == 0
    capsys.readouterr()
    doc = ezdxf.readfile(tmp_path / "design.dxf")
    pts = np.array([v[:2] for e in doc.modelspace().query("LWPOLYLINE") for v in e.get_points()])
    span = pts.max(axis=0) - pts.min(axis=0)
    assert span == pytest.approx([25.0 + 0.8, 30.0 + 0.8], abs=0.01)


def test_off_toggle_reaches_both_searches_and_the_json(quick, tmp_path, capsys, monkeypatch):
    """--off-toggle is passed to the DACM's search, not the basis body's (it has no toggle;
    the constraint itself: tests/design_space/test_optimise.py), and stated in the JSON."""
    searched = []
    shortened = opt.optimise
    monkeypatch.setattr(opt, "optimise", lambda p, *a, **k: searched.append(p.off_toggle) or shortened(p, *a, **k))
    assert main(["design", "--range", "3", "--off-toggle", "--out", str(tmp_path), "--workers", "1",
                 "--draws", "20", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert searched == [True, False]
    assert out["off_toggle"] is True and out["near_toggle"] is False
