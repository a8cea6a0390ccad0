"""``dacm export`` and ``dacm draw`` through the CLI entry point: files written, bad input
reported in one line with exit status 2 and nothing left behind."""

import hashlib
import json

import ezdxf
import ezdxf.bbox
import pytest

from geometry.params import MATERIALS, make_design, save_design
from geometry.topology import load_model


def test_export_preset_writes_what_it_prints(tmp_path, dacm):
    status, out, err = dacm("export", "--preset", "sample-a", "--out", str(tmp_path),
                           "--dxf", "--beam-model")
    assert status == 0 and err == ""
    written = sorted(tmp_path.iterdir())
    assert [p.name for p in written] == ["export-manifest.json", "sample-a.dxf", "sample-a.json"]
    assert out.splitlines() == [f"wrote {tmp_path / 'sample-a.dxf'}", f"wrote {tmp_path / 'sample-a.json'}"]
    assert load_model(tmp_path / "sample-a.json").E_MPa == MATERIALS["delrin"].E_MPa


def test_export_json_prints_the_files_and_solve_reads_the_beam_model(tmp_path, dacm):
    """`--json` is stdout (as in every command), `--beam-model` the file; the README's
    `dacm solve --model` example solves what export wrote, to the design's own numbers."""
    status, out, err = dacm("export", "--preset", "sample-b", "--out", str(tmp_path),
                           "--beam-model", "--json")
    assert status == 0 and err == ""
    files = json.loads(out)
    path = tmp_path / "sample-b.json"
    assert files == {"design": "sample-b", "kerf_mm": None, "formats": ["json"],
                     "files": [{"path": str(path), "bytes": path.stat().st_size,
                                "sha256": hashlib.sha256(path.read_bytes()).hexdigest()}]}
    by_model = json.loads(dacm("solve", "--model", str(tmp_path / "sample-b.json"), "--json")[1])
    by_design = json.loads(dacm("solve", "--preset", "sample-b", "--json")[1])
    assert by_model["amplification"] == by_design["amplification"]  # the same model, same solver


def test_export_all_formats_from_flags_with_kerf(tmp_path, dacm):
    status, out, _ = dacm("export", "--design", "basis", "--phi1", "20", "--hinges",
                         "03-03", "--material", "abs", "--kerf", "0.6", "--out", str(tmp_path))
    assert status == 0
    stem = "basis-20-03-03-abs"
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        [f"{stem}.{ext}" for ext in ("dxf", "stl", "step", "json")] + ["export-manifest.json"])
    assert load_model(tmp_path / f"{stem}.json").E_MPa == 1800.0  # ABS
    doc = ezdxf.readfile(tmp_path / f"{stem}.dxf")
    box = ezdxf.bbox.extents(doc.modelspace())
    assert box.size.x == pytest.approx(25.0 + 0.6, abs=1e-6)  # outline out by kerf / 2


def test_export_from_toml_is_named_after_the_file(tmp_path, dacm):
    save_design(make_design(21.0, 34.0), tmp_path / "mine.toml")
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    status, _, _ = dacm("export", "--config", str(tmp_path / "mine.toml"), "--out",
                       str(out_dir), "--beam-model")
    assert status == 0
    assert sorted(p.name for p in out_dir.iterdir()) == ["export-manifest.json", "mine.json"]


@pytest.mark.parametrize("argv, message", [
    (["--preset", "sample-z"], "preset = 'sample-z': unknown"),
    (["--phi1", "95"], "phi1_deg = 95.0: must be a number strictly between 0 and 90"),
    (["--phi2", "0"], "phi2_deg = 0.0: must be a number strictly between 0 and 90"),
    (["--phi1", "40"], "infeasible design: rule 'angle_limits' fails: phi1_deg = 40"),
    (["--hinges", "07-03"], "hinge_set = '07-03'"),
    (["--design", "hexagon"], "--design = 'hexagon'"),
    (["--design", "basis", "--phi2", "10"], "--phi2 = 10: the basis body has no middle branch"),
    (["--preset", "basis", "--phi1", "20"], "--phi1 cannot be combined with --preset"),
    (["--material", "steel"], "--material = 'steel'"),
    (["--kerf", "1.6", "--preset", "sample-a"], "rule 'kerf_gap' fails"),
])
def test_export_bad_input_one_line_status_2_no_file(tmp_path, dacm, argv, message):
    status, out, err = dacm("export", *argv, "--out", str(tmp_path))
    assert status == 2 and out == ""
    assert len(err.splitlines()) == 1
    assert err.startswith("dacm export: error: ") and message in err
    assert list(tmp_path.iterdir()) == []


def test_export_malformed_toml(tmp_path, dacm):
    bad = tmp_path / "bad.toml"
    bad.write_text("phi1_deg = [\n")
    status, _, err = dacm("export", "--config", str(bad), "--out", str(tmp_path))
    assert status == 2 and len(err.splitlines()) == 1 and "malformed TOML" in err
    assert [p.name for p in tmp_path.iterdir()] == ["bad.toml"]


def test_export_unwritable_output(tmp_path, dacm):
    (tmp_path / "file").write_text("")
    status, _, err = dacm("export", "--preset", "basis", "--out", str(tmp_path / "file" / "dir"))
    assert status == 2 and len(err.splitlines()) == 1 and "cannot create output folder" in err
    assert [p.name for p in tmp_path.iterdir()] == ["file"]


def test_export_bad_design_creates_no_folder(tmp_path, dacm):
    status, _, _ = dacm("export", "--phi1", "40", "--out", str(tmp_path / "new"))
    assert status == 2 and list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("fmt, magic", [("png", b"\x89PNG"), ("svg", b"<?xml")])
def test_draw_writes_picture(tmp_path, dacm, fmt, magic):
    target = tmp_path / "new" / f"sample-a-profile.{fmt}"
    status, out, _ = dacm("draw", "--preset", "sample-a", "--out", str(target.parent),
                          "--format", fmt, "--dpi", "60")
    assert status == 0 and out == f"wrote {target}\n"
    assert target.read_bytes().startswith(magic)
    assert sorted(p.name for p in target.parent.iterdir()) == ["draw-manifest.json", target.name]


@pytest.mark.parametrize("argv, message", [
    (["--out", "{tmp}/a.svg"], "--out = '{tmp}/a.svg': --out is a folder now"),
    (["--format", "jpg"], "--format = 'jpg': must be one of png, svg"),
    (["--phi1", "40", "--out", "{tmp}/o"], "rule 'angle_limits' fails"),
])
def test_draw_bad_input(tmp_path, dacm, argv, message):
    argv = [a.format(tmp=tmp_path) for a in argv]
    message = message.format(tmp=tmp_path)
    status, _, err = dacm("draw", *argv)
    assert status == 2 and len(err.splitlines()) == 1
    assert err.startswith("dacm draw: error: ") and message in err
    assert list(tmp_path.iterdir()) == []
