"""The one output rule (sensor/cli/output.py) in every command that writes files: an existing
finished file (one a manifest lists) stops the command with one line naming it and --force,
before the expensive work (the work is replaced by a function that fails the test if it is
called), and leaves it as it was; a file no manifest lists is what an interrupted run left
and is removed with a note; --force replaces; --out is a folder; sweep --resume finishes a
checkpoint without --force."""

from __future__ import annotations

import json

import pytest

from tests.conftest import assert_one_line_error

LINE = ["--length", "2", "--bore", "0.004", "--volume", "1e-5", "--pressure", "300000"]

#: command -> (arguments, the first file it writes, "module:function" of its expensive work)
CASES = {
    "export": (["--preset", "sample-a", "--dxf"], "sample-a.dxf", "geometry.export:export_design"),
    "draw": (["--preset", "sample-a"], "sample-a-profile.png", "geometry.drawing:profile_figure"),
    "render": (["--preset", "sample-b"], "sample-b-render.png", "sensor.mechanics.solver:solve"),
    "sensor": (["--preset", "sample-b"], "sample-b-calibration.png",
               "sensor.readout.sensor_model:build_sensor"),
    "verify": (["--preset", "basis"], "basis-verify.png", "sensor.mechanics.continuum:verify_design"),
    "report": (["--preset", "basis"], "basis-report.html",
               "sensor.report.design_report:write_design_report"),
    "measure": (["loop.csv", "--preset", "basis", "--calibrate"], "basis-calibrated.toml",
                "sensor.readout.measured:read_loop_csv"),
    "sweep": (["--phi1", "20:22:2", "--phi2", "20:30:2", "--quiet"], "figure49.svg",
              "sensor.design_space.execution:run_sweep"),
    "line": (LINE, "line-step.png", "sensor.pneumatic.line_response:analyse"),
    "loop": ([], "loop.png", "sensor.pneumatic.studies:run"),
    "snr": (["a.png", "b.png", "--figure", "{out}/pair.png"], "pair.png", "mri.study:measure_pair"),
    "design": (["--range", "5"], "design.toml", "sensor.design_space.optimise:optimise"),
}


@pytest.mark.parametrize("command", sorted(CASES))
def test_an_existing_file_stops_the_command_before_it_computes(command, dacm, tmp_path, monkeypatch):
    import importlib

    argv, name, work = CASES[command]
    module, function = work.split(":")

    def computed(*args, **kwargs):
        raise AssertionError(f"{work} was called although {name} exists")

    monkeypatch.setattr(importlib.import_module(module), function, computed)
    existing = tmp_path / name
    existing.write_text("mine")
    if command != "snr":  # a finished result: listed in its command's manifest
        _list_in_manifest(existing, command)
    argv = [a.replace("{out}", str(tmp_path)) for a in argv]
    status, out, err = dacm(command, *argv, *([] if command == "snr" else ["--out", tmp_path]))
    assert_one_line_error(status, err, command)
    assert f"{existing} exists" in err and "--force" in err
    assert out == "" and existing.read_text() == "mine"


def _list_in_manifest(path, command):
    from sensor.cli.output import MANIFEST_SCHEMA, file_record

    run = {"argv": ["dacm", command], "version": "test", "time": "", "files": [file_record(path)]}
    (path.parent / f"{command}-manifest.json").write_text(
        json.dumps({"schema": MANIFEST_SCHEMA, "command": command, "runs": [run], "removed": []}))


def test_a_file_no_manifest_lists_is_removed_with_a_note(dacm, tmp_path):
    """What an interrupted run (or a version before manifests) left under a final name does
    not block the next run: it is removed with one note, no --force needed."""
    left = tmp_path / "basis.dxf"
    left.write_text("half a file")
    status, out, err = dacm("export", "--preset", "basis", "--dxf", "--out", tmp_path)
    assert status == 0, err
    assert err.count("\n") == 1 and err.startswith("dacm export: note: removed") and str(left) in err
    assert out == f"wrote {left}\n" and left.read_text().rstrip().endswith("EOF")
    listed = json.loads((tmp_path / "export-manifest.json").read_text())["runs"][-1]["files"]
    assert [f["name"] for f in listed] == ["basis.dxf"] and listed[0]["bytes"] == left.stat().st_size


def test_force_replaces_and_out_is_a_folder(dacm, tmp_path):
    target = tmp_path / "sample-a-profile.png"
    target.write_text("mine")
    _list_in_manifest(target, "draw")
    status, out, err = dacm("draw", "--preset", "sample-a", "--dpi", "30", "--out", tmp_path, "--force")
    assert status == 0 and out == f"wrote {target}\n"
    assert target.read_bytes().startswith(b"\x89PNG")
    status, _, err = dacm("draw", "--preset", "sample-a", "--out", target)
    assert_one_line_error(status, err, "draw")
    assert "is a file" in err


def test_default_folder_is_dacm_out(dacm, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    status, out, _ = dacm("export", "--preset", "basis", "--dxf")
    assert status == 0 and out == "wrote dacm-out/basis.dxf\n"


def test_sweep_resume_finishes_a_checkpoint_and_is_no_replacement(dacm, tmp_path):
    """A finished sweep's files are protected even with --resume; a checkpoint left alone
    (what an interrupted sweep leaves, OUT/sweep-checkpoint.nc) stops a new run without
    --resume, and is finished by --resume without --force, computing nothing again (every
    cell is in it), to the same dataset; the finished set replaces the checkpoint."""
    import shutil

    import xarray as xr

    grid = ["--phi1", "20:22:2", "--phi2", "20:30:2", "--hinges", "05-03", "--quiet", "--no-plots"]
    status, out, err = dacm("sweep", *grid, "--out", tmp_path, "--json")
    assert status == 0, err
    first = json.loads(out)
    assert first["computed_now"] == first["cells"] == 4
    assert [f["path"] for f in first["files"]] == [str(tmp_path / n) for n in ("sweep.nc", "sweep.csv", "pareto-05-03.csv")]
    before = xr.load_dataset(tmp_path / "sweep.nc", engine="h5netcdf")

    status, _, err = dacm("sweep", *grid, "--out", tmp_path, "--resume")
    assert_one_line_error(status, err, "sweep")
    assert "sweep.nc exists" in err

    checkpoint = tmp_path / "sweep-checkpoint.nc"
    shutil.move(tmp_path / "sweep.nc", checkpoint)
    for name in ("sweep.csv", "pareto-05-03.csv", "sweep-manifest.json"):
        (tmp_path / name).unlink()
    status, _, err = dacm("sweep", *grid, "--out", tmp_path)
    assert_one_line_error(status, err, "sweep")
    assert f"{checkpoint} is the checkpoint of an interrupted sweep" in err and "--resume" in err
    status, out, err = dacm("sweep", *grid, "--out", tmp_path, "--resume", "--json")
    assert status == 0, err
    assert json.loads(out)["computed_now"] == 0
    after = xr.load_dataset(tmp_path / "sweep.nc", engine="h5netcdf")
    xr.testing.assert_equal(before, after)
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "pareto-05-03.csv", "sweep-manifest.json", "sweep.csv", "sweep.nc"]
