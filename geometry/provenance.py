"""What made a file: the tool's version and the command line, for the headers of the files
the tool writes (CSV and TOML comments, the NetCDF ``history`` attribute, the reports).

The ``dacm`` command records its own command line (:func:`record_command`); from Python the
command is the running script's (``python script.py ...``).
"""

from __future__ import annotations

import shlex
import sys
from pathlib import Path

_recorded: list[str] = []


def version() -> str:
    """The installed dacm's version (its metadata), or a note that it is not installed."""
    from importlib.metadata import PackageNotFoundError
    from importlib.metadata import version as installed

    try:
        return installed("dacm")
    except PackageNotFoundError:  # running from a source tree that was never installed
        return "unknown (not installed)"


def record_command(words: list[str]) -> None:
    """Record the command line the files of this process are made by (``["dacm", ...]``)."""
    _recorded[:] = [shlex.join(words)]


def command() -> str:
    """The command line that is making the files (shell-quoted, on one line)."""
    if _recorded:
        return _recorded[0]
    return shlex.join([Path(sys.argv[0]).name if sys.argv and sys.argv[0] else "python", *sys.argv[1:]])


def header_lines() -> list[str]:
    """The provenance lines of a file header: the version, then the command."""
    return [f"made by dacm {version()}", f"command: {command()}"]


def comment_header(prefix: str = "# ") -> str:
    """:func:`header_lines` as comment lines (each ending in a newline)."""
    return "".join(f"{prefix}{line}\n" for line in header_lines())


def git_commit() -> str | None:
    """The commit of the checkout this package runs from (``abc1234...``, with
    ``" + local changes"`` when tracked files differ from it), or None when it is not run
    from a git checkout (an installed wheel) or git is missing."""
    import subprocess

    root = Path(__file__).resolve().parent.parent
    if not (root / ".git").exists():
        return None
    try:
        head = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True,
                              text=True, timeout=10, check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, timeout=10, check=True).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None
    return head + (" + local changes" if dirty else "")
