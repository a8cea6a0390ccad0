"""The ``dacm`` command line: one sub-command per module in :mod:`sensor.commands`.

Each command module exposes ``register(subparsers)``, which adds its parser and sets
``func(args) -> int``. Errors caused by the user's input (the project's own error classes,
malformed TOML, files that cannot be read or written) print one line and exit with status 2;
anything else is a bug and keeps its traceback. Ctrl-C (SIGINT) and SIGTERM stop any command
with one line and exit status 130 or 143 (a sweep saves its checkpoint first); warnings are
printed as one line each.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import os
import signal
import sys
import tomllib
import warnings

from geometry.errors import GeometryError
from mri.errors import MriError
from sensor.errors import ResourceNote, SensorError, SweepInterrupted, Terminated

#: Command modules, in the order ``dacm --help`` lists them.
COMMANDS = ("export", "check", "draw", "solve", "verify", "render", "sweep", "design", "sensor", "measure", "report",
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


def _one_line(text) -> str:
    """A message on one line (library messages sometimes span several)."""
    return " ".join(str(text).split())


@contextlib.contextmanager
def _orderly_stops(command: str):
    """SIGTERM raises :class:`Terminated` like Ctrl-C raises KeyboardInterrupt, and each
    warning prints as one line ``dacm COMMAND: warning|note: ...`` (restored on exit)."""
    def show(message, category, *_args, **_kwargs):
        kind = "note" if issubclass(category, ResourceNote) else "warning"
        print(f"dacm {command}: {kind}: {_one_line(message)}", file=sys.stderr)

    def stop(signum, _frame):
        _stopped_by.append(signum)
        raise Terminated(signum) if signum == signal.SIGTERM else KeyboardInterrupt

    in_main = _is_main_thread()
    previous = {sig: signal.signal(sig, stop) for sig in (signal.SIGTERM, signal.SIGINT)} if in_main else {}
    with warnings.catch_warnings():
        warnings.simplefilter("default")
        warnings.showwarning = show
        try:
            yield
        finally:
            for sig, handler in previous.items():
                signal.signal(sig, handler)


#: The signals that stopped the running command (a C extension interrupted while it loads
#: turns the KeyboardInterrupt into an ImportError; this list still tells it was a stop).
_stopped_by: list[int] = []


def _is_main_thread() -> bool:
    import threading

    return threading.current_thread() is threading.main_thread()


def main(argv: list[str] | None = None) -> int:
    command = None
    _stopped_by.clear()
    try:
        args = build_parser().parse_args(argv)
        command = args.command
        with _orderly_stops(command):
            return int(args.func(args) or 0)
    except BrokenPipeError:
        # the reader went away (e.g. `dacm ... | head`): stop quietly, as a filter should
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except SweepInterrupted as exc:
        print(f"dacm {command}: {_one_line(exc)}", file=sys.stderr)
        return 128 + exc.signum
    except KeyboardInterrupt as exc:
        return _report_stop(command, signal.SIGTERM if isinstance(exc, Terminated) else signal.SIGINT)
    except USER_ERRORS as exc:
        if _stopped_by:
            return _report_stop(command, _stopped_by[-1])
        print(f"dacm {command}: error: {_one_line(exc)}", file=sys.stderr)
        return 2
    except Exception:
        if _stopped_by:
            return _report_stop(command, _stopped_by[-1])
        raise


def _report_stop(command: str | None, signum: int) -> int:
    name = "SIGTERM" if signum == signal.SIGTERM else "SIGINT"
    print(f"dacm{' ' + command if command else ''}: interrupted ({name})", file=sys.stderr)
    return 128 + signum


if __name__ == "__main__":
    sys.exit(main())
