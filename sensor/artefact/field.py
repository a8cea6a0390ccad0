"""The field offset a susceptibility distribution makes in B0: the dipole kernel by FFT.

Convention: ``delta_chi`` is the susceptibility less the surrounding medium's (SI, ppm), and
the result is the offset of the local field along B0 relative to the field in the medium
far away, ΔB/B0 in ppm, to first order in chi, with the Lorentz-sphere correction (the field
a nucleus sees in a continuous medium):

    ΔB/B0 = IFFT[ (1/3 - (k·b)^2 / |k|^2) FFT(Δchi) ],   b the unit vector along B0

(R. Salomir, B. D. de Senneville, C. T. W. Moonen, Concepts Magn. Reson. B 19 (2003) 26-34;
J. P. Marques, R. Bowtell, Concepts Magn. Reson. B 25 (2005) 65-78). The k = 0 term is set
to zero: the medium's own field is the reference. The grid is zero-padded (Δchi = 0 is the
medium) so that the periodic images of the FFT sit far away; :data:`PAD_FACTOR` is checked
by the convergence test. Lengths in mm.
"""

from __future__ import annotations

import math
import os

import numpy as np
import scipy.fft

from sensor.errors import ArtefactError

#: Each axis is zero-padded to at least this multiple of its length (then to a fast FFT size).
PAD_FACTOR = 1.5

#: The proton's gyromagnetic ratio over 2 pi (Hz/T), CODATA 2018 (shielded in water would be
#: 25 ppm less: a rounding at this model's accuracy).
GAMMA_BAR_HZ_PER_T = 42.577478518e6

_AXES = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}


def b0_unit(direction) -> np.ndarray:
    """The unit vector along B0 in the sensor's frame (x across, y up the force axis, z
    through the sheet): ``"x"``, ``"y"``, ``"z"``, or three numbers (a sequence or a string
    ``"0,1,1"``) of any non-zero length."""
    if isinstance(direction, str) and direction.strip().lower() in _AXES:
        return np.array(_AXES[direction.strip().lower()])
    try:
        parts = direction.replace(",", " ").split() if isinstance(direction, str) else list(direction)
        v = np.array([float(p) for p in parts], dtype=float)
    except (TypeError, ValueError):
        v = np.array([])
    norm = float(np.linalg.norm(v)) if v.shape == (3,) and np.all(np.isfinite(v)) else 0.0
    if norm == 0.0:
        raise ArtefactError(f"b0_direction = {direction!r}: must be x, y, z or three numbers "
                            "(not all zero) such as 0,1,1")
    return v / norm


def padded_shape(shape, pad_factor=PAD_FACTOR) -> tuple[int, ...]:
    """The FFT grid: each axis at least ``pad_factor`` times longer (one number, or one per
    axis; 1 leaves an axis periodic), a fast FFT size."""
    factors = tuple(pad_factor) if isinstance(pad_factor, (tuple, list)) else (pad_factor,) * len(shape)
    if len(factors) != len(shape) or not all(isinstance(f, (int, float)) and math.isfinite(f)
                                             and f >= 1.0 for f in factors):
        raise ArtefactError(f"pad_factor = {pad_factor!r}: must be a number >= 1, or one per axis")
    return tuple(n if f == 1.0 else scipy.fft.next_fast_len(math.ceil(n * f), real=True)
                 for n, f in zip(shape, factors))


def dipole_kernel(shape, voxel_mm: float, b0) -> np.ndarray:
    """D(k) = 1/3 - (k·b)^2/|k|^2 on the half-spectrum of :func:`scipy.fft.rfftn` of a
    real grid of ``shape``, float32; D(0) = 0."""
    b = b0_unit(b0)
    kx = scipy.fft.fftfreq(shape[0], voxel_mm).astype(np.float32)[:, None, None]
    ky = scipy.fft.fftfreq(shape[1], voxel_mm).astype(np.float32)[None, :, None]
    kz = scipy.fft.rfftfreq(shape[2], voxel_mm).astype(np.float32)[None, None, :]
    k2 = (kx * kx + ky * ky) + kz * kz          # the only two full-size arrays: k2 and d
    d = (kx * np.float32(b[0]) + ky * np.float32(b[1])) + kz * np.float32(b[2])
    k2[0, 0, 0] = 1.0
    np.square(d, out=d)
    np.divide(d, k2, out=d)
    np.subtract(np.float32(1.0 / 3.0), d, out=d)
    d[0, 0, 0] = 0.0
    return d


