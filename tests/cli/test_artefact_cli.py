"""``dacm artefact`` through ``sensor.cli.main``: numbers, files, JSON and bad input (exit 2,
one line naming flag, value and rule, nothing written)."""

from __future__ import annotations

import json

import numpy as np
import pytest
import xarray as xr

from sensor.cli import main
from tests.conftest import assert_one_line_error

#: A coarse, quick run (1 mm field voxels, 10 mm of water around the body).
QUICK = ["--resolution-mm", "1", "--margin-mm", "10", "--quiet"]


def test_json_numbers_and_files(capsys, tmp_path):
    status = main(["artefact", "--preset", "basis", "--b0", "1.5", "--te-ms", "20", "--json",
                   "--out", str(tmp_path), *QUICK])
    out = capsys.readouterr().out
    assert status == 0
    s = json.loads(out)
    assert s["design"] == "basis" and s["material"] == "delrin" and s["b0_T"] == 1.5
    assert [r["distance_mm"] for r in s["surface_offsets"]] == [1.0, 2.0, 5.0]
    assert set(s["gradient_echo"]) == {"loss_threshold", "extent_mm", "volume_mm3", "reaches_fov_edge"}
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == ["basis-artefact-field.png", "basis-artefact-image.png", "basis-artefact.json",
                     "basis-artefact.nc"]
    assert json.loads((tmp_path / "basis-artefact.json").read_text())["surface_offsets"] == s["surface_offsets"]
    with xr.open_dataset(tmp_path / "basis-artefact.nc", engine="h5netcdf") as ds:
        hz_per_ppm = s["max_offset_hz"] / s["max_offset_ppm"]
        assert np.allclose(ds["field_hz"], ds["field_ppm"] * hz_per_ppm, rtol=1e-5, atol=1e-6)
        assert ds["field_ppm"].attrs["units"] == "ppm" and ds["x"].attrs["units"] == "mm"
        assert json.loads(ds.attrs["summary"])["gradient_echo"] == s["gradient_echo"]


def test_text_output_and_the_output_rule(capsys, tmp_path):
    argv = ["artefact", "--design", "basis", "--phi1", "20", "--medium", "air", "--b0-direction",
            "0,1,1", "--out", str(tmp_path), *QUICK]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "in air (0.36 ppm)" in out and "1 mm from the surface" in out and "spin-echo shift" in out
    assert main(argv) == 2  # the files exist: refused without --force
    assert "exists" in capsys.readouterr().err
    assert main(argv + ["--force"]) == 0


@pytest.mark.parametrize("bad,fragment", [
    (["--b0", "nan"], "--b0 = nan: must be a positive finite number up to 20 (T)"),
    (["--te-ms", "-1"], "--te-ms = -1.0: must be a positive"),
    (["--bandwidth-hz-per-px", "0"], "--bandwidth-hz-per-px = 0.0"),
    (["--voxel-mm", "1.3"], "--voxel-mm = 1.3: must be a whole multiple of the field --resolution-mm = 1"),
    (["--resolution-mm", "inf"], "--resolution-mm = inf"),
    (["--margin-mm", "1e308"], "--margin-mm = 1e+308: must be a number in [10, 200] (mm)"),
    (["--b0-direction", "up"], "--b0-direction = 'up': must be x, y, z or three numbers"),
    (["--b0-direction", "0,0,0"], "--b0-direction = '0,0,0'"),
    (["--medium", "oil"], "invalid choice: 'oil'"),
    (["--material", "aluminium"], "--material = 'aluminium': must be one of delrin, abs"),
])
def test_bad_input_is_one_line_and_writes_nothing(capsys, tmp_path, bad, fragment):
    out = tmp_path / "out"
    argv = ["artefact", "--preset", "basis", *QUICK, "--out", str(out), *bad]
    try:
        status = main(argv)
    except SystemExit as exc:  # argparse's own one-line usage errors
        status = exc.code
    err = capsys.readouterr().err
    assert_one_line_error(status, err, "artefact")
    assert fragment in err, err
    assert not out.exists()


def test_an_infeasible_design_is_refused(capsys, tmp_path):
    out = tmp_path / "out"
    status = main(["artefact", "--phi1", "22", "--phi2", "80", *QUICK, "--out", str(out)])
    assert_one_line_error(status, capsys.readouterr().err, "artefact")
    assert not out.exists()
