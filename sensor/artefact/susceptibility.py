"""Volume magnetic susceptibilities (SI, ppm) of what surrounds and completes the body.

The body's own material carries its susceptibility in :class:`geometry.params.Material`
(``chi_ppm``: delrin, ABS). This table holds the rest: the media the sensor sits in (a water
phantom or air), the fiber, the mirror and aluminium (the metal of the thesis' comparison).
Values at room or body temperature, from

- J. F. Schenck, The role of magnetic susceptibility in magnetic resonance imaging: MRI
  magnetic compatibility of the first and second kinds, Med. Phys. 23 (1996) 815-850,
  Table 1: water -9.05, air +0.36, aluminium +20.7;
- M. C. Wapler et al., Magnetic properties of materials for MR engineering, micro-MR and
  beyond, J. Magn. Reson. 242 (2014) 233-242: PMMA (the plastic fiber's core) -9.06;
- fused silica (a glass fiber): the molar susceptibility -29.6e-6 cm^3/mol (CGS) of SiO2 in
  the CRC Handbook ("Magnetic susceptibility of the elements and inorganic compounds"),
  times the glass' density 2.196 g/cm^3 over 60.08 g/mol and 4 pi: -13.6 ppm;
- silicon (the thesis' mirror, section 6.1.3): the molar susceptibility -3.9e-6 cm^3/mol
  (CGS) of the CRC Handbook of Chemistry and Physics ("Magnetic susceptibility of the
  elements"), times its density 2.329 g/cm^3 over 28.086 g/mol and 4 pi: -4.1 ppm.
"""

from __future__ import annotations

import math

from geometry.params import MATERIALS, Material
from sensor.errors import ArtefactError

#: Susceptibilities (SI, ppm) of the materials that are not the body's.
SUSCEPTIBILITY_PPM: dict[str, float] = {
    "water": -9.05,
    "air": 0.36,
    "aluminium": 20.7,
    "pmma": -9.06,
    "silica": -13.6,
    "silicon": 4.0 * math.pi * -3.9e-6 * 2.329 / 28.086 * 1e6,
}

#: The media a sensor can be imaged in: a water phantom (ASTM F2119) or air.
MEDIA = ("water", "air")

#: The thesis' fiber (section 6.1.3): a 0.9 mm plastic (PMMA) fiber, Industrial Fiber Optics.
FIBER_MATERIAL, FIBER_DIAMETER_MM = "pmma", 0.9

#: The mirror: a silicon chip 0.5 mm thick (an assumed wafer thickness; the thesis names only
#: the material) with a 0.1 um aluminium reflective coating, recessed into the platform's
#: underside. Its layers are voxelised as one slab of their volume-weighted susceptibility
#: (:func:`layered_chi_ppm`), exact for the field beyond the slab's thickness.
MIRROR_LAYERS_MM = (("silicon", 0.5), ("aluminium", 1e-4))

#: Largest |chi| (ppm) of the model: first order in chi (the field of the magnetisation is
#: neglected in the magnetisation itself), an error of order chi, 1 % at 1e4 ppm.
MAX_ABS_CHI_PPM = 1e4


def chi_ppm(name: str) -> float:
    """The susceptibility (SI, ppm) of a named material: this module's table, then the body
    materials of :data:`geometry.params.MATERIALS`."""
    if name in SUSCEPTIBILITY_PPM:
        return SUSCEPTIBILITY_PPM[name]
    if name in MATERIALS and MATERIALS[name].chi_ppm is not None:
        return MATERIALS[name].chi_ppm
    known = sorted(set(SUSCEPTIBILITY_PPM) | set(MATERIALS))
    raise ArtefactError(f"material = {name!r}: no susceptibility known; choose one of {', '.join(known)}")


def body_chi_ppm(material: Material) -> float:
    """The susceptibility (SI, ppm) of a body material, checked against the model's range."""
    chi = material.chi_ppm
    if chi is None:
        raise ArtefactError(f"material {material.name!r}: chi_ppm is not given; the artefact needs "
                            "the volume susceptibility (SI, ppm) in the material table")
    check_chi(f"material {material.name!r} chi_ppm", chi)
    return float(chi)


def check_chi(name: str, chi: float) -> None:
    """Raise :class:`ArtefactError` unless ``chi`` (ppm) is finite and within the linear model."""
    if not (isinstance(chi, (int, float)) and math.isfinite(chi) and abs(chi) <= MAX_ABS_CHI_PPM):
        raise ArtefactError(f"{name} = {chi!r}: must be a finite number with |chi| <= "
                            f"{MAX_ABS_CHI_PPM:g} ppm (linear magnetisation, first order in chi)")


def layered_chi_ppm(layers: tuple[tuple[str, float], ...]) -> float:
    """The thickness-weighted susceptibility (ppm) of a stack of (material, thickness mm)
    layers: the same magnetic moment per unit area as the stack."""
    total = sum(t for _, t in layers)
    return sum(chi_ppm(m) * t for m, t in layers) / total
