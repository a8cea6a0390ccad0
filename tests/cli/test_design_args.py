"""File flags (sensor/cli/design_args.py ``input_file``): a missing file, a folder or an
unreadable file given to ``--config`` (every command that reads a design, and the sweep's
settings) is one line naming the flag and the path; the same for the output file flags of
``dacm snr``."""

from __future__ import annotations

import os

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tests.conftest import assert_one_line_error

#: Every command that takes --config, with what else it needs.
CONFIG_COMMANDS = {"export": [], "check": [], "draw": [], "solve": [], "render": [], "verify": [],
                   "sensor": [], "report": [], "sweep": [], "measure": ["loop.csv"]}


@settings(max_examples=40, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(command=st.sampled_from(sorted(CONFIG_COMMANDS)), kind=st.sampled_from(["missing", "folder"]),
       name=st.text(st.characters(whitelist_categories=("L", "N"), whitelist_characters="-_ ."),
                    min_size=1, max_size=12).filter(lambda n: n not in (".", "..")))
def test_a_config_that_is_no_file_is_one_line_naming_the_flag(tmp_path_factory, dacm, command, kind, name):
    work = tmp_path_factory.mktemp("config")
    path = work / name
    if kind == "folder":
        path.mkdir()
    out_flag = [] if command in ("check", "solve") else ["--out", work / "out"]
    status, out, err = dacm(command, *CONFIG_COMMANDS[command], "--config", path, *out_flag)
    assert_one_line_error(status, err, command)
    why = "no such file" if kind == "missing" else "is a folder"
    assert f"--config {path}: {why}" in err, err
    assert out == "" and not (work / "out").exists()


@pytest.mark.skipif(os.geteuid() == 0, reason="root reads every file whatever its mode")
def test_an_unreadable_config_is_one_line(tmp_path, dacm):
    path = tmp_path / "design.toml"
    path.write_text('phi1_deg = 20\nphi2_deg = 20\n')
    path.chmod(0)
    status, _, err = dacm("check", "--config", path)
    assert_one_line_error(status, err, "check")
    assert f"--config {path}: cannot be read" in err


@pytest.mark.parametrize("flag", ["--csv", "--figure", "--report"])
def test_an_snr_output_flag_naming_a_folder_is_one_line_and_no_force_hint(tmp_path, dacm, flag):
    status, _, err = dacm("snr", "a.png", "b.png", flag, tmp_path)
    assert_one_line_error(status, err, "snr")
    assert "--force" not in err
    assert f"{flag} {tmp_path}" in err, err
