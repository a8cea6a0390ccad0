"""The output folder rules of sensor/cli/output.py (issue 27): a folder is never half-written
(interrupted sets, write errors), never shared by two runs (the flock), and a set is what its
manifest says it is.

Faults are made for real where the machine allows: SIGKILL of a child process at every
stage of its write phase (the child flushes each file through ``geometry.atomic.fsync_path``,
which the test wraps to log an event and pause, so the kill lands where the event log says,
whatever the machine's speed), a file-size limit (RLIMIT_FSIZE in the child) and a full
disk (a 1 MiB tmpfs in a private mount namespace, skipped where the kernel refuses one).
"""

from __future__ import annotations

import fcntl
import hashlib
import json
import os
import resource
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.conftest import assert_one_line_error

ROOT = Path(__file__).resolve().parents[2]
#: The outer limit of a wait on an event: only a hang reaches it, not a slow machine.
PATIENCE_S = 600.0
#: Run dacm in a child; with DACM_TEST_EVENTS set, log every fsync there and pause after it.
CHILD = """
import os, sys, time
log = os.environ.get("DACM_TEST_EVENTS")
if log:
    import geometry.atomic as atomic
    flush = atomic.fsync_path
    def logged(path):
        flush(path)
        with open(log, "a") as fh:
            fh.write(f"{path}\\n")
        time.sleep(float(os.environ.get("DACM_TEST_PAUSE", "0.3")))
    atomic.fsync_path = logged
from sensor.cli import main
sys.exit(main())
"""


def _child(*argv, events: Path | None = None, limit_bytes: int | None = None, **kw) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"}
    if events is not None:
        env["DACM_TEST_EVENTS"] = str(events)

    def limit():
        if limit_bytes is not None:
            resource.setrlimit(resource.RLIMIT_FSIZE, (limit_bytes, limit_bytes))

    return subprocess.Popen([sys.executable, "-c", CHILD, *map(str, argv)], cwd=ROOT, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=limit, **kw)


def _wait_for(event, what: str, proc=None):
    deadline = time.monotonic() + PATIENCE_S
    while not (result := event()):
        if proc is not None and proc.poll() is not None:
            raise AssertionError(f"the run ended (status {proc.returncode}) before {what}: "
                                 f"{proc.stderr.read()}")
        assert time.monotonic() < deadline, f"no {what} within {PATIENCE_S:g} s"
        time.sleep(0.02)
    return result


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _state(out: Path) -> dict[str, str]:
    """The files under their final names (name -> SHA-256), after checking the folder holds
    complete sets: every file a manifest lists exists with its size and SHA-256, and every
    file is listed in a manifest (or is one)."""
    files = {p.name: _sha(p) for p in out.iterdir() if p.is_file() and not p.name.startswith(".")}
    listed = {}
    for manifest in out.glob("*-manifest.json"):
        for run in json.loads(manifest.read_text())["runs"]:
            for f in run["files"]:
                assert f["name"] in files, f"{manifest.name} lists {f['name']}, which is missing"
                assert (out / f["name"]).stat().st_size == f["bytes"], f
                assert files[f["name"]] == f["sha256"], f"{f['name']} is not what {manifest.name} says"
                listed[f["name"]] = f["sha256"]
    unlisted = set(files) - set(listed) - {m.name for m in out.glob("*-manifest.json")}
    assert not unlisted, f"files no manifest lists: {unlisted}"
    return listed


EXPORT = ["export", "--preset", "sample-a", "--dxf", "--stl", "--beam-model"]


def test_sigkill_at_any_point_of_the_write_phase_leaves_the_old_or_the_new_set(tmp_path):
    """An export of three files replaces a finished one (--force, another kerf: another DXF)
    and is killed after its k-th flush, across its write phase. What the next run
    finds (after it finishes or removes what the killed run left, as claim does) is the old
    set or the new set, each complete and as its manifest says; never a mixture."""
    from sensor.cli.output import recover

    out = tmp_path / "out"
    first = _child(*EXPORT, "--out", out)
    assert first.wait(timeout=PATIENCE_S) == 0, first.stderr.read()
    old = _state(out)
    shutil.copytree(out, tmp_path / "old")
    new_run = [*EXPORT, "--kerf", "0.3", "--force", "--out", out]
    log = tmp_path / "events"
    log.write_text("")
    probe = _child(*new_run, events=log)   # counts the flushes of a whole run
    assert probe.wait(timeout=PATIENCE_S) == 0, probe.stderr.read()
    n = len(log.read_text().splitlines())
    assert n >= 10  # each file twice (written, then committed), the folders, the manifest
    shutil.rmtree(out)
    shutil.copytree(tmp_path / "old", out)
    seen = set()
    # every other flush, and each of the last three (the commit point and the moves)
    for k in sorted(set(range(1, n + 1, 2)) | {n - 2, n - 1, n}):
        shutil.rmtree(out)
        shutil.copytree(tmp_path / "old", out)
        log.write_text("")
        proc = _child(*new_run, events=log)
        _wait_for(lambda: len(log.read_text().splitlines()) >= k, f"flush {k}", proc)
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=PATIENCE_S)
        recover(out)   # what the next run's claim does first
        state = _state(out)
        assert not [p for p in out.iterdir() if p.name.startswith(".dacm-staging")]
        if state == old:
            seen.add("old")
            continue
        # the new set (a DXF holds its time of writing, so no two runs' bytes are equal):
        # made by the new command line, every file of it as its manifest says
        [run] = json.loads((out / "export-manifest.json").read_text())["runs"]
        assert "--kerf" in run["argv"] and set(state) == set(old), f"killed after flush {k}: {state}"
        assert state["sample-a.dxf"] != old["sample-a.dxf"], f"killed after flush {k}: a mixture"
        seen.add("new")
    assert seen == {"old", "new"}  # kills landed both before and after the commit point


