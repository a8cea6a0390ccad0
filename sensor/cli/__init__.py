"""The ``dacm`` command line: one sub-command per module in :mod:`sensor.commands`.

Each command module exposes ``register(subparsers)``, which adds its parser and sets
``func(args) -> int``. Errors caused by the user's input (the project's own error classes,
malformed TOML, files that cannot be read or written) print one line and exit with status 2;
anything else is a bug and keeps its traceback.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
import tomllib

from geometry.errors import GeometryError
from mri.errors import MriError
from sensor.errors import SensorError

#: Command modules, in the order ``dacm --help`` lists them.
COMMANDS = ("export", "check", "draw", "solve", "verify", "render", "sweep", "sensor", "measure", "report",
            "snr", "line", "loop")

#: Exceptions that mean "bad input", reported in one line with exit status 2.
USER_ERRORS = (GeometryError, MriError, SensorError, tomllib.TOMLDecodeError, OSError)


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (and exit status 2), like every other
    input error of the tool; `dacm COMMAND --help` still prints the full usage."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="dacm",
        description="Design tool for MRI-compatible optical force sensors (DACM bodies).",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True,
                                parser_class=_Parser)
    for name in COMMANDS:
        importlib.import_module(f"sensor.cli.{name}").register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except BrokenPipeError:
        # the reader went away (e.g. `dacm ... | head`): stop quietly, as a filter should
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except USER_ERRORS as exc:
        print(f"dacm {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
