"""Output folders that are never half-written, never shared by two runs, and never trusted
when their contents are wrong (the machinery behind ``sensor.cli.output``'s rule).

- **One run per folder.** An exclusive ``flock`` on ``OUT/.dacm.lock`` for the rest of the
  command; a second run into the folder stops at once with one line naming the holder's PID.
  The kernel drops the lock of a killed process, so a stale one is simply taken over.
- **Whole sets.** Files are written into a staging folder ``OUT/.dacm-staging-*``
  (:func:`staged`); when the block ends without error each file is checked complete
  (:func:`geometry.atomic.check_complete`) and flushed, the manifest is written (the commit
  point), and the files move into place, the manifest last. The next run removes a staging
  folder stopped before the commit point and finishes one stopped after it.
- **A manifest.** ``OUT/<command>-manifest.json`` lists each run's files (name, bytes,
  SHA-256), command line, version and time; a file about to be written that no manifest
  lists is what an interrupted run left, and is removed with a one-line note.
"""

from __future__ import annotations

import argparse
import contextlib
import datetime
import fcntl
import hashlib
import json
import os
import shutil
import sys
import time
import warnings
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

from sensor.errors import ResourceNote, UsageError

LOCK_NAME = ".dacm.lock"
STAGING_PREFIX = ".dacm-staging-"
MANIFEST_SCHEMA = "dacm-manifest/1"


def make_out_dir(out: Path) -> Path:
    """Create ``out`` (and its parents); an ``OSError`` naming it if that fails."""
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OSError(f"cannot create output folder {out}: {exc.strerror}") from None
    return out


# --- one run per folder -------------------------------------------------------------------

@dataclass
class _Run:
    """This process's hold on an output folder, from :func:`claim` to the command's end."""

    out: Path
    command: str
    lock_fd: int
    created: list[Path]                # the folders this run made, innermost first
    started: float = field(default_factory=time.time)
    exclusive: bool = False
    staging: Path | None = None
    committed: bool = False


#: The folders this process holds, by resolved path (released by :func:`session`).
_RUNS: dict[Path, _Run] = {}
#: The command line of the running command, for the manifest (set by :func:`session`).
_ARGV: list[str] = []


def _note(text: str) -> None:
    warnings.warn(text, ResourceNote, stacklevel=3)


def _lock(out: Path, command: str) -> _Run:
    """Hold ``OUT/.dacm.lock`` (``flock``, exclusive, not waiting) for this process; finish or
    remove what interrupted runs left in the folder (:func:`recover`)."""
    key = out.resolve()
    if key in _RUNS:
        return _RUNS[key]
    created = [p for p in (out, *out.parents) if not p.exists()]
    make_out_dir(out)
    path = out / LOCK_NAME
    while True:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = _holder(fd)
            os.close(fd)
            raise UsageError(f"--out {out}: another dacm run is writing there ({holder}); "
                             "wait for it to finish, or use another --out") from None
        try:  # the holder before may have removed the file it locked: lock the one in place
            same = os.fstat(fd).st_ino == os.stat(path).st_ino
        except FileNotFoundError:
            same = False
        if same:
            break
        os.close(fd)
    os.ftruncate(fd, 0)
    os.write(fd, f"{os.getpid()} {command}\n".encode())
    run = _RUNS[key] = _Run(out, command, fd, created)
    recover(out)
    return run


def _holder(fd: int) -> str:
    """'PID 123, dacm sweep' from a held lock file (its holder writes it just after locking)."""
    for _ in range(20):
        text = os.pread(fd, 200, 0).decode(errors="replace").split()
        if text:
            return f"PID {text[0]}" + (f", dacm {text[1]}" if len(text) > 1 else "")
        time.sleep(0.05)
    return "PID unknown"


def _release(run: _Run, ok: bool) -> None:
    """End this run's hold: drop an unfinished staging folder, list files written in place
    (commands that do not stage) in the manifest when the command succeeded, unlock, and
    remove the folders this run made and left empty."""
    try:
        if run.staging is not None:
            shutil.rmtree(run.staging, ignore_errors=True)
        if ok and not run.committed:
            _commit_in_place(run)
    finally:
        with contextlib.suppress(OSError):
            os.unlink(run.out / LOCK_NAME)
        os.close(run.lock_fd)
        for folder in run.created:  # those left empty
            try:
                folder.rmdir()
            except OSError:
                break


@contextlib.contextmanager
def session(argv: list[str] | None = None):
    """Around one command: the folders it claims are released when it ends, however it ends
    (a killed process's locks are dropped by the kernel)."""
    _ARGV[:] = ["dacm", *(sys.argv[1:] if argv is None else argv)]
    ok = False
    try:
        yield
        ok = True
    finally:
        runs = list(_RUNS.values())
        _RUNS.clear()
        for run in runs:
            _release(run, ok)


# --- whole sets ---------------------------------------------------------------------------

def manifest_path(out: Path, command: str) -> Path:
    return out / f"{command}-manifest.json"


def read_manifest(path: Path) -> dict | None:
    """A manifest's content, or None if it is missing or not a dacm manifest."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(data, dict) or data.get("schema") != MANIFEST_SCHEMA:
        return None
    return data


def listed_files(out: Path) -> set[str]:
    """The names of the files every manifest in ``out`` lists."""
    names = set()
    for path in out.glob("*-manifest.json"):
        data = read_manifest(path) or {}
        for run in data.get("runs", []):
            names.update(f.get("name") for f in run.get("files", []) if isinstance(f, dict))
    return names


def remove_unlisted(paths: Iterable[Path]) -> list[Path]:
    """Remove those of ``paths`` that exist but no manifest lists (what an interrupted run
    left under its final names), with one note; return them."""
    paths = [p for p in paths if p.is_file()]
    if not paths:
        return []
    listed = listed_files(paths[0].parent)
    gone = [p for p in paths if p.name not in listed]
    for p in gone:
        p.unlink()
    if gone:
        _note(f"removed {', '.join(str(p) for p in gone)}: left by an interrupted run "
              "(no manifest lists them)")
    return gone


def file_record(path: Path) -> dict:
    """``{"name", "bytes", "sha256"}`` of a file."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return {"name": path.name, "bytes": path.stat().st_size, "sha256": h.hexdigest()}


