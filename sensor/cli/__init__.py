# PYTHON_ARGCOMPLETE_OK
"""The ``dacm`` command line: one sub-command per module of :mod:`sensor.cli` (the parser is
:mod:`sensor.cli.parser`). Each command module exposes ``register(subparsers)``, which adds
its parser and sets ``func(args) -> int``. Errors caused by the user's input (the project's
own error classes, malformed TOML, files that cannot be read or written) print one line and
exit with status 2; anything else is a bug and keeps its traceback. Ctrl-C (SIGINT) and SIGTERM stop any command
with one line and exit status 130 or 143 (a sweep saves its checkpoint first); warnings are
printed as one line each. A mistyped command, flag or choice gets the closest valid one
("did you mean --phi1?"); ``dacm --version`` prints the installed version; shell completion
comes from argcomplete (``eval "$(register-python-argcomplete dacm)"``).
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import tomllib
import warnings

from geometry.errors import GeometryError
from geometry.provenance import record_command
from mri.errors import MriError
from sensor.cli.output import session
from sensor.cli.parser import build_parser, parse, suggest_choice  # noqa: F401 (build_parser: the CLI's public name)
from sensor.errors import ResourceNote, SensorError, SweepInterrupted, Terminated

#: Exceptions that mean "bad input", reported in one line with exit status 2.
USER_ERRORS = (GeometryError, MriError, SensorError, tomllib.TOMLDecodeError, OSError)


def _one_line(text) -> str:
    """A message on one line (library messages sometimes span several)."""
    return " ".join(str(text).split())


@contextlib.contextmanager
def _orderly_stops(command: str):
    """SIGTERM raises :class:`Terminated` like Ctrl-C raises KeyboardInterrupt, and each
    warning prints as one line ``dacm COMMAND: warning|note: ...`` (restored on exit); after
    a stop signal warnings are dropped (an interrupted import leaves e.g. an unclosed file)."""
    def show(message, category, *_args, **_kwargs):
        if _stopped_by:
            return
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
    record_command(["dacm", *(sys.argv[1:] if argv is None else argv)])
    try:
        args = parse(argv)
        command = args.command
        with _orderly_stops(command), session(argv):
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
        print(f"dacm {command}: error: {suggest_choice(_one_line(exc))}", file=sys.stderr)
        return 2
    except Exception:
        if _stopped_by:
            return _report_stop(command, _stopped_by[-1])
        raise


def _report_stop(command: str | None, signum: int) -> int:
    name = "SIGTERM" if signum == signal.SIGTERM else "SIGINT"
    print(f"dacm{' ' + command if command else ''}: interrupted ({name})", file=sys.stderr)
    return 128 + signum


def run() -> None:
    """The ``dacm`` console command: :func:`main`, then exit without the interpreter's teardown.

    A command has closed and renamed into place everything it writes, and stopped its worker
    pools and threads, before :func:`main` returns; what the teardown would still do is free
    every module and the compiled kernels' libraries, about 0.3 s after a sweep. The atexit
    handlers still run (multiprocessing's, weakref finalizers, logging; not threading's,
    nothing is left for them) and stdout and stderr are flushed: a reader gone from stdout
    ends the command with status 1, as in :func:`main`, another failed flush with 120, as
    Python's own exit does. An unexpected exception leaves as usual, with its traceback."""
    import atexit

    code = main()
    atexit._run_exitfuncs()  # CPython's exit handlers, which the teardown would run
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except BrokenPipeError:
            code = code or 1
        except (OSError, ValueError):
            code = code or 120
    os._exit(code)


if __name__ == "__main__":
    run()
