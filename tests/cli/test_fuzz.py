"""CLI fuzz test: bad inputs sampled at random for export, check, draw, render, solve, sensor,
verify, report, measure, design and sweep (flags with absurd numbers, malformed TOML designs and sweep settings, malformed
beam models, corrupt sweep datasets). Each must give the tool's answer to bad input: exit
status 2, one line on stderr naming the command, no traceback, and no new or changed file
anywhere (inside --out or beside it). Bounded: a fixed number of examples, each refused
before any real work, a few seconds in all."""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

import pytest
import xarray as xr
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from geometry.params import preset
from geometry.topology import build_beam_model, model_to_dict
from sensor.cli import main
from tests.conftest import assert_one_line_error

BAD_NUMBERS = ["nan", "inf", "-inf", "1e308", "-1e308", "", "abc", "1e999", "-1"]
BAD_INTEGERS = ["1e12", "-1", "2.5", "", "x", "1000000000000"]

DESIGN_TOMLS = [b"material = 5\nphi2_deg = 20\n", b"hinge_set = [1]\nphi2_deg = 20\n", b"design = 5\n",
                b"[[design]]\nphi1_deg = 20\n", b"phi1_deg = \xff\xfe\n", b'name = "../escaped"\nphi2_deg = 20\n',
                b'name = ""\nphi2_deg = 20\n', b"wingspan = 3\nphi2_deg = 20\n", b"phi1_deg = 20\n",
                b'phi1_deg = "22"\n', b"hinge_thickness_mm = [1e308, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1]\n",
                b"[design]\nphi2_deg = 20\nmaterial = {name = 'x', E_MPa = inf, nu = 0.3}\n",
                b'body = "basis"\nphi2_deg = 20\n', b"phi1_deg = [\n"]
SWEEP_TOMLS = [b"hinges = [[1]]\n", b"design = 5\n", b"[[design]]\nphi1_deg = 3\n", b"\xff\xfe\x00",
               b"seed = -1\n", b"monte_carlo = 1e12\n", b'phi1 = "6:31:100000000"\n', b"wingspan = 1\n",
               b"[design]\nwingspan = 1\n", b"hinge_sd_mm = inf\nmonte_carlo = 2\n", b"target_output_mm = 1e308\n",
               b'hinges = ["04-04"]\n']

_GOOD = model_to_dict(build_beam_model(preset("basis")))
_M0 = _GOOD["members"][1]
MODELS = [[1, 2], {**_GOOD, "members": [{k: v for k, v in _M0.items() if k != "start"}]},
          {**_GOOD, "members": [dict(_M0, end=_M0["start"])]},
          {**_GOOD, "members": [dict(_M0, thickness_mm="0.5")]},
          {**_GOOD, "material": {"name": "x", "nu": 0.3}},
          {**_GOOD, "material": {"name": "x", "nu": 0.3, "E_MPa": 1e400}},
          {**_GOOD, "members": [dict(_M0, start=4.5)]}, {**_GOOD, "nodes": [[0, 0]]}, "not json"]


#: A loading-unloading loop (force N, displacement mm) and CSVs that are not one.
LOOP_CSV = b"force_N,displacement_mm\n" + b"".join(
    f"{f:g},{f / 4.4:g}\n".encode() for f in [0, 1, 2, 3, 4, 3, 2, 1, 0])
BAD_CSVS = [b"", b"force_N,displacement_mm\n", b"force_N,displacement_mm\n1,2\n", b"a,b\nx,y\nz,w\n",
            b"force_N,displacement_mm\n0,0\nnan,1\n2,inf\n", b"\xff\xfe\x00\x01", b"1,2,3\n4,5,6\n7,8,9\n",
            b"force_N,displacement_mm\n" + b"0,0\n" * 10]


def _design_cases():
    flags = ["--phi1", "--phi2"]
    cases = [[f, v] for f in flags for v in BAD_NUMBERS + ["0", "90"]]
    cases += [["--hinges", "04-04"], ["--hinges", ""], ["--design", "foo"], ["--preset", "sample-z"],
              ["--material", "steel"], ["--design", "basis", "--phi2", "10"],
              ["--preset", "basis", "--phi1", "20"]]
    cases += [["--config", ("toml", t)] for t in DESIGN_TOMLS]
    return cases


def _numbers(flag, values):
    return [[flag, v] for v in values]


