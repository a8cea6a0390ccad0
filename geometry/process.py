"""The cutting process a design is made by (DESIGN section 16): the water-jet by default.

A :class:`Process` holds what the drawing must respect and what the cut part deviates by:

- ``min_drawn_hinge_mm``: the thinnest hinge the drawing may ask for, 0.3 mm. The thesis
  draws its most flexible hinges at 0.3 mm, "as flexible as possible considering the
  manufacturing constraints" (section 6.2.3); their as-cut values, 0.25-0.31 mm (Table 7),
  are scatter around that drawn size, not a drawable size.
- ``kerf_mm``: the jet's width, 0.8 mm (the same default as ``Design.kerf_mm``).
- ``offset_mm`` and ``sd_mm``: the as-cut scatter. Each cut hinge is its drawn thickness
  plus ``offset_mm`` plus an independent normal deviation of SD ``sd_mm``. Fitted to
  Table 7 against the drawing (hinges 1-8 drawn at 0.5 mm, 9-12 at 0.3 mm, hinge set
  05-03; 32 measured hinges of the basis specimen and samples A and B): the mean deviation
  is +0.012 mm, the within-specimen SD 0.024-0.029 mm (pooled 0.026 mm), so 0.025 mm
  (:func:`table7_deviations` and ``tests/geometry/test_process.py`` hold the fit).

Not modelled: the V-shaped cut profile (taper) the thesis mentions (section 6.2.4).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from geometry.errors import ParameterError
from geometry.params import preset
from geometry.validation import Number

_RULES = {"min_drawn_hinge_mm": Number(0.0, 10.0, lo_open=True, unit="mm"),
          "kerf_mm": Number(0.0, 5.0, lo_open=True, unit="mm"),
          "offset_mm": Number(-1.0, 1.0, unit="mm"),
          "sd_mm": Number(0.0, 1.0, unit="mm")}


@dataclass(frozen=True)
class Process:
    """A cutting process (mm): the thinnest drawn hinge, the kerf, and the as-cut scatter
    (a hinge comes out drawn + ``offset_mm`` + N(0, ``sd_mm``), independently per hinge)."""

    name: str = "water-jet"
    min_drawn_hinge_mm: float = 0.3
    kerf_mm: float = 0.8
    offset_mm: float = 0.012
    sd_mm: float = 0.025

    def __post_init__(self):
        for field, rule in _RULES.items():
            rule.check(field, getattr(self, field), ParameterError)

    def as_cut(self, drawn_mm, z) -> np.ndarray:
        """As-cut thicknesses (mm) of drawn thicknesses ``drawn_mm`` (..., hinges) for
        standard normal deviates ``z`` (draws, hinges)."""
        return np.asarray(drawn_mm, dtype=float) + self.offset_mm + self.sd_mm * np.asarray(z, dtype=float)


#: The default process: the thesis' water-jet.
WATER_JET = Process()

def table7_deviations() -> dict[str, np.ndarray]:
    """As-cut (Table 7) minus drawn (Table 5, hinge set 05-03) thickness (mm) of every
    measured hinge, per specimen (the basis specimen has hinges 1-8 only)."""
    out = {}
    for name in ("basis", "sample-a", "sample-b"):
        drawn, cut = preset(name), preset(f"{name}-as-cut")
        out[name] = np.array(cut.used_thickness_mm) - np.array(drawn.used_thickness_mm)
    return out
