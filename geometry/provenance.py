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