#: command -> (bad argument groups, arguments that put its output in OUT)
COMMANDS = {
    "export": (_design_cases() + _numbers("--kerf", BAD_NUMBERS + ["6"]), ["--dxf", "--out", "OUT"]),
    "check": (_design_cases(), []),
    "draw": (_design_cases() + _numbers("--dpi", BAD_NUMBERS + ["0", "5000"]), ["--out", "OUT"]),
    "render": (_design_cases() + _numbers("--target-output", BAD_NUMBERS + ["0", "31"])
               + _numbers("--scale", BAD_NUMBERS) + _numbers("--window-size", ["1e308x2", "0x0", "x"]),
               ["--out", "OUT"]),
    "solve": (_design_cases() + _numbers("--target-output", BAD_NUMBERS + ["31"])
              + _numbers("--target-force", BAD_NUMBERS) + _numbers("--increments", BAD_INTEGERS)
              + [["--model", ("json", m)] for m in MODELS], []),
    "sensor": (_design_cases() + _numbers("--target-output", BAD_NUMBERS) + _numbers("--sample-rate", BAD_NUMBERS)
               + _numbers("--adc-bits", BAD_INTEGERS + ["99", "0"]) + _numbers("--na", BAD_NUMBERS + ["2"])
               + _numbers("--tolerance", BAD_NUMBERS) + [["--adc-range", "nan", "1"], ["--adc-range", "1", "inf"]]
               + [["--calibration", "foo"], ["--readout", "foo"], ["--optics-model", "foo"]],
               ["--out", "OUT"]),
    "verify": (_design_cases() + _numbers("--target-output", BAD_NUMBERS + ["31"])
               + _numbers("--kerf", BAD_NUMBERS + ["6"]) + [["--mesh", "foo"]], ["--out", "OUT"]),
    "report": (_design_cases() + _numbers("--target-output", BAD_NUMBERS + ["31"]), ["--out", "OUT", "--no-verify"]),
    "measure": ([[("csv", LOOP_CSV)] + bad for bad in _design_cases()] + [[("csv", c)] for c in BAD_CSVS]
                + [[("csv", LOOP_CSV), "--columns", c] for c in ("", "force", "volts,force,x", "mass,length")]
                + [["no-such-file.csv"]], ["--calibrate", "--out", "OUT"]),
    "design": ([["--range", v] for v in BAD_NUMBERS + ["0", "1e6"]]
               + [["--range", "5"] + bad for bad in (
                   _numbers("--target-output", BAD_NUMBERS + ["31"]) + _numbers("--hinge-min", BAD_NUMBERS + ["0.01"])
                   + _numbers("--hinge-max", BAD_NUMBERS + ["50"]) + _numbers("--robust", BAD_NUMBERS)
                   + _numbers("--min-yield", BAD_NUMBERS + ["1.5"]) + _numbers("--workers", BAD_INTEGERS)
                   + [["--seed", "-1"], ["--scheduler", "foo"], ["--hinge-min", "1", "--hinge-max", "0.5"]])],
               ["--out", "OUT"]),
    "sweep": ([["--seed", "-1"], ["--monte-carlo", "1000000000000", "--hinge-sd", "0.01"],
               ["--monte-carlo", "2", "--hinge-sd", "inf"], ["--phi1="], ["--phi1", "6:31:100000000"],
               ["--phi2", "a:b:c"], ["--phi1", "nan:20:3"], ["--scheduler", "foo"], ["--workers", "-1"],
               ["--target-output", "1e308"], ["--hinges", "04-04"], ["--hinge-sd", "-1", "--monte-carlo", "2"],
               ["--resume", ("nc", "corrupt")], ["--resume", ("nc", "no-computed")]]
              + [["--config", ("toml", t)] for t in SWEEP_TOMLS], ["--out", "OUT", "--quiet", "--no-plots"]),
}
CASES = [(cmd, bad) for cmd, (groups, _) in COMMANDS.items() for bad in groups]


def _materialise(arg, work: Path, out: Path) -> str:
    """A file argument written into the work folder (or into OUT for a sweep dataset)."""
    if not isinstance(arg, tuple):
        return arg.replace("OUT", str(out)) if arg.startswith("OUT") else arg
    kind, content = arg
    if kind == "toml":
        path = work / "in.toml"
        path.write_bytes(content)
    elif kind == "csv":
        path = work / "loop.csv"
        path.write_bytes(content)
    elif kind == "json":
        path = work / "model.json"
        path.write_text(content if isinstance(content, str) else json.dumps(content))
    else:
        path = out / "sweep-checkpoint.nc"
        if content == "corrupt":
            path.write_bytes(b"\x89HDF\r\n\x1a\n" + b"\x00" * 64)
        else:
            xr.Dataset({"amplification": ("x", [1.0, 2.0])}).to_netcdf(path, engine="h5netcdf")
        return None
    return str(path)


