"""Atomic file output shared by every writer of the tool (geometry is the bottom package).

A file is written to a temporary sibling, checked, flushed to the disk (``fsync``) and moved
into place only when complete, so an error half-way never leaves a partial or corrupt file
under its name. The temporary file is named ``.NAME.tmp<PID>-XXXX.SUFFIX`` after the writing
process: one killed (SIGKILL) in the middle of a write leaves it behind, and the next write
of NAME removes it once that process is gone (:func:`remove_stale_temps`).

Some writers do not report a failed write: OpenCASCADE's STEP writer returns success when a
file-size limit (``ulimit -f``, EFBIG) or a full disk (ENOSPC) cut its file short. Every file
of a format with a known end (STEP, STL, DXF, PNG, SVG, PDF, HTML, JSON, TOML, CSV) is
therefore checked to end where it should before it is moved into place
(:func:`check_complete`); a write error of any kind is one :class:`OSError` naming the file
and the errno (:func:`write_error`).
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import re
import resource
import shutil
import tempfile
import tomllib
from pathlib import Path


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # someone else's process
        return True
    return True


def remove_stale_temps(path: str | os.PathLike) -> list[Path]:
    """Remove the temporary files of ``path`` left by writers that no longer run (and those
    of the older ``.NAME.XXXXXXXX.SUFFIX`` form); return what was removed."""
    target = Path(path)
    folder = target.parent if str(target.parent) else Path(".")
    name, suffix = re.escape(target.name), re.escape(target.suffix)
    pattern = re.compile(rf"\.{name}\.(?:tmp(\d+)-[A-Za-z0-9_]+|[a-z0-9_]{{8}}){suffix}")
    removed = []
    with contextlib.suppress(OSError):
        for entry in folder.iterdir():
            m = pattern.fullmatch(entry.name)
            if m and not (m.group(1) and _alive(int(m.group(1)))):
                with contextlib.suppress(FileNotFoundError):
                    entry.unlink()
                    removed.append(entry)
    return removed


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike):
    """Yield a temporary path next to ``path``; on success check it is complete
    (:func:`check_complete`), flush it to the disk and move it onto ``path``.

    Raises ``OSError`` naming ``path`` when the folder is missing or not writable, or when a
    write fails or leaves the file cut short (:func:`write_error`); the temporary file is
    removed and ``path`` keeps what it held.
    """
    target = Path(path)
    folder = target.parent if str(target.parent) else Path(".")
    if not folder.is_dir():
        raise FileNotFoundError(f"output folder does not exist: {folder}")
    if not os.access(folder, os.W_OK):
        raise PermissionError(f"output folder is not writable: {folder}")
    remove_stale_temps(target)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.tmp{os.getpid()}-", suffix=target.suffix,
                               dir=folder)
    os.close(fd)
    try:
        try:
            yield Path(tmp)
        except WriteError as exc:  # a nested write's: name this file if it named the temporary one
            if tmp not in str(exc):
                raise
            raise WriteError(exc.errno, exc.strerror.replace(tmp, str(target))) from None
        except OSError as exc:  # a write of this file (or of none named) failed
            if exc.errno is None or exc.filename not in (None, tmp):
                raise
            raise write_error(target, exc.errno) from None
        check_complete(Path(tmp), target)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; give the usual file mode
        try:
            fsync_path(tmp)
            os.replace(tmp, target)
            fsync_path(folder)
        except OSError as exc:
            raise write_error(target, exc.errno or errno.EIO) from None
    finally:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)


def write_bytes(path: str | os.PathLike, data: bytes | memoryview) -> Path:
    """Write ``data`` to ``path`` atomically with Python's own file I/O (every failed write
    raises); for writers that can render to memory (NetCDF), whose libraries handle a failed
    write badly (HDF5 crashes on a full disk)."""
    target = Path(path)
    with atomic_path(target) as tmp:
        with open(tmp, "wb") as fh:
            fh.write(data)
    if target.stat().st_size != len(data):  # pragma: no cover - the write above raises first
        raise write_error(target, errno.EIO)
    return target


def fsync_path(path: str | os.PathLike) -> None:
    """Flush a file, or a folder's entries, to the disk."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


class WriteError(OSError):
    """A write that failed, or left its file cut short; the message names the file."""


