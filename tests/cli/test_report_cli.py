"""``dacm report``: the page and the files, --json, the output rule (--force), bad input."""

import json
from pathlib import Path

from tests.conftest import assert_one_line_error


def test_report_writes_the_page_and_replaces_only_with_force(dacm, tmp_path):
    status, out, err = dacm("report", "--preset", "basis", "--out", tmp_path, "--no-verify", "--json")
    assert status == 0, err
    s = json.loads(out)
    assert s["report"] == str(tmp_path / "basis-report.html")
    assert [Path(f["path"]).name for f in s["files"]] == [f"basis.{x}" for x in ("dxf", "stl", "step", "json", "toml")] + [
        "basis-report.html"]
    # the basis body is a symmetric hexagon: output travel = input travel (A_kin = 1; A = 1
    # less the input contact's compression, 0.02 %)
    assert abs(s["solve"]["amplification"] - 1.0) < 1e-3 and s["solve"]["A_kin"] == 1.0
    assert s["verification"]["status"] == "not run"
    page = tmp_path / "basis-report.html"
    before, inode = page.read_bytes(), page.stat().st_ino

    status, _, err = dacm("report", "--preset", "basis", "--out", tmp_path, "--no-verify")
    assert_one_line_error(status, err, "report")
    assert "basis" in err and "--force" in err
    assert page.read_bytes() == before

    status, out, err = dacm("report", "--preset", "basis", "--out", tmp_path, "--no-verify", "--force")
    assert status == 0, err
    assert out.strip().splitlines()[-1] == f"wrote {page}"
    assert page.stat().st_ino != inode            # a new file moved into place


def test_bad_input_is_one_line(dacm, tmp_path):
    for argv, word in ((("--target-output", "-1"), "--target-output"),
                       (("--preset", "sample-b", "--phi1", "20"), "--phi1"),
                       (("--preset", "no-such"), "no-such")):
        status, _, err = dacm("report", *argv, "--out", tmp_path, "--no-verify")
        assert_one_line_error(status, err, "report")
        assert word in err
    assert not any(tmp_path.iterdir())
