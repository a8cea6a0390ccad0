"""From the field offset to the image artefact: offsets near the surface, the spin-echo
readout shift and the gradient-echo signal loss (ASTM F2119's 30 % criterion).

- Field offset at 1, 2 and 5 mm from the sensor's surface: the largest |ΔB| on the shell
  of voxels at that distance beyond the body's convex hull (where tissue can be; the
  mechanism's own openings are left out), in ppm and in Hz at B0
  (:func:`sensor.artefact.field.offset_hz`).
  Distances are those of voxel centres from the nearest voxel the sensor touches (Euclidean
  distance transform) less half a voxel: the distance from the surface within half a voxel.
- Spin echo: a resonance offset Δf shifts a voxel along the readout by Δf / (bandwidth per
  pixel) pixels.
- Gradient echo: each image voxel (``voxel_mm``, a whole number of field voxels) holds
  water in the medium's part of its field voxels, each with the phase 2π Δf TE and the
  dephasing of its own field gradient across it (the sinc of a linear phase, exact for a
  linear field across a field voxel). The magnitude is |mean over the image voxel|,
  against 1 for the same phantom without the sensor (uniform water, no offset). Voxels
  losing more than 30 % of the signal are the artefact (ASTM F2119-07, section 9: "signal
  intensity changes by more than 30 %"). Its extent is the largest distance from the
  sensor's surface of an artefact voxel's centre (``reaches_fov_edge`` flags an artefact
  more than a voxel from the sensor on the box's boundary: the extent is then a lower
  bound; enlarge the margin). In air there is no signal: the loss is
  then that of the dephasing alone, what tissue placed there would lose.

Not modelled: eddy currents from the RF or the gradients (the body is an insulator, the
metal comparison is not), chemical shift, relaxation, the readout shift's own distortion
of the gradient-echo image. Lengths mm, fields ppm, frequencies Hz, times ms.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from geometry.params import Design
from sensor.artefact.field import PAD_FACTOR, b0_unit, field_offset_ppm, offset_hz, padded_shape
from sensor.artefact.scene import MARGIN_MM, RESOLUTION_MM, Scene, sensor_scene
from sensor.errors import ArtefactError
from sensor.validation import Number, check_fields

#: Distances (mm) from the surface at which the field offset is reported.
SURFACE_DISTANCES_MM = (1.0, 2.0, 5.0)

#: ASTM F2119: a voxel is artefact when its signal changes by more than this fraction.
SIGNAL_LOSS_THRESHOLD = 0.30

#: Solid fraction above which an image voxel counts as the sensor itself, not its artefact.
_INSIDE = 0.5


@dataclass(frozen=True)
class Protocol:
    """A scan: field ``b0_T`` (T), echo time ``te_ms`` (ms), readout ``bandwidth_hz_per_px``
    (Hz per pixel) and isotropic image ``voxel_mm`` (mm)."""

    b0_T: float = 3.0
    te_ms: float = 10.0
    bandwidth_hz_per_px: float = 130.0
    voxel_mm: float = 1.0

    def __post_init__(self):
        check_fields(self, PROTOCOL_RULES, ArtefactError)


#: The rule of each :class:`Protocol` field (research magnets reach 11.7 T for humans, 20 T
#: for small animals).
PROTOCOL_RULES = {
    "b0_T": Number(0.0, 20.0, lo_open=True, unit="T"),
    "te_ms": Number(0.0, 1000.0, lo_open=True, unit="ms"),
    "bandwidth_hz_per_px": Number(0.0, 1e6, lo_open=True, unit="Hz per pixel"),
    "voxel_mm": Number(0.0, 20.0, lo_open=True, unit="mm"),
}

#: The rules of the field grid: its voxel, and the margin around the sensor (at least 5 mm
#: and a voxel, so that every shell of :data:`SURFACE_DISTANCES_MM` lies in the box).
GRID_RULES = {"resolution_mm": Number(0.0, 5.0, lo_open=True, unit="mm"),
              "margin_mm": Number(10.0, 200.0, unit="mm")}


@dataclass(frozen=True)
class Artefact:
    """The prediction: the scene, its field offset (ppm, field grid), the simulated
    gradient-echo magnitude with the sensor (image grid; 1 is the phantom without it), the
    artefact mask and the numbers of :meth:`summary`."""

    design: Design
    protocol: Protocol
    b0_direction: tuple[float, float, float]
    scene: Scene
    field_ppm: np.ndarray
    distance_mm: np.ndarray
    magnitude: np.ndarray
    artefact: np.ndarray
    inside: np.ndarray
    block: int
    padded_shape: tuple[int, int, int]
    body_material: str

    @property
    def image_grid(self):
        return self.scene.grid.coarsened(self.block)

    def surface_offsets(self) -> list[dict]:
        """The largest |offset| on the shells 1, 2, 5 mm from the surface, with the
        spin-echo readout shift it causes."""
        h = self.scene.grid.voxel_mm
        rows = []
        for d in SURFACE_DISTANCES_MM:
            shell = (np.abs(self.distance_mm - d) <= h / 2.0) & self.scene.beyond_hull
            ppm = float(np.max(np.abs(self.field_ppm[shell]))) if shell.any() else math.nan
            hz = float(offset_hz(ppm, self.protocol.b0_T))
            rows.append({"distance_mm": d, "ppm": ppm, "hz": hz,
                         "spin_echo_shift_px": hz / self.protocol.bandwidth_hz_per_px})
        return rows

    def summary(self) -> dict:
        """The numbers, JSON-ready."""
        g, p = self.image_grid, self.protocol
        outside = self.artefact & ~self.inside
        centre_distance = _block_mean(self.distance_mm, self.block)
        extent = float(centre_distance[outside].max()) if outside.any() else 0.0
        medium = self.distance_mm > 0
        peak = float(np.max(np.abs(self.field_ppm[medium])))
        edge = np.zeros(outside.shape, bool)
        edge[[0, -1], :, :] = edge[:, -1, :] = edge[:, :, [0, -1]] = True  # y min: the fiber leaves
        return {
            "design": self.design.name,
            "material": self.body_material,
            "chi_ppm": dict(self.scene.parts),
            "medium": self.scene.medium,
            "chi_medium_ppm": self.scene.chi_medium_ppm,
            "b0_T": p.b0_T,
            "b0_direction": [round(v, 6) for v in self.b0_direction],
            "te_ms": p.te_ms,
            "bandwidth_hz_per_px": p.bandwidth_hz_per_px,
            "voxel_mm": p.voxel_mm,
            "resolution_mm": self.scene.grid.voxel_mm,
            "grid_shape": list(self.scene.grid.shape),
            "fft_shape": list(self.padded_shape),
            "max_offset_ppm": peak,
            "max_offset_hz": float(offset_hz(peak, p.b0_T)),
            "surface_offsets": self.surface_offsets(),
            "gradient_echo": {
                "loss_threshold": SIGNAL_LOSS_THRESHOLD,
                "extent_mm": extent,
                "volume_mm3": float(outside.sum() * g.voxel_mm ** 3),
                "reaches_fov_edge": bool((outside & edge & (centre_distance > g.voxel_mm)).any()),
            },
        }


def _block_mean(a: np.ndarray, n: int) -> np.ndarray:
    """Means over blocks of n^3 voxels (shape divisible by n)."""
    if n == 1:
        return a
    x, y, z = a.shape
    return a.reshape(x // n, n, y // n, n, z // n, n).mean(axis=(1, 3, 5))


def block_factor(voxel_mm: float, resolution_mm: float) -> int:
    """Field voxels per image voxel side; raises unless ``voxel_mm`` is a whole multiple."""
    n = round(voxel_mm / resolution_mm)
    if n < 1 or abs(n * resolution_mm - voxel_mm) > 1e-6 * voxel_mm:
        raise ArtefactError(f"voxel_mm = {voxel_mm:g}: must be a whole multiple of the field "
                            f"resolution_mm = {resolution_mm:g}")
    return int(n)


def gradient_echo_magnitude(field_ppm: np.ndarray, water: np.ndarray, h_mm: float, block: int,
                            b0_T: float, te_ms: float) -> np.ndarray:
    """|mean of water · e^{iφ} · Π sinc(∂φ/∂x_i h / 2)| over image voxels of ``block``^3
    field voxels, φ = 2π Δf TE (rad); 1 is full signal."""
    phase = (2.0 * np.pi * te_ms * 1e-3) * offset_hz(field_ppm, b0_T).astype(np.float32)
    weight = water.astype(np.float32)
    for g in np.gradient(phase, h_mm):
        weight *= np.sinc(g * (h_mm / (2.0 * np.pi))).astype(np.float32)  # np.sinc(x) = sin(πx)/(πx)
    signal = weight * np.exp(1j * phase)
    return np.abs(_block_mean(signal, block)).astype(np.float32)


def predict(design: Design, protocol: Protocol = Protocol(), medium: str = "water", b0_direction="z",
            resolution_mm: float = RESOLUTION_MM, margin_mm: float = MARGIN_MM,
            body_material: str | None = None, pad_factor: float = PAD_FACTOR,
            workers: int | None = None) -> Artefact:
    """The artefact of a design's sensor (body, fiber, mirror) in ``medium`` for a scan."""
    b = b0_unit(b0_direction)
    check_fields({"resolution_mm": resolution_mm, "margin_mm": margin_mm}, GRID_RULES, ArtefactError)
    block = block_factor(protocol.voxel_mm, resolution_mm)
    scene = sensor_scene(design, medium, resolution_mm, margin_mm, block, body_material)
    field = field_offset_ppm(scene.delta_chi_ppm, resolution_mm, b, pad_factor, workers)
    touched = scene.solid > 0.0  # voxels holding any of the sensor: its surface runs through them
    distance = ndimage.distance_transform_edt(~touched, sampling=resolution_mm).astype(np.float32)
    distance = np.where(touched, 0.0, distance - resolution_mm / 2.0).astype(np.float32)
    water = 1.0 - scene.solid
    magnitude = gradient_echo_magnitude(field, water, resolution_mm, block, protocol.b0_T, protocol.te_ms)
    if medium == "air":  # no signal in air: the loss of the dephasing alone (0 in the sensor)
        fraction = _block_mean(water, block)
        magnitude = np.divide(magnitude, fraction, out=np.zeros_like(magnitude), where=fraction > 1e-3)
    inside = _block_mean(scene.solid, block) >= _INSIDE
    artefact = magnitude < 1.0 - SIGNAL_LOSS_THRESHOLD
    result = Artefact(design, protocol, tuple(float(v) for v in b), scene, field, distance,
                      magnitude, artefact, inside, block, padded_shape(scene.grid.shape, pad_factor),
                      body_material or design.material.name)
    return result
