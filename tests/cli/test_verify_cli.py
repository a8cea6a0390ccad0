"""`dacm verify` from the command line: JSON keys, the figure, bad input."""

import json
import math

import pytest

from geometry.params import MATERIALS, preset, save_design
from sensor.cli import main
from sensor.cli.verify import PUNCH_DEFAULT_MM
from geometry.topology import INPUT_CONTACT_MM
from tests.mechanics.make_continuum_table import BASIS_5N, DESIGN_5N, PAIRS, body


def test_verify_json_has_the_issue_keys_and_writes_the_figure(tmp_path, capsys):
    """The drawing (--kerf 0), where today's beam model (sharp roots) applies."""
    assert main(["verify", "--preset", "basis", "--mesh", "coarse", "--kerf", "0", "--json",
                 "--out", str(tmp_path)]) == 0
    out = json.loads(capsys.readouterr().out)
    assert (out["kerf_mm"], out["profile"]) == (0.0, "as drawn (kerf 0: sharp hinge roots)")
    # the CLI's default punch is the reference's (it does not import the continuum module)
    assert out["options"]["punch_width_mm"] == INPUT_CONTACT_MM == PUNCH_DEFAULT_MM
    for side in ("fe", "beam"):
        for key in ("amplification", "k_out_N_per_mm", "strain_energy_mJ", "hinge_stress_MPa",
                    "hinge_peak_stress_MPa"):
            assert key in out[side], (side, key)
        assert sorted(out[side]["hinge_stress_MPa"], key=int) == [str(h) for h in range(1, 9)]
    assert sorted(out["fe"]["hinge_peak_station_mm"], key=int) == [str(h) for h in range(1, 9)]
    peak = out["convergence"]["hinge_peak_stress_MPa"]
    assert sorted(peak, key=int) == [str(h) for h in range(1, 9)]
    assert peak["1"]["values"][-1] == out["fe"]["hinge_peak_stress_MPa"]["1"]
    for key in ("amplification", "k_out_N_per_mm", "strain_energy_mJ", "knee_outward_per_input",
                "knee_rotation_per_input_rad_per_mm"):
        assert out["errors_pct"][key] == pytest.approx(100 * (out["beam"][key] / out["fe"][key] - 1))
        c = out["convergence"][key]
        assert len(c["values"]) == 3 and c["elements_across"][-1] == pytest.approx(3.0)
        assert c["extrapolated"] == out["fe"][key]
    # the stress verdict: the beam's largest peak against delrin's 36 MPa; none from the FE,
    # whose peak at the drawing's sharp corners is singular
    beam = out["beam"]
    hinge = max(beam["hinge_peak_stress_MPa"], key=beam["hinge_peak_stress_MPa"].get)
    assert (str(beam["peak_stress_hinge"]), beam["peak_stress_MPa"]) == (hinge, beam["hinge_peak_stress_MPa"][hinge])
    assert beam["stress_utilisation"] == pytest.approx(beam["peak_stress_MPa"] / 36.0, rel=1e-12)
    assert out["fe"]["peak_stress_MPa"] is None and out["fe"]["stress_utilisation"] is None
    # the beam model agrees with the continuum (the coarse mesh's own error is about 1 %)
    assert abs(out["errors_pct"]["k_out_N_per_mm"]) < 4.0
    assert (tmp_path / "basis-verify.png").stat().st_size > 10_000


@pytest.mark.parametrize("argv,fragment", [
    (["--mesh", "medium"], "--mesh = 'medium'"),
    (["--target-output", "0"], "--target-output = 0.0"),
    (["--kerf", "-1"], "--kerf = -1.0"),
    (["--kerf", "nan"], "--kerf = nan"),
    (["--punch-width", "0"], "--punch-width = 0.0"),
    (["--preset", "basis", "--punch-width", "30"], "--punch-width = 30.0"),
    (["--preset", "basis", "--phi1", "20"], "--phi1 cannot be combined with --preset"),
    (["--preset", "basis", "--nonlinear", "--nonlinear-meshes", "2"], "--nonlinear-meshes = 2: must be 1 or 3"),
])
def test_bad_input_is_one_line_and_exit_2(argv, fragment, capsys):
    assert main(["verify"] + argv) == 2
    err = capsys.readouterr().err
    assert fragment in err and len(err.strip().splitlines()) == 1