def test_a_second_run_stops_at_once_naming_the_holder_and_force_does_not_break_the_lock(dacm, tmp_path):
    tmp_path.joinpath("sample-a.dxf").write_text("not mine to replace")
    with open(tmp_path / ".dacm.lock", "w") as holder:   # a live run: this process
        fcntl.flock(holder, fcntl.LOCK_EX)
        holder.write(f"{os.getpid()} sweep\n")
        holder.flush()
        status, out, err = dacm("export", "--preset", "sample-a", "--dxf", "--force", "--out", tmp_path)
    assert_one_line_error(status, err, "export")
    assert f"another dacm run is writing there (PID {os.getpid()}, dacm sweep)" in err
    assert out == "" and tmp_path.joinpath("sample-a.dxf").read_text() == "not mine to replace"


def test_a_stale_lock_of_a_killed_run_is_taken_over(dacm, tmp_path):
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    tmp_path.joinpath(".dacm.lock").write_text(f"{dead.pid} export\n")   # nobody holds it
    status, out, err = dacm("export", "--preset", "basis", "--dxf", "--out", tmp_path)
    assert status == 0 and err == "", err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["basis.dxf", "export-manifest.json"]


def test_two_concurrent_sweeps_into_one_folder(tmp_path):
    """The second sweep, started while the first holds the folder, stops at once with one
    line naming the first's PID; the folder ends with the first's set only."""
    first = _child("sweep", "--phi1", "14:26:8", "--phi2", "10:40:8", "--hinges", "05-03",
                   "--workers", "1", "--quiet", "--no-plots", "--out", tmp_path)
    lock = tmp_path / ".dacm.lock"
    _wait_for(lambda: lock.exists() and lock.read_text().strip(), "lock of the first sweep", first)
    second = _child("sweep", "--phi1", "20:22:2", "--phi2", "20:30:2", "--hinges", "03-03",
                    "--workers", "1", "--quiet", "--no-plots", "--out", tmp_path)
    _, err = second.communicate(timeout=PATIENCE_S)
    assert second.returncode == 2, err
    assert err.strip().startswith("dacm sweep: error: --out") and err.count("\n") == 1, err
    assert f"(PID {first.pid}, dacm sweep)" in err
    _, err = first.communicate(timeout=PATIENCE_S)
    assert first.returncode == 0, err
    assert set(_state(tmp_path)) == {"sweep.nc", "sweep.csv", "pareto-05-03.csv"}


def test_a_file_size_limit_is_one_line_naming_the_file_and_leaves_no_file(tmp_path):
    """Under `ulimit -f` the STEP writer of OpenCASCADE reports success on a cut file: the
    check of its end catches it. Python ignores SIGXFSZ, so the limit is EFBIG."""
    out = tmp_path / "out"
    proc = _child("export", "--preset", "sample-b", "--out", out, limit_bytes=100_000)
    _, err = proc.communicate(timeout=PATIENCE_S)
    assert proc.returncode == 2, err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert f"[Errno 27] File too large (EFBIG): cannot write {out / 'sample-b.step'}" in err
    assert not out.exists()   # made by the run, left empty: removed


def test_a_file_size_limit_in_the_sweep_is_one_line(tmp_path):
    proc = _child("sweep", "--phi1", "20:22:2", "--phi2", "20:30:2", "--hinges", "05-03",
                  "--workers", "1", "--quiet", "--out", tmp_path, limit_bytes=60_000)
    _, err = proc.communicate(timeout=PATIENCE_S)
    assert proc.returncode == 2, err
    assert err.count("\n") == 1 and "(EFBIG): cannot write" in err and "h5py" not in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def _tmpfs_available() -> bool:
    if shutil.which("unshare") is None:
        return False
    probe = subprocess.run(["unshare", "-rm", "sh", "-c", "mount -t tmpfs -o size=64k tmpfs /mnt"],
                           capture_output=True)
    return probe.returncode == 0


@pytest.mark.skipif(not _tmpfs_available(), reason="no private mount namespace to mount a small "
                    "tmpfs in (unshare -rm refused); the EFBIG tests cover the same paths")
