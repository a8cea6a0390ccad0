"""The ``dacm`` argument parser: one sub-command per module of :mod:`sensor.cli`, one-line
argument errors with the closest valid choice suggested, ``--version`` and shell completion."""

from __future__ import annotations

import argparse
import difflib
import importlib
import re

from geometry.provenance import version

#: Command modules, in the order ``dacm --help`` lists them.
COMMANDS = ("export", "check", "draw", "solve", "verify", "render", "sweep", "design", "sensor", "measure", "report",
            "snr", "line", "loop")


def did_you_mean(word: str, choices) -> str:
    """`` (did you mean X?)`` for the closest of ``choices`` to a mistyped ``word``, or ''."""
    close = difflib.get_close_matches(word, list(choices), n=1, cutoff=0.6)
    return f" (did you mean {close[0]}?)" if close else ""


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (and exit status 2), like every other
    input error of the tool, with the closest valid choice suggested; `dacm COMMAND --help`
    still prints the full usage."""

    def error(self, message):
        m = re.search(r"invalid choice: '([^']*)' \(choose from (.*)\)$", message)
        if m:
            message += did_you_mean(m.group(1), re.findall(r"'([^']*)'", m.group(2)))
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")

    def reject_unknown(self, extras: list[str]) -> None:
        """Stop with one line naming the unknown arguments and the closest flag."""
        flags = [o for a in self._actions for o in a.option_strings if o.startswith("--")]
        unknown = next((e.split("=")[0] for e in extras if e.startswith("-")), "")
        self.error(f"unrecognized arguments: {' '.join(extras)}" + did_you_mean(unknown, flags))


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="dacm",
        description="Design tool for MRI-compatible optical force sensors (DACM bodies).",
    )
    parser.add_argument("--version", action="version", version=f"dacm {version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True,
                                parser_class=_Parser)
    for name in COMMANDS:
        importlib.import_module(f"sensor.cli.{name}").register(sub)
    return parser


def parse(argv: list[str] | None) -> argparse.Namespace:
    """Parse the command line (answering shell completion first, when asked by the shell)."""
    import argcomplete

    parser = build_parser()
    argcomplete.autocomplete(parser)
    args, extras = parser.parse_known_args(argv)
    if extras:
        sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
        sub.choices[args.command].reject_unknown(extras)
    return args
