"""The tool's one matplotlib style (``geometry/dacm.mplstyle``: fonts legible at page width,
PNGs at 150 dpi), applied by every module that draws figures when it is imported."""

from __future__ import annotations

from pathlib import Path

#: The style sheet shipped with the package.
STYLE = Path(__file__).with_name("dacm.mplstyle")


def use() -> None:
    """Make :data:`STYLE` matplotlib's current style (rcParams; idempotent)."""
    import matplotlib.style

    matplotlib.style.use(STYLE)
