"""Checks shared by the public dataclasses and functions of :mod:`sensor`.

Each check raises the package's input error with one line that names the field, the value
and the rule it breaks. numpy scalars count as the numbers they hold.
"""

from __future__ import annotations

import math
import numbers

from sensor.errors import SensorInputError


def is_real(value) -> bool:
    """A finite real number (Python or numpy scalar; not a bool)."""
    return (isinstance(value, numbers.Real) and not isinstance(value, bool)
            and type(value).__name__ != "bool_" and math.isfinite(float(value)))


def is_integer(value) -> bool:
    """An integer (Python or numpy; not a bool)."""
    return (isinstance(value, numbers.Integral) and not isinstance(value, bool)
            and type(value).__name__ != "bool_")


def require(ok: bool, name: str, value, rule: str, error: type[SensorInputError] = SensorInputError) -> None:
    """Raise ``error("NAME = VALUE: must be RULE")`` unless ``ok``."""
    if not ok:
        raise error(f"{name} = {value!r}: must be {rule}")
