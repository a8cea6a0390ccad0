"""Checks shared by the public dataclasses and functions of :mod:`sensor`.

Each check raises the package's input error with one line that names the field, the value
and the rule it breaks. numpy scalars count as the numbers they hold. The rules themselves
(:class:`Number`, :func:`check_fields`) live in :mod:`geometry.validation`, the bottom package.
"""

from __future__ import annotations

from geometry.validation import Number, check_fields, is_integer, is_real, is_stem
from sensor.errors import SensorInputError

__all__ = ["Number", "check_fields", "is_integer", "is_real", "is_stem", "require", "require_finite"]


def require(ok: bool, name: str, value, rule: str, error: type[SensorInputError] = SensorInputError) -> None:
    """Raise ``error("NAME = VALUE: must be RULE")`` unless ``ok``."""
    if not ok:
        raise error(f"{name} = {value!r}: must be {rule}")


def require_finite(stage: str, values: dict) -> None:
    """Raise :class:`~sensor.errors.SolverError` naming the stage and the first value of
    ``values`` (name -> number) that is NaN or infinite: a result is never silently inf."""
    import math

    from sensor.errors import SolverError

    for name, v in values.items():
        if isinstance(v, float) and not math.isfinite(v):
            raise SolverError(f"{stage}: {name} = {v}: the result is not finite")