def write_error(target: str | os.PathLike, code: int, detail: str = "") -> WriteError:
    """The one error of a failed write: names the file and the errno (``[Errno 28] No space
    left on device (ENOSPC): cannot write OUT/x.step``)."""
    name = errno.errorcode.get(code, str(code))
    return WriteError(code, f"{os.strerror(code)} ({name}): cannot write {target}"
                            + (f" ({detail})" if detail else ""))


def cut_short_errno(path: Path) -> int:
    """Why a file stopped early: the file-size limit (EFBIG), a full disk (ENOSPC) or EIO."""
    size = path.stat().st_size
    soft, _ = resource.getrlimit(resource.RLIMIT_FSIZE)
    if soft != resource.RLIM_INFINITY and size >= soft:
        return errno.EFBIG
    if shutil.disk_usage(path.parent).free < 64 * 1024:
        return errno.ENOSPC
    return errno.EIO


def _tail(path: Path, n: int = 1024) -> bytes:
    with open(path, "rb") as fh:
        fh.seek(0, os.SEEK_END)
        fh.seek(max(0, fh.tell() - n))
        return fh.read()


def _ends_with(*markers: bytes):
    return lambda path: _tail(path).rstrip().endswith(markers)


def _stl(path: Path) -> bool:
    with open(path, "rb") as fh:
        head = fh.read(84)
    if head.startswith(b"solid") and b"endsolid" in _tail(path):
        return True  # ASCII STL
    n = int.from_bytes(head[80:84], "little")
    return len(head) == 84 and path.stat().st_size == 84 + 50 * n


def _parses(loads):
    def check(path: Path) -> bool:
        try:
            loads(path.read_text(encoding="utf-8"))
        except (ValueError, UnicodeDecodeError):  # JSONDecodeError, TOMLDecodeError
            return False
        return True
    return check


#: How a complete file of each suffix ends: suffix -> check(path) -> bool. Text formats
#: whose writers end every line (CSV, TOML) are checked for the final newline: a cut at a
#: line's end passes; these writers are Python's, which raise on a failed write anyway.
COMPLETE = {
    ".step": _ends_with(b"END-ISO-10303-21;"), ".stp": _ends_with(b"END-ISO-10303-21;"),
    ".stl": _stl, ".dxf": _ends_with(b"EOF"), ".png": _ends_with(b"IEND\xaeB`\x82"),
    ".svg": _ends_with(b"</svg>"), ".pdf": _ends_with(b"%%EOF"),
    ".html": _ends_with(b"</html>", b"</HTML>"), ".json": _parses(json.loads),
    ".toml": lambda path: _tail(path, 1).endswith(b"\n") and _parses(tomllib.loads)(path),
    ".csv": lambda path: _tail(path, 1).endswith(b"\n"),
}


def check_complete(path: Path, target: Path | None = None) -> None:
    """Raise :func:`write_error` (naming ``target``) when the file at ``path`` does not end
    as a complete file of ``target``'s format must (:data:`COMPLETE`; other suffixes are
    not checked)."""
    target = path if target is None else target
    check = COMPLETE.get(target.suffix.lower())
    if check is not None and not check(path):
        raise write_error(target, cut_short_errno(path),
                          f"the file stopped at {path.stat().st_size} bytes, before its end")


def save_figure(fig, path: str | os.PathLike, dpi: float | None = None, close: bool = True,
                **savefig_kwargs) -> Path:
    """Write a matplotlib figure atomically (format from the suffix; ``dpi`` by default the
    tool's style, :mod:`geometry.style`; an SVG carries no date, so it depends only on the
    figure).

    Figures made with ``matplotlib.figure.Figure`` need no closing; a figure that pyplot
    manages is closed after writing unless ``close`` is False.
    """
    target = Path(path)
    kind = target.suffix.lstrip(".") or "png"
    if kind == "svg":
        savefig_kwargs.setdefault("metadata", {"Date": None})
    try:
        with atomic_path(target) as tmp:
            fig.savefig(tmp, format=kind, dpi=dpi, **savefig_kwargs)
    finally:
        if close and getattr(fig.canvas, "manager", None) is not None:
            import matplotlib.pyplot as plt

            plt.close(fig)
    return target
