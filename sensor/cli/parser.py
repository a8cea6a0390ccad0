"""The ``dacm`` argument parser: one sub-command per module of :mod:`sensor.cli`, one-line
argument errors with the closest valid choice suggested, ``--version`` and shell completion."""

from __future__ import annotations

import argparse
import difflib
import importlib
import re
import sys

from geometry.provenance import version

#: Command modules, in the order ``dacm --help`` lists them.
COMMANDS = ("export", "check", "draw", "solve", "verify", "render", "sweep", "design", "sensor", "measure", "report",
            "snr", "line", "loop", "artefact")


def did_you_mean(word: str, choices) -> str:
    """`` (did you mean X?)`` for the closest of ``choices`` to a mistyped ``word``, or ''."""
    close = difflib.get_close_matches(word, list(choices), n=1, cutoff=0.6)
    return f" (did you mean {close[0]}?)" if close else ""


#: A one-line error that names a value and the choices it must be one of, as every check of
#: a choice in the tool words it (``--format = 'pgn': must be one of png, svg``).
_CHOICE_ERROR = re.compile(r"'([^']*)'[^']*?(?:must be one of|choose one of) (.+)$")


def suggest_choice(message: str) -> str:
    """``message`` with the closest valid choice appended when it is a bad-choice error
    (whatever raised it: argparse, a design field, a preset, a model name)."""
    m = _CHOICE_ERROR.search(message)
    if not m or "did you mean" in message:
        return message
    return message + did_you_mean(m.group(1), re.findall(r"[A-Za-z0-9][\w.+:-]*", m.group(2)))


class DeprecatedAlias(argparse.Action):
    """An old flag kept for one release: stores into the new flag's ``dest`` and prints one
    line ``dacm COMMAND: warning: --OLD is deprecated ...; use --NEW``."""

    def __init__(self, option_strings, dest, new_flag: str, **kwargs):
        self.new_flag = new_flag
        super().__init__(option_strings, dest, **kwargs)

    def __call__(self, parser, namespace, values, option_string=None):
        print(f"{parser.prog}: warning: {option_string} is deprecated and will be removed in the next "
              f"release; use {self.new_flag}", file=sys.stderr)
        setattr(namespace, self.dest, values)


def add_target_output_argument(parser: argparse.ArgumentParser, help: str, old: str | None = None,
                               **kwargs) -> None:
    """``--target-output MM`` (``args.target_output``): the full-scale output travel, the one
    name of that quantity in every command (``target_output_mm`` in files and JSON); ``old``
    is a former name kept as a deprecated alias."""
    parser.add_argument("--target-output", type=float, metavar="MM", help=help, **kwargs)
    if old:
        parser.add_argument(old, type=float, dest="target_output", metavar="MM", action=DeprecatedAlias,
                            new_flag="--target-output", help=f"deprecated name of --target-output")


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
    for command in sub.choices.values():  # --quiet on every command, as the convention says
        if "--quiet" not in command._option_string_actions:
            command.add_argument("--quiet", action="store_true", help="print nothing on stderr but errors")
    return parser


def parse(argv: list[str] | None) -> argparse.Namespace:
    """Parse the command line (answering shell completion first, when asked by the shell)."""
    import argcomplete

    parser = build_parser()
    argcomplete.autocomplete(parser)
    if not (sys.argv[1:] if argv is None else argv):  # bare `dacm`: the help, not an error
        parser.print_help()
        parser.exit(0)
    args, extras = parser.parse_known_args(argv)
    if extras:
        sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
        sub.choices[args.command].reject_unknown(extras)
    return args
