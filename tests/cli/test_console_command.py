"""The `dacm` console command (sensor.cli.run) skips the interpreter's teardown: what a command
printed and wrote must still be complete, and its exit status the command's."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from sensor.design_space.dataset import load_dataset

ROOT = Path(__file__).resolve().parents[2]
DACM = "from sensor.cli import run; run()"


def dacm(*args):
    # stdout block-buffered, as a pipe normally is: output not flushed before the exit would be lost
    env = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}
    return subprocess.run([sys.executable, "-c", DACM, *args], cwd=ROOT, capture_output=True, text=True,
                          timeout=300, env=env)


def test_output_and_files_are_complete_after_the_fast_exit(tmp_path):
    # a 2 x 2 sweep with --json through a pipe: the whole JSON arrives, the dataset is readable
    done = dacm("sweep", "--phi1", "16:26:2", "--phi2", "14:38:2", "--out", str(tmp_path), "--json",
                "--no-plots", "--workers", "2")
    assert done.returncode == 0, done.stderr
    summary = json.loads(done.stdout)
    assert summary["cells"] == summary["computed_now"] == 8
    assert [Path(f["path"]).name for f in summary["files"]][:2] == ["sweep.nc", "sweep.csv"]
    ds = load_dataset(tmp_path / "sweep.nc")
    assert ds["feasible"].shape == (2, 2, 2)
    assert (tmp_path / "sweep.csv").read_text().count("\n") > 8


@pytest.mark.parametrize("args, status", [(("sweep", "--workers", "-1"), 2), (("check", "--preset", "sample-b"), 0)])
def test_exit_status_is_the_command_s(tmp_path, args, status):
    done = dacm(*args)
    assert done.returncode == status, done.stderr
    if status == 2:
        assert done.stderr.count("\n") == 1 and done.stderr.startswith("dacm sweep: error: --workers = -1")
    else:
        assert "design sample-b" in done.stdout
