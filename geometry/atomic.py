"""Atomic file output shared by every writer of the tool (geometry is the bottom package).

A file is written to a temporary sibling and moved into place only when complete, so an
error half-way never leaves a partial or corrupt file behind.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path


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
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=target.suffix, dir=folder)
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


def save_figure(fig, path: str | os.PathLike, dpi: int = 110, close: bool = True,
                **savefig_kwargs) -> Path:
    """Write a matplotlib figure atomically (format from the suffix).

    Figures made with ``matplotlib.figure.Figure`` need no closing; a figure that pyplot
    manages is closed after writing unless ``close`` is False.
    """
    target = Path(path)
    try:
        with atomic_path(target) as tmp:
            fig.savefig(tmp, format=target.suffix.lstrip(".") or "png", dpi=dpi, **savefig_kwargs)
    finally:
        if close and getattr(fig.canvas, "manager", None) is not None:
            import matplotlib.pyplot as plt

            plt.close(fig)
    return target
