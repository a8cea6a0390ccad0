"""Measured loops: figures of exact loops, recovery of E and of the strain-energy law from
synthetic loops made by the model with known parameters, and bad files."""

import dataclasses

import numpy as np
import pytest

from geometry.params import load_design, preset
from sensor.errors import HysteresisError
from sensor.mechanics.hysteresis import StrainEnergyLaw, preisach_offsets
from sensor.readout.measured import Loop, fit_law, fit_modulus, loop_figures, model_loop
from tests.conftest import assert_one_line_error

DESIGN = preset("sample-b-as-cut")
TRUE_E_MPA, TRUE_H_PER_MJ, MAX_FORCE_N = 1900.0, 0.08, 5.0


def _synthetic(noise_mm: float, seed: int = 1) -> Loop:
    """A force-displacement loop of sample B at E = 1900 MPa with H = 0.08/mJ x SE."""
    true = DESIGN.replace(material=dataclasses.replace(DESIGN.material, E_MPa=TRUE_E_MPA))
    loop = model_loop(true, "displacement", MAX_FORCE_N, StrainEnergyLaw(TRUE_H_PER_MJ, "truth"))
    rng = np.random.default_rng(seed)
    return Loop(loop.force_N, loop.response + noise_mm * rng.standard_normal(len(loop.force_N)),
                "displacement", "synthetic")


def test_figures_of_a_linear_preisach_loop_are_exact():
    """y = 0.2 F + Preisach offsets of hysteresis 0.05: slope 0.2 (the offsets are odd about
    the mean branch, so least squares keeps the slope), H = 0.05 (eq 87), nonlinearity 0."""
    up = np.linspace(0, 1, 401)
    f = np.concatenate([up, up[-2::-1]])
    h, _ = preisach_offsets(f, 2 * 0.05)
    fig = loop_figures(Loop(f, 0.2 * f + 0.2 * h, "displacement"))
    assert fig.sensitivity == pytest.approx(0.2, rel=1e-6)
    assert fig.hysteresis == pytest.approx(0.05, rel=1e-3)  # eq 87 on a 512-point grid
    assert fig.nonlinearity_pct == pytest.approx(0.0, abs=1e-6)


def test_modulus_recovered_from_a_noise_free_loop():
    """The model's forces scale with E at every shape: E back within 0.1 % (the loop's
    201-point branches are interpolated linearly against a 16-increment solve)."""
    fit = fit_modulus(_synthetic(0.0), DESIGN)
    assert fit.E_MPa == pytest.approx(TRUE_E_MPA, rel=1e-3)
    assert fit.E_model_MPa == DESIGN.material.E_MPa


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_modulus_and_law_recovered_from_a_noisy_loop(seed):
    """0.2 um RMS travel noise (a good capacitive probe) on a 0.94 mm loop: E within 0.3 %
    (noise averages over 400 samples) and the law's constant within 5 % (eq 87 takes the
    largest branch gap, which noise biases up by a few sigma: 3 x 0.2 um / 34 um = 2 %)."""
    loop = _synthetic(0.2e-3, seed)
    fit = fit_modulus(loop, DESIGN)
    assert fit.E_MPa == pytest.approx(TRUE_E_MPA, rel=3e-3)
    assert fit_law(loop, fit.strain_energy_mJ).h_per_mJ == pytest.approx(TRUE_H_PER_MJ, rel=0.05)


def test_cli_calibrates_and_writes_a_design_every_command_reads(tmp_path, dacm):
    loop = _synthetic(0.0)
    csv = tmp_path / "loop.csv"
    np.savetxt(csv, np.c_[loop.force_N, loop.response], delimiter=",",
               header="force_N,displacement_mm", comments="")
    status, out, err = dacm("measure", csv, "--preset", "sample-b-as-cut", "--calibrate",
                            "--out", tmp_path / "o", "--json")
    assert status == 0, err
    import json
    res = json.loads(out)
    assert res["calibration"]["E_MPa"] == pytest.approx(TRUE_E_MPA, rel=1e-3)
    written = load_design(res["files"][0]["path"])
    assert written.material.E_MPa == pytest.approx(res["calibration"]["E_MPa"])
    status, out, _ = dacm("solve", "--config", res["files"][0]["path"], "--json")
    assert status == 0


@pytest.mark.parametrize("content, extra", [
    ("force_N,displacement_mm\n1,2\n", []),                       # too short
    ("force_N,displacement_mm\n" + "".join(f"{i},{i}\n" for i in range(20)), []),  # no unloading
    ("force_N,height\n" + "".join(f"{i},{i}\n" for i in range(20)), []),  # no displacement column
    ("a,b\n1,x\n", []),                                            # not numbers
    (b"\xff\xfe\x00garbage", []),                                  # not UTF-8
    ("1,2\n2,3\n", ["--columns", "force,strain"]),                 # unknown columns
])
def test_bad_files_one_line_exit_2(tmp_path, dacm, content, extra):
    path = tmp_path / "bad.csv"
    (path.write_bytes if isinstance(content, bytes) else path.write_text)(content)
    status, _, err = dacm("measure", path, "--preset", "basis", *extra, "--out", tmp_path / "o")
    assert_one_line_error(status, err, "measure")
    assert not (tmp_path / "o").exists()


def test_missing_file_is_one_line(tmp_path, dacm):
    status, _, err = dacm("measure", tmp_path / "none.csv", "--preset", "basis")
    assert_one_line_error(status, err, "measure")


def test_volts_loops_cannot_calibrate_E():
    up = np.linspace(0, 1, 50)
    loop = Loop(np.concatenate([up, up[-2::-1]]), np.concatenate([up, up[-2::-1]]), "volts")
    with pytest.raises(HysteresisError, match="force,displacement"):
        fit_modulus(loop, DESIGN)