@contextlib.contextmanager
def staged(args: argparse.Namespace, remove: Iterable[str] = ()):
    """Yield the staging folder of this run's set in ``--out`` (claimed before); when the
    block ends without error, commit: check and flush every file written in it, write the
    manifest, move the files into place and then the manifest, and remove the files named
    in ``remove`` (e.g. a checkpoint the set supersedes). On an error the staging folder is
    removed and nothing new is left under a final name; an ``OSError`` names the final file."""
    run = _RUNS[args.out.resolve()]
    run.staging = args.out / f"{STAGING_PREFIX}{run.command}-{os.getpid()}"
    shutil.rmtree(run.staging, ignore_errors=True)
    run.staging.mkdir()
    try:
        yield run.staging
        _commit(run, list(remove))
    except OSError as exc:
        shutil.rmtree(run.staging, ignore_errors=True)
        raise _renamed(exc, run.staging, run.out) from None
    except BaseException:
        shutil.rmtree(run.staging, ignore_errors=True)
        raise


def _renamed(exc: OSError, staging: Path, out: Path) -> OSError:
    """The error with the staging folder's paths told as the final ones."""
    new = OSError(str(exc).replace(str(staging), str(out)))
    new.errno = exc.errno
    return new


def _commit(run: _Run, remove: list[str]) -> None:
    from geometry.atomic import check_complete, fsync_path

    files = sorted(p for p in run.staging.iterdir() if p.is_file() and not p.name.startswith("."))
    for p in files:
        check_complete(p, run.out / p.name)
        fsync_path(p)
    manifest = _manifest(run, [file_record(p) for p in files], remove)
    _write_json(run.staging / manifest_path(run.out, run.command).name, manifest)  # committed
    _finish(run.staging, run.out)
    run.committed = True


def _commit_in_place(run: _Run) -> None:
    """The manifest of a command that wrote its files in place: those it wrote since it
    claimed the folder."""
    from geometry.atomic import fsync_path

    files = sorted(p for p in run.out.iterdir() if p.is_file() and not p.name.startswith(".")
                   and not p.name.endswith("-manifest.json") and p.stat().st_mtime >= run.started - 0.05)
    if not files:
        return
    for p in files:
        fsync_path(p)
    from geometry.atomic import write_bytes

    write_bytes(manifest_path(run.out, run.command),
                _json_bytes(_manifest(run, [file_record(p) for p in files], [])))
    run.committed = True


def _manifest(run: _Run, records: list[dict], remove: list[str]) -> dict:
    """This run's manifest: its own files, after the earlier runs' files it does not replace
    (none of them for an exclusive command, whose earlier files are to be removed)."""
    from importlib.metadata import version

    old = read_manifest(manifest_path(run.out, run.command)) or {}
    new_names = {r["name"] for r in records}
    runs, removed = [], [n for n in remove if n not in new_names]
    for earlier in old.get("runs", []):
        kept = [f for f in earlier.get("files", []) if isinstance(f, dict)
                and f.get("name") not in new_names and (run.out / str(f.get("name"))).is_file()]
        if run.exclusive:
            removed += [f["name"] for f in kept]
        elif kept:
            runs.append({**earlier, "files": kept})
    runs.append({"argv": list(_ARGV), "version": version("dacm"), "pid": os.getpid(),
                 "time": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
                 "files": records})
    return {"schema": MANIFEST_SCHEMA, "command": run.command, "runs": runs, "removed": removed}


def _json_bytes(data: dict) -> bytes:
    return (json.dumps(data, indent=1) + "\n").encode()


def _write_json(path: Path, data: dict) -> None:
    from geometry.atomic import write_bytes

    write_bytes(path, _json_bytes(data))


def _finish(staging: Path, out: Path) -> None:
    """Move a committed staging folder's files into ``out`` (the manifest last), remove the
    files its manifest says the set replaced, and remove the staging folder. Run again on
    the same folder after a crash, it completes the move."""
    from geometry.atomic import fsync_path

    [manifest] = [p for p in staging.iterdir() if p.name.endswith("-manifest.json")]
    data = read_manifest(manifest) or {}
    for name in data.get("removed", []):
        with contextlib.suppress(FileNotFoundError, IsADirectoryError):
            (out / Path(name).name).unlink()
    for p in sorted(staging.iterdir()):
        if p != manifest and p.is_file() and not p.name.startswith("."):
            os.replace(p, out / p.name)
    os.replace(manifest, out / manifest.name)
    fsync_path(out)
    shutil.rmtree(staging, ignore_errors=True)


def recover(out: Path) -> None:
    """What interrupted runs left in ``out`` (this process holds its lock, so none of them
    runs): a committed staging folder is moved into place, any other one is removed; one
    note each."""
    for staging in sorted(out.glob(f"{STAGING_PREFIX}*")):
        if not staging.is_dir():
            continue
        committed = any(p.name.endswith("-manifest.json") for p in staging.iterdir())
        if committed:
            _finish(staging, out)
            _note(f"finished moving the files of an interrupted run into {out} ({staging.name})")
        else:
            shutil.rmtree(staging, ignore_errors=True)
            _note(f"removed {staging}: the unfinished files of an interrupted run")
