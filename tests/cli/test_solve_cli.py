"""`dacm solve` and `dacm check` from the command line (exit codes, JSON, bad input)."""

import json

import pytest

from geometry.params import preset
from geometry.topology import build_beam_model, model_to_json
from sensor.cli import main
from sensor.mechanics.solver import solve


def test_solve_json_has_every_qualifier(capsys):
    assert main(["solve", "--preset", "sample-b", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    for key in ("amplification", "A_kin", "k_out_N_per_mm", "sensitivity_mm_per_N", "strain_energy_mJ",
                "input_force_N", "input_travel_mm", "output_travel_mm", "hysteresis_fraction",
                "quality_mm_per_N", "increments", "residual", "converged", "hinge_rotation_deg"):
        assert key in out, key
    r = solve(build_beam_model(preset("sample-b")))
    assert out["k_out_N_per_mm"] == pytest.approx(r.k_out_N_per_mm, rel=1e-9)
    assert out["output_travel_mm"] == pytest.approx(1.0)
    assert out["converged"] is True


def test_solve_reads_an_exported_beam_model(tmp_path, capsys):
    path = tmp_path / "b.json"
    path.write_text(model_to_json(build_beam_model(preset("sample-a"))))
    assert main(["solve", "--model", str(path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["amplification"] == pytest.approx(solve(build_beam_model(preset("sample-a"))).amplification, rel=1e-12)
    assert out["A_kin"] is None


def test_solve_to_a_force(capsys):
    assert main(["solve", "--preset", "basis", "--target-force", "2", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["input_force_N"] == pytest.approx(2.0)


@pytest.mark.parametrize("argv,fragment", [
    (["solve", "--preset", "sample-z"], "preset = 'sample-z'"),
    (["solve", "--phi1", "40"], "rule 'angle_limits'"),
    (["solve", "--preset", "basis", "--phi1", "20"], "cannot be combined"),
    (["solve", "--increments", "0"], "--increments = 0"),
    (["solve", "--target-output", "-1"], "--target-output = -1.0"),
    (["solve", "--model", "/nonexistent/m.json"], "No such file"),
])
def test_solve_bad_input_exits_2_with_one_line(argv, fragment, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and fragment in err[0]


def test_check_exit_status_says_feasible_or_not(capsys):
    assert main(["check", "--preset", "sample-a"]) == 0
    assert "feasible" in capsys.readouterr().out
    assert main(["check", "--phi1", "31", "--phi2", "55", "--json"]) == 1
    report = json.loads(capsys.readouterr().out)
    assert report["feasible"] is False
    assert {r["rule"] for r in report["rules"] if not r["ok"]} >= {"no_crossing"}
    assert main(["check", "--hinges", "04-04"]) == 2


@pytest.mark.parametrize("argv", [["solve", "--phi1", "abc"], ["nope"], ["sweep", "--workers", "x"]])  # bare dacm: the help
def test_argument_errors_are_one_line_with_status_2(argv, capsys):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "error:" in err[0] and "--help" in err[0]


def test_solve_says_how_k_out_and_a_change_over_the_stroke_and_warns_next_to_the_toggle(tmp_path, capsys):
    """The ratios are those of the beam model's linear limit (its own solve), ``near_toggle``
    is the flag of sensor/mechanics/toggle.py (checked against the continuum in
    tests/mechanics/test_toggle.py); the 15 N answer of the design table is flagged, sample B
    is not, and ``--linear`` has no stroke to report."""
    from sensor.mechanics.solver import LINEAR_LIMIT_FRACTION

    assert main(["solve", "--preset", "sample-b", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    model = build_beam_model(preset("sample-b"))
    linear = solve(model, target_output_mm=LINEAR_LIMIT_FRACTION)
    assert out["k_out_stroke_ratio"] == pytest.approx(out["k_out_N_per_mm"] / linear.k_out_N_per_mm, rel=1e-9)
    assert out["amplification_stroke_ratio"] == pytest.approx(out["amplification"] / linear.amplification, rel=1e-9)
    assert out["near_toggle"] is False
    assert main(["solve", "--preset", "sample-b"]) == 0
    text = capsys.readouterr().out
    assert f"k_out x {out['k_out_stroke_ratio']:.3f}" in text and "warning" not in text
    config = tmp_path / "answer-15N.toml"
    config.write_text('phi1_deg = 30.9\nphi2_deg = 7.65\nhinge_set = "custom"\nname = "answer-15N"\n'
                      "hinge_thickness_mm = [0.5293, 0.3, 0.3, 0.7957, 0.7957, 0.3, 0.3, 0.5293, 0.3, 0.3, 0.3, 0.3]\n")
    assert main(["solve", "--config", str(config), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["near_toggle"] is True
    assert main(["solve", "--config", str(config)]) == 0
    warning = [line for line in capsys.readouterr().out.splitlines() if "warning" in line]
    assert len(warning) == 1 and "next to the toggle" in warning[0] and "dacm verify --nonlinear" in warning[0]
    assert main(["solve", "--preset", "sample-b", "--linear", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["near_toggle"] is None
