"""Declared rules for input values, shared by every package (geometry is the bottom one).

A :class:`Number` states what one numeric field accepts (finite, integer or real, a range);
:func:`check_fields` applies a table of them to an object or a mapping and raises the
caller's error with one line naming the field, the value and the rule. numpy scalars count
as the numbers they hold; bools are not numbers.
"""

from __future__ import annotations

import math
import numbers
import re
from dataclasses import dataclass

#: A file-name stem: what may be put in front of ".dxf" inside an output folder. No
#: separators, no leading dot (no hidden files, no "." or ".." escaping the folder).
STEM_PATTERN = re.compile(r"[A-Za-z0-9_-][A-Za-z0-9._-]*")
STEM_RULE = "a file-name stem of letters, digits, '.', '_' and '-' not starting with '.'"


def is_real(value) -> bool:
    """A finite real number (Python or numpy scalar; not a bool)."""
    if type(value) is float or type(value) is int:  # the common case, without the ABC check
        return math.isfinite(value)
    return (isinstance(value, numbers.Real) and not isinstance(value, bool)
            and type(value).__name__ != "bool_" and math.isfinite(float(value)))


def is_integer(value) -> bool:
    """An integer (Python or numpy; not a bool)."""
    return (isinstance(value, numbers.Integral) and not isinstance(value, bool)
            and type(value).__name__ != "bool_")


def is_stem(value) -> bool:
    """A safe file-name stem (see :data:`STEM_PATTERN`)."""
    return isinstance(value, str) and STEM_PATTERN.fullmatch(value) is not None


@dataclass(frozen=True)
class Number:
    """The rule of one numeric field: a finite number (or integer) in a range.

    ``lo``/``hi`` are bounds (None: unbounded), closed unless ``lo_open``/``hi_open``.
    """

    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    integer: bool = False
    unit: str = ""

    def ok(self, value) -> bool:
        if not (is_integer(value) if self.integer else is_real(value)):
            return False
        v = int(value) if self.integer else float(value)
        if self.lo is not None and (v <= self.lo if self.lo_open else v < self.lo):
            return False
        return not (self.hi is not None and (v >= self.hi if self.hi_open else v > self.hi))

    @property
    def rule(self) -> str:
        kind = "an integer" if self.integer else "a number"
        lo, hi = (None if v is None else str(int(v)) if self.integer else f"{v:g}"
                  for v in (self.lo, self.hi))
        if self.lo == 0 and self.lo_open and not self.hi_open:
            text = f"a positive {'integer' if self.integer else 'finite number'}"
            text += "" if hi is None else f" up to {hi}"
        elif lo is not None and hi is not None:
            text = (f"{kind} strictly between {lo} and {hi}" if self.lo_open and self.hi_open else
                    f"{kind} in {'(' if self.lo_open else '['}{lo}, {hi}{')' if self.hi_open else ']'}")
        elif lo is not None:
            text = f"{kind} {'>' if self.lo_open else '>='} {lo}"
        elif hi is not None:
            text = f"{kind} {'<' if self.hi_open else '<='} {hi}"
        else:
            text = kind if self.integer else "a finite number"
        return f"{text} ({self.unit})" if self.unit else text

    def check(self, name: str, value, error: type[Exception]):
        """``value`` as int or float; raise ``error("NAME = VALUE: must be RULE")`` if it breaks the rule."""
        if not self.ok(value):
            raise error(f"{name} = {value!r}: must be {self.rule}")
        return int(value) if self.integer else float(value)


def check_fields(source, table: dict[str, Number], error: type[Exception], prefix: str = "",
                 skip_none: bool = False) -> None:
    """Check every field of ``table`` on an object (attributes) or a mapping (keys).

    ``prefix`` goes in front of each field name in messages (e.g. ``"--"`` for flags);
    with ``skip_none`` a field that is None (not given) is not checked.
    """
    get = source.get if isinstance(source, dict) else (lambda k: getattr(source, k))
    for name, rule in table.items():
        value = get(name)
        if value is None and skip_none:
            continue
        rule.check(prefix + name.replace("_", "-") if prefix == "--" else prefix + name, value, error)
