"""The one output rule of every ``dacm`` command that writes files.

``--out DIR`` (default ``./dacm-out/``, created when the first file is written) holds every
file of a command, named after the design (or the study); a file that exists is replaced only
with ``--force``. Otherwise the command stops with one line naming the file, before it computes
anything, whenever the names are known up front (:func:`claim`).
"""

from __future__ import annotations

import argparse
from collections.abc import Iterable
from pathlib import Path

from sensor.errors import UsageError

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


def refuse_existing(paths: Iterable[Path], force: bool, hint: str = "",
                    elsewhere: str = "another --out") -> None:
    """Raise :class:`UsageError` naming the first of ``paths`` that exists, unless ``force``;
    ``hint`` is another way out, e.g. ``"--resume to finish it"``."""
    if force:
        return
    paths = list(paths)
    existing = [p for p in paths if Path(p).exists()]
    if existing:
        more = f" ({len(existing)} of the {len(paths)} files to write do)" if len(existing) > 1 else ""
        raise UsageError(f"{existing[0]} exists{more}: use --force to replace, "
                         f"{hint + ', ' if hint else ''}or {elsewhere}")


def claim_files(paths_by_flag: dict[str, str | None], force: bool) -> None:
    """The rule for a command whose flags name their files (``dacm snr --csv PATH``): each
    given path's folder exists and the file does not, unless ``force``; checked before any
    work, one line naming the flag otherwise."""
    for flag, path in paths_by_flag.items():
        if path and not Path(path).parent.is_dir():
            raise UsageError(f"{flag} {path}: the folder {Path(path).parent} does not exist")
    refuse_existing([Path(p) for p in paths_by_flag.values() if p], force, elsewhere="another path")


def claim(args: argparse.Namespace, names: Iterable[str], hint: str = "") -> list[Path]:
    """The paths ``args.out / name`` of the files a command will write, checked by the rule:
    ``--out`` is a folder, and none of them exists unless ``--force``."""
    check_out_dir(args.out)
    paths = [args.out / name for name in names]
    refuse_existing(paths, args.force, hint)
    return paths


def make_out_dir(out: Path) -> Path:
    """Create ``out`` (and its parents) when the first file is about to be written."""
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OSError(f"cannot create output folder {out}: {exc.strerror}") from None
    return out


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
