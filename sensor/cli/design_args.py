"""The design-selection flags shared by every command that works on one design.

A design comes from exactly one source: the flags ``--design basis|proposed --phi1 --phi2
--hinges`` (the default: the proposed body at phi1 = 22, phi2 = 17.2 deg, hinge set 05-03),
a thesis preset (``--preset sample-a``), or a TOML file (``--config design.toml``).
``--material`` overrides the material of any of them.
"""

from __future__ import annotations

import argparse
import os
import re
from pathlib import Path

from geometry.errors import GeometryError
from geometry.params import (
    HINGE_SETS,
    MATERIALS,
    PRESETS,
    Design,
    load_design,
    make_design,
    preset,
)
from sensor.errors import UsageError
from sensor.validation import Number, check_fields

DESIGN_KINDS = ("basis", "proposed")
DEFAULT_PHI1_DEG, DEFAULT_PHI2_DEG, DEFAULT_HINGES = 22.0, 17.2, "05-03"


def add_design_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the design-selection flags to a sub-command's parser."""
    g = parser.add_argument_group("design (flags, or --preset, or --config)")
    g.add_argument("--design", metavar="KIND", help="basis | proposed (default proposed)")
    g.add_argument("--phi1", type=float, metavar="DEG",
                   help=f"side-link lean from the vertical, deg (default {DEFAULT_PHI1_DEG:g})")
    g.add_argument("--phi2", type=float, metavar="DEG",
                   help=f"middle-link rise above the horizontal, deg (default {DEFAULT_PHI2_DEG:g}; "
                        "not for --design basis)")
    g.add_argument("--hinges", metavar="SET",
                   help=f"hinge set: {' | '.join(HINGE_SETS)} (default {DEFAULT_HINGES})")
    g.add_argument("--preset", metavar="NAME", help=f"thesis specimen: {', '.join(PRESETS)}")
    g.add_argument("--config", metavar="TOML", type=Path, help="read the design from a TOML file")
    g.add_argument("--material", metavar="NAME",
                   help=f"{' | '.join(MATERIALS)} (default: the design's own, delrin)")


def _flag_design(args: argparse.Namespace) -> Design:
    kind = "proposed" if args.design is None else args.design
    if kind not in DESIGN_KINDS:
        raise UsageError(f"--design = {kind!r}: must be one of {', '.join(DESIGN_KINDS)}")
    phi1 = DEFAULT_PHI1_DEG if args.phi1 is None else args.phi1
    hinges = DEFAULT_HINGES if args.hinges is None else args.hinges
    if kind == "basis":
        if args.phi2 is not None:
            raise UsageError(f"--phi2 = {args.phi2:g}: the basis body has no middle branch "
                                 "(drop --phi2 or use --design proposed)")
        return make_design(phi1, None, hinges, name=f"basis-{phi1:g}-{hinges}")
    phi2 = DEFAULT_PHI2_DEG if args.phi2 is None else args.phi2
    return make_design(phi1, phi2, hinges, name=f"proposed-{phi1:g}-{phi2:g}-{hinges}")


def _stem(text: str) -> str:
    """A file name's stem made safe as a design name (other characters become '_')."""
    return re.sub(r"[^A-Za-z0-9._-]", "_", text).lstrip(".") or "custom"


def design_from_args(args: argparse.Namespace) -> Design:
    """The design chosen by the flags of :func:`add_design_arguments`.

    Raises :class:`~sensor.errors.UsageError` for conflicting or unknown choices (one-line messages).
    """
    shape_flags = [f"--{n}" for n in ("design", "phi1", "phi2", "hinges")
                   if getattr(args, n) is not None]
    if args.preset is not None and args.config is not None:
        raise UsageError("--preset and --config: give only one source for the design")
    source = "--preset" if args.preset is not None else "--config" if args.config is not None else None
    if source and shape_flags:
        raise UsageError(f"{shape_flags[0]} cannot be combined with {source} "
                             "(give the design by flags, by --preset or by --config)")
    if args.preset is not None:
        design = preset(args.preset)
    elif args.config is not None:
        try:
            design = load_design(input_file("--config", args.config))
        except GeometryError as exc:  # name the flag and the file, as every message does
            message = str(exc).removeprefix(f"{args.config}: ")
            raise type(exc)(f"--config {args.config}: {message}") from None
        if design.name == "custom":
            design = design.replace(name=_stem(args.config.stem))
    else:
        design = _flag_design(args)
    if args.material is not None:
        if args.material not in MATERIALS:
            raise UsageError(f"--material = {args.material!r}: must be one of {', '.join(MATERIALS)}")
        if MATERIALS[args.material] != design.material:
            design = design.replace(material=MATERIALS[args.material],
                                    name=f"{design.name}-{args.material}")
    return design


def input_file(flag: str, path: str | os.PathLike) -> Path:
    """``path`` of a file flag, checked to be a readable file: raise
    :class:`~sensor.errors.UsageError` naming the flag when it is missing, a folder or
    unreadable."""
    path = Path(path)
    if not path.exists():
        raise UsageError(f"{flag} {path}: no such file")
    if path.is_dir():
        raise UsageError(f"{flag} {path}: is a folder; give a file")
    if not os.access(path, os.R_OK):
        raise UsageError(f"{flag} {path}: cannot be read (permission denied)")
    return path


def flagged(message: str, flags: dict[str, str]) -> str:
    """A library message with its fields named as the flags that set them
    (``flags``: field -> flag)."""
    for name, flag in flags.items():
        message = message.replace(f"{name} = ", f"{flag} = ")
    return message


def check_flags(args: argparse.Namespace, rules: dict[str, Number]) -> None:
    """Check numeric flags by their declared rules (a flag not given is skipped); raise
    :class:`~sensor.errors.UsageError` naming ``--flag``, the value and the rule."""
    check_fields(args, rules, UsageError, prefix="--", skip_none=True)


def travel_rule(size_mm: float) -> Number:
    """The rule of a target output travel: positive, at most the body's size (mm)."""
    return Number(0.0, float(size_mm), lo_open=True, unit="mm, at most the body's size")
