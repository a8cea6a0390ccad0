"""`dacm verify` from the command line: JSON keys, the figure, bad input."""

import json

import pytest

from sensor.cli import main


def test_verify_json_has_the_issue_keys_and_writes_the_figure(tmp_path, capsys):
    assert main(["verify", "--preset", "basis", "--mesh", "coarse", "--json", "--out", str(tmp_path)]) == 0
    out = json.loads(capsys.readouterr().out)
    for side in ("fe", "beam"):
        for key in ("amplification", "k_out_N_per_mm", "strain_energy_mJ", "hinge_stress_MPa"):
            assert key in out[side], (side, key)
        assert sorted(out[side]["hinge_stress_MPa"], key=int) == [str(h) for h in range(1, 9)]
    for key in ("amplification", "k_out_N_per_mm", "strain_energy_mJ"):
        assert out["errors_pct"][key] == pytest.approx(100 * (out["beam"][key] / out["fe"][key] - 1))
        c = out["convergence"][key]
        assert len(c["values"]) == 3 and c["elements_across"][-1] == pytest.approx(3.0)
    # the beam model agrees with the continuum (the coarse mesh's own error is about 1 %)
    assert abs(out["errors_pct"]["k_out_N_per_mm"]) < 4.0
    assert (tmp_path / "basis-verify.png").stat().st_size > 10_000


@pytest.mark.parametrize("argv,fragment", [
    (["--mesh", "medium"], "--mesh = 'medium'"),
    (["--target-output", "0"], "--target-output = 0.0"),
    (["--kerf", "-1"], "--kerf = -1.0"),
    (["--preset", "basis", "--phi1", "20"], "--phi1 cannot be combined with --preset"),
])
def test_bad_input_is_one_line_and_exit_2(argv, fragment, capsys):
    assert main(["verify"] + argv) == 2
    err = capsys.readouterr().err
    assert fragment in err and len(err.strip().splitlines()) == 1