def field_offset_ppm(delta_chi_ppm: np.ndarray, voxel_mm: float, b0="z",
                     pad_factor: float = PAD_FACTOR, workers: int | None = None) -> np.ndarray:
    """ΔB/B0 (ppm, float32, the grid's shape) of a susceptibility difference map (ppm) on a
    grid of cubic voxels ``voxel_mm``; ``workers`` FFT threads (default: every core)."""
    chi = np.asarray(delta_chi_ppm, dtype=np.float32)
    if chi.ndim != 3:
        raise ArtefactError(f"delta_chi_ppm has shape {chi.shape}: must be a 3D grid")
    if not np.all(np.isfinite(chi)):
        raise ArtefactError("delta_chi_ppm holds NaN or infinite values: must be finite")
    shape = padded_shape(chi.shape, pad_factor)
    workers = workers or os.cpu_count() or 1
    spectrum = scipy.fft.rfftn(chi, s=shape, workers=workers, overwrite_x=False)
    spectrum *= dipole_kernel(shape, voxel_mm, b0)
    field = scipy.fft.irfftn(spectrum, s=shape, workers=workers, overwrite_x=True)
    nx, ny, nz = chi.shape
    return np.ascontiguousarray(field[:nx, :ny, :nz], dtype=np.float32)


def offset_hz(ppm, b0_T: float):
    """The resonance offset (Hz) of a field offset ``ppm`` at ``b0_T`` tesla."""
    return np.asarray(ppm) * 1e-6 * b0_T * GAMMA_BAR_HZ_PER_T


# --- exact solutions (the tests' references) ---------------------------------------------

def sphere_offset_ppm(points_mm, radius_mm: float, delta_chi_ppm: float, b0="z") -> np.ndarray:
    """ΔB/B0 (ppm) of a sphere at the origin: (Δchi/3)(R/r)^3 (3 cos^2 θ - 1) outside, θ from
    B0; 0 inside (Lorentz-corrected: the macroscopic 2Δchi/3 less the sphere's 2Δchi/3)."""
    p = np.asarray(points_mm, float)
    r = np.linalg.norm(p, axis=-1)
    cos = np.divide(p @ b0_unit(b0), r, out=np.zeros_like(r), where=r > 0)
    outside = delta_chi_ppm / 3.0 * (radius_mm / np.maximum(r, radius_mm)) ** 3 * (3 * cos**2 - 1)
    return np.where(r > radius_mm, outside, 0.0)


def cylinder_offset_ppm(points_mm, radius_mm: float, delta_chi_ppm: float, axis="z", b0="x") -> np.ndarray:
    """ΔB/B0 (ppm) of an infinite cylinder along ``axis`` through the origin, perpendicular
    to B0: (Δchi/2)(R/r)^2 cos 2φ outside, φ from B0 in the cross-section; -Δchi/6 inside."""
    a, b = b0_unit(axis), b0_unit(b0)
    if abs(float(a @ b)) > 1e-9:
        raise ArtefactError(f"axis = {axis!r}: the exact solution is for a cylinder perpendicular to B0")
    p = np.asarray(points_mm, float)
    radial = p - np.outer(p @ a, a).reshape(p.shape)
    r = np.linalg.norm(radial, axis=-1)
    cos = np.divide(radial @ b, r, out=np.zeros_like(r), where=r > 0)
    outside = delta_chi_ppm / 2.0 * (radius_mm / np.maximum(r, radius_mm)) ** 2 * (2 * cos**2 - 1)
    return np.where(r > radius_mm, outside, -delta_chi_ppm / 6.0)
