"""Atomic file output shared by every writer of the tool (geometry is the bottom package).

A file is written to a temporary sibling and moved into place only when complete, so an
error half-way never leaves a partial or corrupt file behind. The temporary file is named
``.NAME.tmp<PID>-XXXX.SUFFIX`` after the writing process: one killed (SIGKILL) in the
middle of a write leaves it behind, and the next write of NAME removes it once that process
is gone (:func:`remove_stale_temps`).
"""

from __future__ import annotations

import contextlib
import os
import re
import tempfile
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
    """Yield a temporary path next to ``path``; on success move it onto ``path``.

    Raises ``OSError`` (with the path in its message) when the folder is missing or not
    writable.
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
        yield Path(tmp)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; give the usual file mode
        os.replace(tmp, target)
    finally:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)


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