#: Bodies ``dacm design`` can output (thin, thick, unequal hinges; basis and proposed; both
#: materials): its 5 N DACM (hinges 0.25-0.83 mm) and basis body (0.37-1.24 mm, the body
#: whose verify stopped with a traceback), a hinge at the 0.25 mm minimum feature (sample A
#: as cut), a thick-hinge basis (t / L = 0.69) and an ABS body at the sweep's corner.
DESIGN_OUTPUTS = {
    "design-5N": body(*DESIGN_5N, "design-5N"),
    "basis-5N": body(*BASIS_5N, "basis-5N"),
    "sample-a-as-cut": preset("sample-a-as-cut"),
    "thick": body(22.0, None, (1.1,) * 8 + (0.5,) * 4, "thick", hinge_length_mm=1.6),
    "abs": body(31.0, 8.0, (0.3,) * 12, "abs", material=MATERIALS["abs"]),
}


@pytest.mark.parametrize("name", sorted(DESIGN_OUTPUTS))
def test_verify_works_on_design_outputs_as_cut(name, tmp_path, capsys):
    """``dacm verify --config X.toml --mesh coarse`` (1.5 to 3 elements across each hinge)
    on each body: the part as cut with the design's 0.8 mm kerf by default, and said so;
    every hinge gets a neck stress and a peak at least as large (exact on a linear field:
    the peak is the maximum over the corners of the triangles holding the neck's points);
    on mirror-symmetric bodies mirror-image hinges agree within 3 % (the mesh is not
    mirror-symmetric)."""
    d = DESIGN_OUTPUTS[name]
    save_design(d, tmp_path / "d.toml")
    argv = ["verify", "--config", str(tmp_path / "d.toml"), "--mesh", "coarse", "--no-plots"]
    assert main(argv + ["--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert (out["kerf_mm"], out["profile"]) == (0.8, "as cut, kerf 0.8 mm")
    hinges = range(1, 9) if d.is_basis else range(1, 13)
    neck, peak = out["fe"]["hinge_stress_MPa"], out["fe"]["hinge_peak_stress_MPa"]
    assert sorted(neck, key=int) == sorted(peak, key=int) == [str(h) for h in hinges]
    for h in neck:
        assert math.isfinite(neck[h]) and 0 < neck[h] <= peak[h] * (1 + 1e-9), h
    pairs = [(a, b) for a, b in PAIRS if str(a) in neck]
    if all(d.hinge_thickness_mm[a - 1] == d.hinge_thickness_mm[b - 1] for a, b in pairs):
        for a, b in pairs:
            assert neck[str(a)] == pytest.approx(neck[str(b)], rel=0.03), (a, b)
            assert peak[str(a)] == pytest.approx(peak[str(b)], rel=0.03), (a, b)
    assert out["convergence"]["k_out_N_per_mm"]["error_pct"] < 5.0
    # the knee block's core (0.5 mm inside its edges) moves nearly as a rigid body (the
    # beam model's knee bends only as two stubs, read at its centre node): a rigid motion
    # fits its nodes within 0.5 % of its travel (measured 0.01-0.07 %); the beam moves it
    # outward within 5 % of the FE (measured -3.4 to +1.2 % on these coarse meshes with
    # the knees rigid: where an error in A starts)
    assert out["fe"]["knee_fit_residual"] < 5e-3
    assert abs(out["errors_pct"]["knee_outward_per_input"]) < 5.0
    # and turns it the same way within 8 % (measured -3.5 to +5.2 %; a sign slip is -200 %)
    assert abs(out["errors_pct"]["knee_rotation_per_input_rad_per_mm"]) < 8.0
    # both extrapolated from the three meshes, like A: the finest coarse mesh within 1.5 % of
    # the estimate (measured 0.03-0.56 %), so the errors above are the beam's, not the mesh's
    for key in ("knee_outward_per_input", "knee_rotation_per_input_rad_per_mm"):
        assert out["convergence"][key]["error_pct"] < 1.5, key


def test_verify_warns_when_the_part_passes_its_allowable_stress_before_the_travel(tmp_path, capsys):
    """The basis specimen as cut, 2 mm output (linear, scaled): its largest FE peak (64 MPa,
    the converged fillet peak) is 1.8 x delrin's allowable 36 MPa, so the elastic values are
    of a state the cut part does not hold, and the text says so; at 1 mm (32 MPa) it does not."""
    argv = ["verify", "--preset", "basis", "--mesh", "coarse", "--no-plots", "--target-output"]
    assert main(argv + ["2", "--json"]) == 0
    fe = json.loads(capsys.readouterr().out)["fe"]
    assert fe["peak_stress_MPa"] == max(fe["hinge_peak_stress_MPa"].values())
    assert fe["stress_utilisation"] == pytest.approx(fe["peak_stress_MPa"] / 36.0, rel=1e-12)
    assert fe["stress_utilisation"] > 1.0
    assert main(argv + ["2"]) == 0
    text = capsys.readouterr().out
    assert f"largest peak at 2 mm (FE): {fe['peak_stress_MPa']:.1f} MPa at hinge {fe['peak_stress_hinge']}" in text
    assert "warning: the part passes its allowable stress before 2 mm" in text
    assert main(argv + ["1"]) == 0
    text = capsys.readouterr().out
    assert "largest peak at 1 mm (FE)" in text and "warning" not in text


@pytest.mark.parametrize(("name", "knee", "hinges"), [
    ("basis-5N", "left knee per mm of input, FE / beam: outward", 8),
    ("design-5N", "left knee per mm of input (where an error in A starts), FE / beam: outward", 12)])
def test_verify_text_says_the_part_is_as_cut(name, knee, hinges, tmp_path, capsys):
    """The issue's command on ``dacm design``'s 5 N bodies (the basis used to stop with a
    traceback): the header names the profile solved, each hinge prints its peak, the knee
    line its FE mesh error, and only a DACM's knee line says an error in A starts there (the
    basis has no middle branch to amplify the knee's motion)."""
    save_design(DESIGN_OUTPUTS[name], tmp_path / "d.toml")
    assert main(["verify", "--config", str(tmp_path / "d.toml"), "--mesh", "coarse",
                 "--no-plots"]) == 0
    text = capsys.readouterr().out
    assert f"{name} as cut, kerf 0.8 mm: continuum FE" in text
    knee_line = next(line for line in text.splitlines() if "left knee" in line)
    assert knee_line.strip().startswith(knee) and "FE mesh error" in knee_line, knee_line
    assert sum(line.strip().startswith("hinge") and "peak:" in line for line in text.splitlines()) == hinges


def test_a_beam_model_that_goes_unstable_is_reported_beside_the_fe(tmp_path, capsys, monkeypatch):
    """Where the beam model's path stops being stable before the target (nonlinear), verify
    still reports the continuum's values and whether its state is stable, and says why the
    beam has none, instead of stopping on the beam's error after the FE's minute."""
    import sensor.mechanics.solver as solver
    from sensor.errors import InstabilityError

    def unstable(*args, **kwargs):
        raise InstabilityError("increment 4: the equilibrium at input force 104.8 N is unstable")

    monkeypatch.setattr(solver, "solve", unstable)
    argv = ["verify", "--preset", "basis", "--mesh", "coarse", "--kerf", "0", "--no-plots",
            "--target-output", "0.05", "--nonlinear", "--out", str(tmp_path)]
    assert main(argv + ["--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["beam"] == {"unstable": "increment 4: the equilibrium at input force 104.8 N is unstable"}
    assert out["errors_pct"] == {} and out["fe"]["k_out_N_per_mm"] > 0
    assert out["stability"]["stable"] is True and out["options"]["nonlinear_meshes"] == 1
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "nonlinear on that mesh, the coarsest of three solved linear" in text
    assert "beam model: increment 4: the equilibrium at input force 104.8 N is unstable" in text
    assert "the continuum state" not in text   # the FE's own state is stable
