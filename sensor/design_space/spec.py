"""What a phi1 x phi2 sweep computes: the grids, the hinge sets, the target travel, the
Monte-Carlo settings and the hysteresis law (thesis section 6.2.3, Figure 49)."""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field

import numpy as np

from geometry.params import HINGE_SETS, Design, design_from_dict, hinge_set_thicknesses
from sensor.errors import SweepError
from sensor.mechanics.hysteresis import DEFAULT_LAW, StrainEnergyLaw


@dataclass(frozen=True)
class Grid:
    """An inclusive grid START:STOP:N of angles in degrees."""

    start: float
    stop: float
    n: int

    @classmethod
    def parse(cls, text: str, name: str) -> "Grid":
        parts = str(text).split(":")
        try:
            start, stop, n = float(parts[0]), float(parts[1]), int(parts[2])
        except (IndexError, ValueError):
            raise SweepError(f"{name} = {text!r}: must be START:STOP:N (degrees, degrees, count)") from None
        if len(parts) != 3:
            raise SweepError(f"{name} = {text!r}: must be START:STOP:N (degrees, degrees, count)")
        return cls(start, stop, n).validated(name)

    def validated(self, name: str) -> "Grid":
        if self.n < 1:
            raise SweepError(f"{name} = {self}: the grid is empty (N = {self.n}; need N >= 1)")
        if not (0 < self.start < 90 and 0 < self.stop < 90):
            raise SweepError(f"{name} = {self}: angles must lie strictly between 0 and 90 degrees")
        if self.n > 1 and self.stop <= self.start:
            raise SweepError(f"{name} = {self}: STOP must exceed START")
        return self

    @property
    def values(self) -> np.ndarray:
        return np.linspace(self.start, self.stop, self.n)

    def __str__(self):
        return f"{self.start:g}:{self.stop:g}:{self.n}"


@dataclass(frozen=True)
class SweepSpec:
    """Everything a sweep's numbers depend on (stored with the dataset)."""

    hinge_sets: tuple[str, ...] = ("05-03", "03-03")
    phi1: Grid = Grid(6.0, 31.0, 41)
    phi2: Grid = Grid(4.0, 56.0, 41)
    target_output_mm: float = 1.0
    base: dict = field(default_factory=dict)   # Design fields other than angles and hinges
    monte_carlo: int = 0
    hinge_sd_mm: float = 0.0
    seed: int = 0
    law: StrainEnergyLaw = DEFAULT_LAW         # hysteresis from strain energy (section 6.2.5)

    def __post_init__(self):
        for h in self.hinge_sets:
            if h not in HINGE_SETS:
                raise SweepError(f"hinge set {h!r}: must be one of {', '.join(HINGE_SETS)}")
        if not self.hinge_sets:
            raise SweepError("no hinge set to sweep")
        self.phi1.validated("--phi1")
        self.phi2.validated("--phi2")
        if not (np.isfinite(self.target_output_mm) and self.target_output_mm > 0):
            raise SweepError(f"--target-output = {self.target_output_mm!r}: must be a positive number of mm")
        if self.monte_carlo < 0:
            raise SweepError(f"--monte-carlo = {self.monte_carlo}: must be >= 0")
        if self.monte_carlo and not self.hinge_sd_mm > 0:
            raise SweepError(f"--hinge-sd = {self.hinge_sd_mm!r}: must be > 0 mm with --monte-carlo")
        if not isinstance(self.law, StrainEnergyLaw):
            raise SweepError(f"law = {self.law!r}: must be a StrainEnergyLaw")
        self.design("05-03", 20.0, None)  # the base fields must make a valid design

    def design(self, hinges: str, phi1: float, phi2: float | None) -> Design:
        base = {k: v for k, v in self.base.items() if k not in ("phi1_deg", "phi2_deg", "hinge_set", "hinge_thickness_mm", "name")}
        return design_from_dict({**base, "phi1_deg": float(phi1), "phi2_deg": None if phi2 is None else float(phi2),
                                 "hinge_set": hinges, "hinge_thickness_mm": hinge_set_thicknesses(hinges),
                                 "name": f"{hinges}-{phi1:g}-{phi2}"}, source="sweep design")

    def to_json(self) -> str:
        d = dataclasses.asdict(self)
        return json.dumps(d, sort_keys=True, default=str)