@pytest.mark.parametrize("argv", [
    ["export", "--preset", "sample-b"],
    ["report", "--preset", "sample-b", "--no-verify"],
    ["sweep", "--phi1", "20:22:2", "--phi2", "20:30:2", "--hinges", "05-03", "--workers", "1", "--quiet"],
])
def test_a_full_disk_is_one_line_without_a_crash_and_leaves_no_file(tmp_path, argv):
    """On a 200 KiB tmpfs: exit 2, one line naming a file and ENOSPC, no segfault (HDF5
    writing to a full disk used to crash the sweep), and nothing left on the disk."""
    mnt = tmp_path / "mnt"
    mnt.mkdir()
    script = (f"mount -t tmpfs -o size=200k tmpfs {mnt} && cd {ROOT} && "
              f"{sys.executable} -c '{CHILD}' \"$@\"; status=$?; ls -A {mnt}; exit $status")
    proc = subprocess.run(["unshare", "-rm", "sh", "-c", script, "sh", *argv, "--out", str(mnt / "out")],
                          capture_output=True, text=True, timeout=PATIENCE_S,
                          env={**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"})
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.count("\n") == 1 and "(ENOSPC): cannot write" in proc.stderr, proc.stderr
    assert proc.stdout == "", f"left on the disk: {proc.stdout}"


def test_unfinished_staging_is_removed_and_a_committed_one_finished(dacm, tmp_path):
    """What a killed run leaves: before its commit point a staging folder with some files
    (removed, with a note); after it, a staging folder with its manifest (moved into place,
    with a note)."""
    from sensor.cli.output import MANIFEST_SCHEMA, file_record

    unfinished = tmp_path / ".dacm-staging-export-1"
    unfinished.mkdir()
    unfinished.joinpath("basis.dxf").write_text("half")
    committed = tmp_path / ".dacm-staging-draw-2"
    committed.mkdir()
    picture = committed / "basis-profile.svg"
    picture.write_text("<svg></svg>")
    run = {"argv": ["dacm", "draw"], "version": "test", "time": "", "files": [file_record(picture)]}
    committed.joinpath("draw-manifest.json").write_text(json.dumps(
        {"schema": MANIFEST_SCHEMA, "command": "draw", "runs": [run], "removed": []}))
    status, out, err = dacm("export", "--preset", "basis", "--dxf", "--out", tmp_path)
    assert status == 0, err
    notes = err.strip().splitlines()
    assert len(notes) == 2 and all(n.startswith("dacm export: note: ") for n in notes), err
    assert any("removed" in n and str(unfinished) in n for n in notes)
    assert any("finished moving" in n for n in notes)
    assert set(_state(tmp_path)) == {"basis.dxf", "basis-profile.svg"}
    assert tmp_path.joinpath("basis.dxf").read_text() != "half"


def test_an_exclusive_set_replaces_the_previous_one_whole(dacm, tmp_path):
    """A sweep with --force and other hinge sets leaves no Pareto table of the old run."""
    base = ["sweep", "--phi1", "20:22:2", "--phi2", "20:30:2", "--quiet", "--no-plots", "--out", tmp_path]
    assert dacm(*base, "--hinges", "03-03")[0] == 0
    assert dacm(*base, "--hinges", "05-03", "--force")[0] == 0
    assert set(_state(tmp_path)) == {"sweep.nc", "sweep.csv", "pareto-05-03.csv"}
    runs = json.loads(tmp_path.joinpath("sweep-manifest.json").read_text())["runs"]
    assert len(runs) == 1 and runs[0]["argv"][:2] == ["dacm", "sweep"] and "--force" in runs[0]["argv"]


def test_ctrl_c_while_the_sweep_writes_its_set_keeps_every_cell_for_resume(tmp_path):
    """Ctrl-C once the sweep writes its files (the first flush in its staging folder): one
    line, status 130, no file of the set under its final name, and every cell in the
    checkpoint, so --resume (no --force needed) computes nothing and writes the whole set."""
    grid = ["sweep", "--phi1", "20:22:2", "--phi2", "20:30:2", "--hinges", "05-03", "--workers", "1",
            "--quiet", "--no-plots", "--out", tmp_path]
    log = tmp_path.parent / "events"
    log.write_text("")
    proc = _child(*grid, events=log)
    _wait_for(lambda: ".dacm-staging" in log.read_text(), "first flush of the set", proc)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=PATIENCE_S)
    assert proc.returncode == 130, err
    assert err.count("\n") == 1 and "interrupted while writing the files" in err and "--resume" in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sweep-checkpoint.nc"]
    resumed = _child(*grid, "--resume", "--json")
    out, err = resumed.communicate(timeout=PATIENCE_S)
    assert resumed.returncode == 0, err
    assert json.loads(out)["computed_now"] == 0
    assert set(_state(tmp_path)) == {"sweep.nc", "sweep.csv", "pareto-05-03.csv"}
