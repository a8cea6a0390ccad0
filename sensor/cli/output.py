"""The one output rule of every ``dacm`` command that writes files.

``--out DIR`` (default ``./dacm-out/``) holds every file of a command, named after the design
(or the study); a file that exists is replaced only with ``--force``. Otherwise the command
stops with one line naming the file, before it computes anything, whenever the names are
known up front (:func:`claim`).

The folder's locking, whole sets and manifests are :mod:`sensor.output_sets`; the JSON
answer's contract is :mod:`sensor.json_contract`.
"""

from __future__ import annotations

import argparse
from collections.abc import Iterable
from pathlib import Path

from sensor.errors import UsageError
from sensor.json_contract import RENAMED_KEYS, contract_json, file_records, print_json  # noqa: F401
from sensor.output_sets import (  # noqa: F401 (the CLI's names for the output-set machinery)
    LOCK_NAME,
    MANIFEST_SCHEMA,
    STAGING_PREFIX,
    _lock,
    file_record,
    make_out_dir,
    recover,
    remove_unlisted,
    session,
    staged,
)

DEFAULT_OUT_DIR = Path("dacm-out")

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
