"""Shared test set-up.

- Figures render off-screen (Agg) whatever the environment says.
- ``dacm`` runs a command line in-process and returns (exit status, stdout, stderr).
- ``assert_one_line_error`` checks the tool's rule for bad input: exit status 2 and one
  line on stderr that starts with ``dacm COMMAND: error:``.
"""

from __future__ import annotations

import matplotlib
import pytest

matplotlib.use("Agg")


@pytest.fixture
def dacm(capsys):
    """Run ``dacm ARGS...`` in this process: returns (status, stdout, stderr)."""
    from sensor.cli import main

    def run(*argv):
        status = main([str(a) for a in argv])
        out, err = capsys.readouterr()
        return status, out, err

    return run


def assert_one_line_error(status: int, err: str, command: str) -> None:
    """Bad input: exit status 2, one line naming the command."""
    assert status == 2, f"exit status {status}, expected 2; stderr: {err!r}"
    text = err.strip()
    assert text.startswith(f"dacm {command}: error:"), text
    assert "\n" not in text and "Traceback" not in text, text
