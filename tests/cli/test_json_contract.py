"""The JSON contract of every command (README, "JSON contract"), checked on each one's
``--json`` answer: one object; ``files``, on every command that writes, lists exactly the
files in its output folder as {path, bytes, sha256} (checked against the files themselves);
one name per quantity with its unit (no former names; every hysteresis a ``_fraction``;
times ``_s``); counts and indices as integers; and what the text prints is in the JSON."""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import re
from pathlib import Path

import numpy as np
import pytest

from sensor.cli.output import RENAMED_KEYS
from sensor.cli.parser import COMMANDS
from tests.readout.test_measured import _synthetic

ROOT = Path(__file__).resolve().parents[2]
MRI = ROOT / "tests" / "data" / "mri" / "siemens_aera_pair"
PAIR = [MRI / f"tra_250_2meas_{k}.IMA" for k in (1, 2)]

#: Each command with --json, quick arguments, and whether it writes files ({out} is its
#: own empty folder). draw computes no numbers and has no --json.
CASES = {
    "check": (["--preset", "sample-b"], False),
    "solve": (["--preset", "sample-b"], False),
    "export": (["--preset", "sample-a", "--dxf", "--beam-model", "--out", "{out}"], True),
    "render": (["--preset", "sample-b", "--window-size", "320x240", "--out", "{out}"], True),
    "verify": (["--preset", "sample-b", "--mesh", "coarse", "--out", "{out}"], True),
    "sweep": (["--hinges", "03-03", "--phi1", "15:33:7", "--phi2", "4:30:7", "--no-plots", "--out", "{out}"], True),
    "design": (["--range", "3", "--workers", "1", "--out", "{out}"], True),
    "sensor": (["--preset", "sample-a-as-cut", "--out", "{out}"], True),
    "measure": (["{loop}", "--preset", "sample-b-as-cut", "--calibrate", "--out", "{out}"], True),
    "report": (["--preset", "sample-b", "--no-verify", "--out", "{out}"], True),
    "snr": ([*map(str, PAIR), "--csv", "{out}/snr.csv", "--figure", "{out}/pair.png"], True),
    "line": (["--length", "2", "--bore", "0.004", "--volume", "4.5e-5", "--pressure", "5e5", "--points", "20",
              "--model", "dead-volume", "--out", "{out}"], True),
    "loop": (["--duration", "2", "--out", "{out}"], True),
    "artefact": (["--preset", "sample-b", "--out", "{out}"], True),
}
#: Commands whose text answer is compared with the JSON here (each runs twice).
TEXT = ("sweep", "solve", "design")
#: Keys that hold counts or indices: integers, never 38.0.
INTEGER_KEYS = {"i", "j", "cells", "computed_now", "feasible_cells", "admissible_cells", "evaluations",
                "increments", "adc_bits", "elements"}


def _keys(value, path=""):
    """Every (dotted path, key, value) of a JSON value."""
    if isinstance(value, dict):
        for k, v in value.items():
            yield f"{path}.{k}", k, v
            yield from _keys(v, f"{path}.{k}")
    elif isinstance(value, list):
        for n, v in enumerate(value):
            yield from _keys(v, f"{path}[{n}]")


@pytest.fixture(scope="module")
def answers(tmp_path_factory):
    """command -> (JSON answer, text answer or None, output folder), each command run when
    a test first asks for it."""
    from sensor.cli import main

    loop = _synthetic(0.0)
    csv = tmp_path_factory.mktemp("loop") / "loop.csv"
    np.savetxt(csv, np.c_[loop.force_N, loop.response], delimiter=",", header="force_N,displacement_mm",
               comments="")

    class Answers(dict):
        def __missing__(self, command):
            argv = CASES[command][0]
            folders = [tmp_path_factory.mktemp(f"{command}-{kind}") for kind in ("json", "text")]
            runs = [None, None]
            for n, (folder, extra) in enumerate(zip(folders, (["--json"], []))):
                if n and command not in TEXT:
                    continue
                words = [a.replace("{out}", str(folder)).replace("{loop}", str(csv)) for a in argv]
                buf = io.StringIO()
                with contextlib.redirect_stdout(buf):
                    assert main([command, *words, "--quiet", *extra]) == 0, command
                runs[n] = buf.getvalue()
            self[command] = (json.loads(runs[0]), runs[1], folders[0])
            return self[command]

    return Answers()


