"""Faults during a sweep: a Dask cluster that loses every worker or its scheduler (real
processes, killed by PID), a sweep process killed while its pool runs, SIGTERM/Ctrl-C, and
temp files left by a killed write. Each ends in order and ``resume`` finishes the sweep
with exactly the dataset of an uninterrupted run.

The tests wait on events (worker processes existing, the checkpoint file appearing, the
scheduler holding tasks), never on the machine's speed; the outer limits (minutes) only
stop a test that would otherwise hang."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from sensor.design_space.dataset import load_dataset
from sensor.design_space.execution import run_sweep
from sensor.design_space.spec import Grid, SweepSpec
from sensor.errors import ClusterLostError
from tests.conftest import assert_one_line_error
from tests.design_space.test_sweep import _same

#: 6 rows of 6 cells: enough rows that a fault lands mid-sweep, a second or two of work.
SPEC = SweepSpec(hinge_sets=("05-03",), phi1=Grid(14, 26, 6), phi2=Grid(10, 40, 6))
#: The outer limit of a wait on an event: only a hang reaches it, not a slow machine.
PATIENCE_S = 600.0
DASK = Path(sys.executable).with_name("dask")
ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def serial():
    return run_sweep(SPEC, "test", workers=1)[0]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _spawn(*argv) -> subprocess.Popen:
    return subprocess.Popen([str(DASK), *argv], cwd=ROOT, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, env={**os.environ, "PYTHONPATH": str(ROOT)})


@pytest.fixture
def cluster():
    """A real scheduler and two worker processes (no nanny, so a killed worker stays dead)."""
    pytest.importorskip("distributed")
    from distributed import Client

    address = f"tcp://127.0.0.1:{_free_port()}"
    procs = [_spawn("scheduler", "--host", "127.0.0.1", "--port", address.rsplit(":", 1)[1],
                    "--no-dashboard")]
    procs += [_spawn("worker", address, "--no-nanny", "--nthreads", "1", "--no-dashboard")
              for _ in range(2)]
    with Client(address, timeout=20) as c:
        c.wait_for_workers(2, timeout=30)
    yield address, procs
    for p in procs:
        p.kill()
        p.wait()


class _KillAfter:
    """A progress reporter that kills processes once some rows are in."""

    def __init__(self, rows, procs):
        self.rows, self.procs, self.killed_at = rows, procs, None

    def start(self, total):
        pass

    def advance(self, n):
        self.rows -= 1
        if self.rows == 0:
            for p in self.procs:
                os.kill(p.pid, signal.SIGKILL)
            self.killed_at = time.monotonic()

    def stop(self):
        pass


@pytest.mark.parametrize("victim", ["workers", "scheduler"])
def test_lost_cluster_ends_with_a_checkpoint_that_resume_completes(cluster, tmp_path, serial, victim):
    address, procs = cluster
    killed = procs[1:] if victim == "workers" else procs[:1]
    path = tmp_path / "sweep.nc"
    killer = _KillAfter(2, killed)
    with pytest.raises(ClusterLostError) as exc:
        run_sweep(SPEC, "test", path, scheduler=address, progress=killer,
                  checkpoint_s=1e9, cluster_timeout_s=2.0)
    # from the kill: 2 s without a cluster plus the client's own detection, well inside the
    # 20 s promised (the rows solved before the kill take what the machine's load makes them)
    assert time.monotonic() - killer.killed_at < 20
    msg = str(exc.value)
    assert "\n" not in msg and "--resume" in msg and str(path) in msg, msg
    partial = load_dataset(path)
    done = int(partial["computed"].values.sum())
    assert 0 < done < 36
    ds, n = run_sweep(SPEC, "test", path, resume=True, workers=1)
    assert n == 36 - done
    _same(serial, ds)


def _children(pid: int) -> list[int]:
    out = subprocess.run(["ps", "-o", "pid=", "--ppid", str(pid)], capture_output=True, text=True, check=False)
    return [int(x) for x in out.stdout.split()]


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    # a zombie (dead, not yet reaped) counts as gone
    with open(f"/proc/{pid}/stat") as fh:
        return fh.read().split(")")[-1].split()[0] != "Z"


def _start_sweep(tmp_path) -> subprocess.Popen:
    """`dacm sweep` in a child process with 2 workers on a grid that takes long (80 000
    cells, about a minute on 2 quiet cores: still running when the tests stop it, once its
    workers exist or its first checkpoint is written)."""
    code = "import sys; from sensor.cli import main; sys.exit(main())"
    return subprocess.Popen([sys.executable, "-c", code, "sweep", "--phi1", "8:30:200", "--phi2",
                             "6:50:200", "--workers", "2", "--out", str(tmp_path), "--quiet",
                             "--no-plots"], cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def _wait_for(event, what: str, proc=None, timeout_s: float = PATIENCE_S):
    """Return ``event()`` once it is true; fail naming ``what`` if ``proc`` ends first or
    ``timeout_s`` passes."""
    deadline = time.monotonic() + timeout_s
    while not (result := event()):
        if proc is not None and proc.poll() is not None:
            raise AssertionError(f"the process ended (status {proc.returncode}) before {what}: "
                                 f"{proc.stderr.read() if proc.stderr else ''}")
        assert time.monotonic() < deadline, f"no {what} within {timeout_s:g} s"
        time.sleep(0.05)
    return result


def _workers_of(proc) -> list[int]:
    return _wait_for(lambda: kids if len(kids := _children(proc.pid)) >= 2 else None,
                     "worker processes of the sweep", proc)


def test_sigkill_of_the_sweep_takes_its_workers_along(tmp_path):
    proc = _start_sweep(tmp_path)
    kids = _workers_of(proc)
    proc.kill()
    proc.wait()
    deadline = time.monotonic() + 5
    while any(_alive(k) for k in kids) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not any(_alive(k) for k in kids), "worker processes outlived the killed sweep"


@pytest.mark.parametrize("sig,status", [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
def test_signal_saves_the_checkpoint_and_prints_one_line(tmp_path, sig, status):
    proc = _start_sweep(tmp_path)
    kids = _workers_of(proc)
    checkpoint = tmp_path / "sweep-checkpoint.nc"
    _wait_for(checkpoint.exists, "first checkpoint", proc)  # rows are done: the stop lands mid-sweep
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=PATIENCE_S)
    assert proc.returncode == status, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    assert "interrupted after" in lines[0] and "finish with --resume" in lines[0], lines
    done = int(lines[0].split("after ")[1].split()[0])
    assert int(load_dataset(checkpoint)["computed"].values.sum()) == done
    assert not any(_alive(k) for k in kids)
    assert sorted(p.name for p in tmp_path.iterdir()) == [checkpoint.name]  # no lock, no staging


def test_temp_file_of_a_killed_write_is_removed_by_the_next_run(tmp_path):
    from sensor.design_space.dataset import save_dataset

    # the temp file a writer killed mid-write leaves: its PID is gone
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    stale = tmp_path / f".sweep.nc.tmp{dead.pid}-k1ll3d.nc"
    stale.write_bytes(b"\x89HDF half")
    ds, _ = run_sweep(SweepSpec(hinge_sets=("05-03",), phi1=Grid(20, 22, 2), phi2=Grid(20, 30, 2)),
                      "test", tmp_path / "sweep.nc", workers=1)
    assert not stale.exists()
    save_dataset(ds, tmp_path / "sweep.nc")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sweep.nc"]
    assert np.isfinite(load_dataset(tmp_path / "sweep.nc")["amplification"].values).any()


def _wait_for_tasks(address: str, proc) -> None:
    """Return once the scheduler holds tasks: the sweep has connected and submitted rows."""
    from distributed import Client

    with Client(address, timeout=60) as c:
        _wait_for(lambda: c.run_on_scheduler(lambda dask_scheduler: len(dask_scheduler.tasks)),
                  "task submitted to the scheduler", proc)


def test_lost_scheduler_from_the_command_line_is_one_line(cluster, tmp_path):
    """The command line adds distributed's own logging to the picture: still one line."""
    address, procs = cluster
    code = "import sys; from sensor.cli import main; sys.exit(main())"
    proc = subprocess.Popen([sys.executable, "-c", code, "sweep", "--phi1", "8:30:80", "--phi2", "6:50:40",
                             "--scheduler", address, "--out", str(tmp_path), "--quiet", "--no-plots"],
                            cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    _wait_for_tasks(address, proc)
    os.kill(procs[0].pid, signal.SIGKILL)
    _, err = proc.communicate(timeout=PATIENCE_S)
    assert proc.returncode == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "lost the scheduler" in lines[0], err
    assert "--resume" in lines[0] or "nothing to save" in lines[0], err


def test_workers_beyond_the_cores_are_capped_with_a_one_line_note(tmp_path, capsys):
    from sensor.cli import main
    from sensor.design_space.execution import local_workers
    from sensor.errors import ResourceNote

    cores = len(os.sched_getaffinity(0))
    with pytest.warns(ResourceNote, match=f"workers = 4096: more than the {cores} cores"):
        assert local_workers(4096) == cores
    assert main(["sweep", "--phi1", "20:22:2", "--phi2", "20:30:2", "--hinges", "05-03", "--workers", "64",
                 "--out", str(tmp_path), "--quiet", "--no-plots"]) == 0
    err = capsys.readouterr().err.strip()
    assert err == f"dacm sweep: note: workers = 64: more than the {cores} cores of this machine; using {cores}"


def _checkpoint_of_two_rows(tmp_path) -> Path:
    """A checkpoint with two of SMALL's rows done (saved after every row)."""
    from sensor.design_space.dataset import save_dataset

    small = SweepSpec(hinge_sets=("05-03",), phi1=Grid(18, 22, 3), phi2=Grid(15, 30, 3))
    ds, _ = run_sweep(small, "test", workers=1)
    ds["computed"].values[:, 2] = False
    ds["feasible"].values[:, 2] = False
    path = tmp_path / "sweep-checkpoint.nc"
    save_dataset(ds, path)
    return path


def _rewrite(path: Path, change, keep_checksums: bool) -> None:
    """Change a saved dataset's values as a tool other than dacm would (flags intact), with
    the stored row checksums kept as they were or recomputed to match the new values."""
    import json as _json

    import xarray as xr

    from sensor.design_space.dataset import row_checksums

    ds = load_dataset(path)
    change(ds)
    if not keep_checksums:
        ds.attrs["row_sha256"] = _json.dumps(row_checksums(ds))
    for k in ("reason", "basis_reason"):
        ds[k] = ds[k].astype(str)
    for k in ("computed", "feasible"):
        ds[k] = ds[k].astype("i1")
    data = ds.to_netcdf(engine="h5netcdf")
    path.write_bytes(bytes(data))
    xr.open_dataset(path, engine="h5netcdf").close()   # still a valid NetCDF


def _all_nan(ds):
    for v in ds.data_vars:
        if ds[v].dtype.kind == "f":
            ds[v].values[:] = np.nan


def _amplification_x100(ds):
    ds["amplification"].values[:] *= 100
    ds["ratio_amplification"].values[:] *= 100


@pytest.mark.parametrize("change, keep, fragment", [
    (_all_nan, True, "do not match the checksum"),
    (_all_nan, False, "= nan in a cell flagged computed and feasible"),
    (_amplification_x100, True, "do not match the checksum"),
    (_amplification_x100, False, "(1.5 x the rigid-link value)"),
])
def test_a_corrupt_checkpoint_is_refused_with_one_line(tmp_path, dacm, change, keep, fragment):
    """Every float set to NaN, or the amplification (and its ratio) times 100, in a valid
    NetCDF whose flags say the cells were solved: refused by --resume, whether the row
    checksums were left (they no longer match) or recomputed (the values contradict their
    flags, or the rigid-link bound on A); nothing is written."""
    path = _checkpoint_of_two_rows(tmp_path)
    _rewrite(path, change, keep)
    before = path.read_bytes()
    status, out, err = dacm("sweep", "--phi1", "18:22:3", "--phi2", "15:30:3", "--hinges", "05-03",
                            "--workers", "1", "--quiet", "--no-plots", "--resume", "--out", tmp_path)
    assert_one_line_error(status, err, "sweep")
    assert f"--resume: {path}" in err and fragment in err, err
    assert out == "" and path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == [path.name]


def test_a_good_checkpoint_resumes_to_the_uninterrupted_dataset(tmp_path, dacm):
    path = _checkpoint_of_two_rows(tmp_path)
    status, _, err = dacm("sweep", "--phi1", "18:22:3", "--phi2", "15:30:3", "--hinges", "05-03",
                          "--workers", "1", "--quiet", "--no-plots", "--resume", "--out", tmp_path)
    assert status == 0, err
    assert not path.exists()   # the finished set replaced it
    whole, _ = run_sweep(SweepSpec(hinge_sets=("05-03",), phi1=Grid(18, 22, 3), phi2=Grid(15, 30, 3)),
                         "test", workers=1)
    _same(whole, load_dataset(tmp_path / "sweep.nc"))


def _server(reply: bytes | None):
    """A TCP port that accepts and answers ``reply`` (None: never answers); its address."""
    import threading

    listener = socket.socket()
    listener.bind(("127.0.0.1", 0))
    listener.listen(8)
    held = []

    def serve():
        while True:
            try:
                conn, _ = listener.accept()
            except OSError:
                return
            held.append(conn)
            if reply is not None:
                conn.sendall(reply)

    threading.Thread(target=serve, daemon=True).start()
    return f"tcp://127.0.0.1:{listener.getsockname()[1]}", listener


@pytest.mark.parametrize("reply, fragment", [
    (b"SSH-2.0-OpenSSH_9.6\r\n" * 4, "not a Dask scheduler"),
    (b"HTTP/1.1 400 Bad Request\r\n\r\n", "not a Dask scheduler"),
    (None, "no Dask handshake within"),
])
@pytest.mark.parametrize("command", [
    ["sweep", "--phi1", "20:22:2", "--phi2", "20:30:2", "--hinges", "05-03", "--quiet", "--no-plots"],
    ["design", "--range", "5", "--quiet"],
])
def test_a_port_that_is_no_dask_scheduler_ends_within_10_s_with_one_line(tmp_path, dacm, reply,
                                                                          fragment, command):
    pytest.importorskip("distributed")
    address, listener = _server(reply)
    try:
        t0 = time.monotonic()
        status, out, err = dacm(*command, "--scheduler", address, "--out", tmp_path)
        elapsed = time.monotonic() - t0
    finally:
        listener.close()
    assert_one_line_error(status, err, command[0])
    assert f"--scheduler = {address!r}" in err and fragment in err, err
    assert elapsed < 10, f"{elapsed:.1f} s"   # the probe gives up after 4 s
    assert list(tmp_path.iterdir()) == []


def test_a_signal_during_a_held_block_is_raised_when_it_ends():
    """A row is merged and counted under _signals_held: a Ctrl-C that arrives in the middle
    interrupts after the block, not inside it (under load a stop between merge and count
    made the message say 1600 cells while the checkpoint held 1800). In a fresh Python
    process given Python's own SIGINT handler (pytest's workers ignore SIGINT, and a child
    started from one inherits that: the signal then did nothing, in two full runs of stop 56)."""
    script = """
import signal
from sensor.design_space.execution import _signals_held
signal.signal(signal.SIGINT, signal.default_int_handler)
steps = []
try:
    with _signals_held():
        signal.raise_signal(signal.SIGINT)
        steps.append("inside, after the signal")
except KeyboardInterrupt:
    assert steps == ["inside, after the signal"], steps
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    print("raised after the block")
"""
    root = Path(__file__).resolve().parents[2]
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd=root, timeout=120)
    assert run.returncode == 0 and run.stdout.strip() == "raised after the block", run.stderr