def _snapshot(folder: Path) -> dict:
    return {p: p.read_bytes() for p in folder.rglob("*") if p.is_file()}


@settings(max_examples=100, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(case=st.sampled_from(CASES))
def test_bad_input_is_one_line_exit_2_and_writes_nothing(capsys, tmp_path, case):
    command, bad = case
    work = Path(tempfile.mkdtemp(dir=tmp_path))
    out = work / "out"
    out.mkdir()
    argv = [command] + [a for a in (_materialise(x, work, out) for x in bad + COMMANDS[command][1])
                        if a is not None]
    before = _snapshot(work)
    try:
        status = main(argv)
    except SystemExit as exc:  # argparse's own one-line usage errors
        status = exc.code
    err = capsys.readouterr().err
    assert_one_line_error(status, err, command)
    assert _snapshot(work) == before, f"{argv} changed files"
    assert not list(tmp_path.parent.glob("escaped*")), "a file was written outside the folders"


@pytest.mark.parametrize("command,bad,fragment", [
    ("export", ["--kerf", "1e308"], "--kerf = 1e+308: must be a number in [0, 5] (mm)"),
    ("solve", ["--target-output", "1e308"], "--target-output = 1e+308"),
    ("draw", ["--dpi", "1e308"], "--dpi = 1e+308"),
    ("sweep", ["--seed", "-1"], "seed = -1: must be an integer"),
    ("sweep", ["--phi1", "6:31:100000000"], "N = 100000000"),
    ("sweep", ["--monte-carlo", "1000000000000", "--hinge-sd", "0.01"], "monte_carlo = 1000000000000"),
    ("sweep", ["--hinge-sd", "inf", "--monte-carlo", "2"], "hinge_sd_mm = inf"),
    ("sweep", ["--phi1="], "--phi1 = ''"),
    ("sweep", ["--scheduler", "foo"], "--scheduler = 'foo'"),
    ("sweep", ["--resume", ("nc", "corrupt")], "sweep-checkpoint.nc is not a readable sweep dataset"),
    ("sweep", ["--resume", ("nc", "no-computed")], "computed"),
    ("export", ["--config", ("toml", b'name = "../escaped"\nphi2_deg = 20\n')], "name = '../escaped'"),
    ("export", ["--config", ("toml", b'name = ""\nphi2_deg = 20\n')], "name = ''"),
    ("check", ["--config", ("toml", b"phi1_deg = 20\n")], "phi2_deg is missing"),
    ("check", ["--config", ("toml", b"[design]\nphi2_deg = 20\nwingspan = 1\n")], "wingspan"),
    ("check", ["--config", ("toml", b"[[design]]\nphi2_deg = 20\n")], "must be a table"),
    ("check", ["--config", ("toml", b"phi2_deg = \xff\n")], "malformed TOML"),
    ("solve", ["--model", ("json", MODELS[-3])], "member 0 start = 4.5: must be an integer node index"),
    ("solve", ["--model", ("json", MODELS[0])], "must be a JSON object"),
])
def test_the_line_names_the_culprit(capsys, tmp_path, command, bad, fragment):
    out = tmp_path / "out"
    out.mkdir()
    argv = [command] + [a for a in (_materialise(x, tmp_path, out) for x in bad + COMMANDS[command][1])
                        if a is not None]
    status = main(argv)
    err = capsys.readouterr().err
    assert_one_line_error(status, err, command)
    assert fragment in err, err


def test_ctrl_c_in_a_command_is_one_line_and_status_130(tmp_path):
    """Ctrl-C in the middle of a render's work: one line, no traceback, 130, and no picture
    (nor temp file) left. The child prints a marker when the work reaches the deformed body
    (after the solve and the CAD parts, before the picture), so the signal lands in the work
    however loaded the machine is, not in an import."""
    import signal
    import subprocess
    import sys

    root = Path(__file__).resolve().parents[2]
    code = ("import sys, pyvista, sensor.mechanics.render as r; work = r.deformed_body\n"
            "def marked(*a, **k):\n    print('working', flush=True)\n    return work(*a, **k)\n"
            "r.deformed_body = marked\n"
            "from sensor.cli import main; sys.exit(main())")
    proc = subprocess.Popen([sys.executable, "-c", code, "render", "--out", str(tmp_path / "r")], cwd=root,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stdout.readline() == "working\n"
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert err.strip() == "dacm render: interrupted (SIGINT)", err
    assert list(tmp_path.iterdir()) == []