def test_every_command_with_json_is_covered():
    from sensor.cli import build_parser

    sub = next(a for a in build_parser()._actions if a.dest == "command")
    with_json = {c for c in COMMANDS if "--json" in sub.choices[c]._option_string_actions}
    assert with_json == set(CASES)


@pytest.mark.parametrize("command", CASES)
def test_files_are_every_file_written_with_size_and_sha256(answers, command):
    result, _, folder = answers[command]
    writes = CASES[command][1]
    assert isinstance(result, dict)
    if not writes:
        assert "files" not in result
        return
    files = result["files"]
    assert files and all(set(f) == {"path", "bytes", "sha256"} for f in files), files
    for f in files:
        data = Path(f["path"]).read_bytes()
        assert f["bytes"] == len(data) and f["sha256"] == hashlib.sha256(data).hexdigest(), f
    # the set's manifest (sensor.cli.output.staged: the commit point of the set, its own
    # record of these files) is bookkeeping, not a result
    written = {p for p in folder.rglob("*")
               if p.is_file() and not p.name.startswith(".") and not p.name.endswith("-manifest.json")}
    assert {Path(f["path"]) for f in files} == written


@pytest.mark.parametrize("command", CASES)
def test_one_name_per_quantity_with_its_unit(answers, command):
    result = answers[command][0]
    for where, key, value in _keys(result):
        assert key not in RENAMED_KEYS and key not in {"plot", "figure", "file"}, where
        if "hysteresis" in key and isinstance(value, float) and "ratio" not in key:
            # a fraction, or a percentile of one (the tolerance report's _p10, _p50, _p90)
            assert re.search(r"_fraction(_p\d+)?$", key) and 0 <= value < 1, (where, value)
        if key in INTEGER_KEYS:
            assert isinstance(value, int) and not isinstance(value, bool), (where, value)


def test_what_the_sweep_prints_is_in_its_json(answers):
    """The printed H ratio, 1/A and resolution ratio are the JSON's values, rounded."""
    result, text, _ = answers["sweep"]
    printed = [float(x) for x in re.findall(r"H ratio ([\d.]+)", text)]
    answered = [a["hysteresis_ratio"] if a["hysteresis_ratio"] is not None else a["hysteresis_ratio_any_stress"]
                for a in result["equal_range"] if a["cell"]]
    answered = [x for x in answered if x is not None]
    assert printed and printed == [round(x, 3) for x in answered]
    for p, a in zip(re.findall(r"\(1/A = ([\d.]+)\), resolution ratio ([\d.]+)", text),
                    [a for a in result["equal_range"] if a["cell"] and a["hysteresis_ratio"] is not None]):
        assert [float(x) for x in p] == [round(a["inverse_amplification"], 3), round(a["resolution_ratio"], 3)]
    for a in result["equal_range"]:
        if a["cell"]:
            assert isinstance(a["cell"]["i"], int) and "hysteresis_fraction" in a["cell"]


def test_what_solve_and_design_print_is_in_their_json(answers):
    result, text, _ = answers["solve"]
    h = float(re.search(r"predicted hysteresis H\s+([\d.]+)", text).group(1))
    assert h == round(result["hysteresis_fraction"], 4)
    result, text, _ = answers["design"]
    assert f"in {result['wall_s']:.1f} s" in text or "bodies evaluated" in text
    assert f"H = {result['hysteresis_fraction']:.4f}" in text
