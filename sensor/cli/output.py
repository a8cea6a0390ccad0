"""The one output rule of every ``dacm`` command that writes files.

``--out DIR`` (default ``./dacm-out/``) holds every file of a command, named after the design
(or the study); a file that exists is replaced only with ``--force``. Otherwise the command
stops with one line naming the file, before it computes anything, whenever the names are
known up front (:func:`claim`).

An output folder is never half-written, never shared by two runs, and never trusted when its
contents are wrong:

- **One run per folder.** :func:`claim` takes an exclusive ``flock`` on ``OUT/.dacm.lock``
  for the rest of the command; a second run into the folder stops at once with one line
  naming the holder's PID. ``--force`` never breaks a live lock; the kernel drops the lock
  of a killed process, so a stale one is simply taken over.
- **Whole sets.** A command writes its files into a staging folder ``OUT/.dacm-staging-*``
  (:func:`staged`); when the block ends without error each file is checked complete
  (:func:`geometry.atomic.check_complete`) and flushed to the disk, the manifest is written
  in the staging folder (the commit point), and the files move into place, the manifest
  last. A run stopped before the commit point leaves only a staging folder, which the next
  run into the folder removes with a note; one stopped after it is finished by the next run.
- **A manifest.** ``OUT/<command>-manifest.json`` lists the files of each run of the
  command (name, bytes, SHA-256), its command line, the software version and the time.
  A file that a command is about to write and that exists without being listed in any
  manifest is what an interrupted run (or a version before manifests) left: it is removed
  with a one-line note, no ``--force`` needed. A listed file is a finished result and is
  replaced only with ``--force``.
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

DEFAULT_OUT_DIR = Path("dacm-out")
LOCK_NAME = ".dacm.lock"
STAGING_PREFIX = ".dacm-staging-"
MANIFEST_SCHEMA = "dacm-manifest/1"

#: Suffixes that make ``--out`` look like a file name rather than a folder.
FILE_SUFFIXES = (".png", ".svg", ".pdf", ".jpg", ".html", ".csv", ".nc", ".json", ".toml",
                 ".dxf", ".stl", ".step", ".md")


def add_output_arguments(parser: argparse.ArgumentParser, what: str) -> None:
    """Add ``--out DIR`` and ``--force`` to a command; ``what`` names the files it writes."""
    g = parser.add_argument_group("output")
    g.add_argument("--out", type=Path, default=DEFAULT_OUT_DIR, metavar="DIR",
                   help=f"folder for {what} (default ./dacm-out/; created if missing)")
    g.add_argument("--force", action="store_true",
                   help="replace files that exist (without it the command stops first)")


def check_out_dir(out: Path) -> None:
    """Raise :class:`UsageError` when ``--out`` is an existing file or looks like a file name."""
    if out.exists() and not out.is_dir():
        raise UsageError(f"--out = {str(out)!r}: is a file; --out is the folder the files "
                         "are written to (they are named after the design)")
    if not out.exists() and out.suffix.lower() in FILE_SUFFIXES:
        fmt = " --format svg" if out.suffix.lower() == ".svg" else ""
        raise UsageError(f"--out = {str(out)!r}: --out is a folder now (the files are named "
                         f"after the design): use --out {out.parent}{fmt}, or another folder")


def refuse_existing(paths: Iterable[Path], force: bool, elsewhere: str = "another --out") -> None:
    """Raise :class:`UsageError` naming the first of ``paths`` that exists, unless ``force``."""
    if force:
        return
    paths = list(paths)
    existing = [p for p in paths if Path(p).exists()]
    if existing:
        more = f" ({len(existing)} of the {len(paths)} files to write do)" if len(existing) > 1 else ""
        raise UsageError(f"{existing[0]} exists{more}: use --force to replace, or {elsewhere}")


def claim_files(paths_by_flag: dict[str, str | None], force: bool) -> None:
    """The rule for a command whose flags name their files (``dacm snr --csv PATH``): each
    given path's folder exists and the file does not, unless ``force``; checked before any
    work, one line naming the flag otherwise."""
    for flag, path in paths_by_flag.items():
        if path and not Path(path).parent.is_dir():
            raise UsageError(f"{flag} {path}: the folder {Path(path).parent} does not exist")
        if path and Path(path).is_dir():
            raise UsageError(f"{flag} {path}: is a folder; give the name of the file to write")
    refuse_existing([Path(p) for p in paths_by_flag.values() if p], force, elsewhere="another path")


def claim(args: argparse.Namespace, names: Iterable[str], exclusive: bool = False) -> list[Path]:
    """The paths ``args.out / name`` of the files a command will write, checked by the rule:
    ``--out`` is a folder, no other run holds it (this run locks it until the command ends),
    and none of the files exists as a finished result unless ``--force`` (files no manifest
    lists are removed with a note). With ``exclusive`` the folder holds one set of this
    command (a study): a new set replaces every file of the previous one."""
    check_out_dir(args.out)
    run = _lock(args.out, getattr(args, "command", None) or "dacm")
    run.exclusive = run.exclusive or exclusive
    paths = [args.out / name for name in names]
    remove_unlisted(paths)
    refuse_existing(paths, args.force)
    return paths


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
# --- the JSON contract of every command (README "JSON contract") ------------------------------

#: Former JSON key -> (key of the contract, factor on the value): one name per quantity, its
#: unit in the name. The predicted hysteresis of the strain-energy law and the eq 87
#: hysteresis of a loop are fractions of full scale (``_fraction``), the sensor output's eq 87
#: hysteresis is ``output_hysteresis_fraction``; times are ``_s``.
RENAMED_KEYS = {
    "hysteresis": ("hysteresis_fraction", 1.0),
    "hysteresis_predicted": ("hysteresis_fraction", 1.0),
    "hysteresis_mechanical_pct": ("hysteresis_fraction", 0.01),
    "hysteresis_pct": ("output_hysteresis_fraction", 0.01),
    "seconds": ("wall_s", 1.0),
}


def file_records(paths) -> list[dict]:
    """The contract's ``files``: ``{"path", "bytes", "sha256"}`` of each written file, in
    the order written (``path`` as the command named it, under ``--out``)."""
    import hashlib

    out = []
    for p in paths:
        data = Path(p).read_bytes()
        out.append({"path": str(p), "bytes": len(data), "sha256": hashlib.sha256(data).hexdigest()})
    return out


def contract_json(value):
    """A command's result in the JSON contract: keys of :data:`RENAMED_KEYS` renamed (values
    scaled), numpy scalars as Python numbers (integers stay integers), NaN and inf as null."""
    import math

    import numpy as np

    if isinstance(value, dict):
        out = {}
        for k, v in value.items():
            new, factor = RENAMED_KEYS.get(k, (k, 1.0))
            v = contract_json(v)
            out[new] = v * factor if factor != 1.0 and isinstance(v, float) else v
        return out
    if isinstance(value, (list, tuple)):
        return [contract_json(v) for v in value]
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, Path):
        return str(value)
    return value


def print_json(result: dict, files=None) -> None:
    """Print a command's ``--json`` answer on stdout: ``result`` in the contract
    (:func:`contract_json`) with ``files`` (:func:`file_records`) when the command writes
    files (``files`` given, possibly empty)."""
    import json

    out = contract_json(result)
    if files is not None:
        out["files"] = file_records(files)
    print(json.dumps(out, indent=1))
