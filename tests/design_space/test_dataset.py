"""The sweep dataset's files: CF-1.10 by the IOOS compliance-checker (an independent
implementation of the conventions), provenance in every file, flags as 0/1 everywhere, and
a lossless NetCDF round trip."""

import json

import numpy as np
import pandas as pd
import pytest
import xarray as xr

from sensor.cli import main
from sensor.design_space.dataset import FLAGS, load_dataset

ARGS = ["sweep", "--hinges", "03-03", "--phi1", "18:26:3", "--phi2", "12:30:3", "--monte-carlo", "2",
        "--hinge-sd", "0.01", "--no-plots", "--quiet"]


@pytest.fixture(scope="module")
def out(tmp_path_factory):
    path = tmp_path_factory.mktemp("sweep")
    assert main([*ARGS, "--out", str(path)]) == 0
    return path


def test_netcdf_passes_the_cf_1_10_checker_without_errors_or_warnings(out, tmp_path):
    from compliance_checker.runner import CheckSuite, ComplianceChecker

    CheckSuite.load_all_available_checkers()
    report = tmp_path / "cf.json"
    passed, crashed = ComplianceChecker.run_checker(str(out / "sweep.nc"), ["cf:1.10"], 0, "normal",
                                                    output_filename=str(report), output_format="json")
    result = json.loads(report.read_text())["cf:1.10"]
    problems = {level: [(c["name"], c["msgs"]) for c in result[level] if c["msgs"]]
                for level in ("high_priorities", "medium_priorities")}
    assert problems == {"high_priorities": [], "medium_priorities": []}
    assert passed and not crashed  # crashed: a check raised (it did on a string coordinate)


def test_netcdf_records_the_command_and_keeps_coordinates_without_fill_values(out):
    with xr.open_dataset(out / "sweep.nc", engine="h5netcdf", decode_cf=False) as raw:
        assert raw.attrs["history"].endswith(f"{' '.join(['dacm', *ARGS, '--out', str(out)])} (dacm "
                                             f"{raw.attrs['software'].split()[1]})")
        for name in ("phi1_deg", "phi2_deg", "family_hinge_mm"):
            assert "_FillValue" not in raw[name].attrs, name
        assert raw["hinge_set"].dims == ("hinges",) and "units" not in raw["hinge_set"].attrs
        assert "hinge_set" in raw["amplification"].attrs["coordinates"]
        assert "units" not in raw["reason"].attrs
        assert raw["feasible"].dtype == np.int8 and set(np.unique(raw["feasible"].values)) <= {0, 1}


def test_netcdf_round_trip_is_lossless(out, tmp_path):
    from sensor.design_space.dataset import save_dataset

    ds = load_dataset(out / "sweep.nc")
    assert list(ds["hinges"].values) == ["03-03"] and ds["feasible"].dtype == bool
    save_dataset(ds, tmp_path / "again.nc")
    again = load_dataset(tmp_path / "again.nc")
    xr.testing.assert_identical(ds.drop_attrs(deep=False), again.drop_attrs(deep=False))
    # the same command saving again adds no second history line
    assert again.attrs["history"] == ds.attrs["history"]


def test_csv_has_provenance_comments_and_flags_as_0_1(out):
    lines = (out / "sweep.csv").read_text().splitlines()
    assert lines[0].startswith("# made by dacm ") and lines[1] == "# command: " + " ".join(
        ["dacm", *ARGS, "--out", str(out)])
    df = pd.read_csv(out / "sweep.csv", comment="#")
    assert "hinges" in df.columns and "reason" in df.columns   # text columns: no [units]
    for flag in FLAGS:
        assert set(df[f"{flag} [1]"].unique()) <= {0, 1}
    assert (out / "pareto-03-03.csv").read_text().startswith("# made by dacm ")
