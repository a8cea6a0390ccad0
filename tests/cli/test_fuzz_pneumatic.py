"""CLI fuzz test for the pneumatic commands ``line`` and ``loop`` (the idea of test_fuzz.py):
absurd numbers, huge sizes and unknown names sampled at random.  Each must give exit status 2,
one line on stderr naming the command and no traceback, and leave no file behind.  Every case is
refused before any integration (the size bounds are checked before allocating), so the whole
test takes seconds."""

from __future__ import annotations

import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sensor.cli import main
from tests.cli.test_fuzz import BAD_INTEGERS, BAD_NUMBERS
from tests.conftest import assert_one_line_error

LINE_GOOD = {"--length": "2", "--bore": "0.004", "--volume": "1e-5", "--pressure": "3e5"}
# amplitude and offset may be negative: only the non-finite and huge values are bad there
BAD_FORCES = [v for v in BAD_NUMBERS if v != "-1"] + ["2e5"]


def _line_cases() -> list[list[str]]:
    cases = [[f, v] for f in LINE_GOOD for v in BAD_NUMBERS + ["0", "2e8"]]
    cases += [["--fmax", v] for v in BAD_NUMBERS + ["2e6"]]
    cases += [["--points", v] for v in BAD_INTEGERS + ["9", "100001"]]
    return cases + [["--model", "pipe"]]


def _loop_cases() -> list[list[str]]:
    cases = [["--line-length", v] for v in BAD_NUMBERS + ["0", "1001"]]
    cases += [[f, v] for f in ("--amplitude", "--offset") for v in BAD_FORCES]
    cases += [["--duration", v] for v in BAD_NUMBERS + ["0", "1e-9", "3601"]]
    cases += [["--segments", v] for v in BAD_INTEGERS + ["0", "1001"]]
    cases += [["--reference", r] for r in ("ramp", "sine:nanHz", "sine:1e308Hz", "sine:-1Hz", "square:xHz",
                                           "sine:1e-300Hz")]
    cases += [[f, v] for f in ("--stiction", "--coulomb") for v in BAD_NUMBERS + ["101"]]
    cases += [["--spool-bandwidth", v] for v in ("0", "-1", "nan")]
    cases += [["--stiction", "0.01", "--coulomb", "0.05"], ["--study", "controllers", "--energy"]]
    cases += [["--controller", "pid"], ["--observer", "kalman"], ["--valve", "foo"], ["--study", "chapter9"],
              ["--sensor", "sample-z"], ["--study", "observer", "--duration", "1e308"],
              ["--study", "controllers", "--segments", "1000000000000"]]
    return cases


CASES = [("line", bad) for bad in _line_cases()] + [("loop", bad) for bad in _loop_cases()]


def _argv(command: str, bad: list[str], out: Path) -> list[str]:
    if command == "line":
        given_ = dict(LINE_GOOD)
        extra = []
        for flag, value in zip(bad[::2], bad[1::2]):
            if flag in given_:
                given_[flag] = value
            else:
                extra += [flag, value]
        return ["line", *[x for kv in given_.items() for x in kv], *extra, "--out", str(out)]
    return ["loop", *bad, "--out", str(out), "--quiet"]


def _files(folder: Path) -> set[Path]:
    return {p for p in folder.rglob("*") if p.is_file()}


@settings(max_examples=80, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(case=st.sampled_from(CASES))
def test_bad_pneumatic_input_is_one_line_exit_2_and_writes_nothing(capsys, tmp_path, case):
    command, bad = case
    work = Path(tempfile.mkdtemp(dir=tmp_path))
    try:
        status = main(_argv(command, bad, work / "out"))
    except SystemExit as exc:      # argparse's own one-line usage errors
        status = exc.code
    assert_one_line_error(status, capsys.readouterr().err, command)
    assert _files(work) == set(), f"{bad} wrote files"


@pytest.mark.parametrize("command,bad,fragment", [
    ("line", ["--points", "1000000000000"], "--points = 1000000000000: must be an integer in [10, 100000]"),
    ("loop", ["--duration", "1e308"], "--duration 1e+308: must be a positive finite number <= 3600 (s)"),
    ("loop", ["--segments", "1000000000000"], "--segments 1000000000000: must be an integer in [1, 1000]"),
    ("loop", ["--amplitude", "1e308"], "--amplitude 1e+308: must be a finite force within +-100000 N"),
    ("loop", ["--reference", "sine:1e308Hz"], "reference frequency = 1e+308 Hz: must be a positive finite "),
    ("loop", ["--duration", "1e-9"], "duration 1e-09 s at 1000 Hz: must cover at least one control period"),
    # duration x rate x states is bounded before the arrays are allocated
    ("loop", ["--reference", "sine:1e-300Hz"], "stores 1.87e+307 values: must be <= 2e+08"),
])
def test_the_line_names_the_flag_and_the_rule(capsys, tmp_path, command, bad, fragment):
    try:
        status = main(_argv(command, bad, tmp_path / "out"))
    except SystemExit as exc:
        status = exc.code
    err = capsys.readouterr().err
    assert_one_line_error(status, err, command)
    assert fragment in err, err
