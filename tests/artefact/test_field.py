"""The dipole-kernel field against the exact sphere and infinite-cylinder solutions, with its
convergence in resolution and padding.

Error measure: |FFT field - exact| over the grid points outside the object at the stated
distance from its surface, divided by the largest exterior offset of the exact solution
(2|Δchi|/3 for the sphere, at its poles; |Δchi|/2 for the cylinder): a relative error of the
offsets that matter, defined also where the exact offset crosses zero (the magic angle).
"""

import numpy as np
import pytest
import trimesh

from sensor.artefact.field import (
    b0_unit,
    cylinder_offset_ppm,
    dipole_kernel,
    field_offset_ppm,
    offset_hz,
    padded_shape,
    sphere_offset_ppm,
)
from sensor.artefact.voxels import Grid, grid_around, occupancy
from sensor.errors import ArtefactError

R_MM, DCHI = 5.0, 10.0
#: The converged resolution of the tests: 20 voxels across the sphere's radius.
CONVERGED_MM = 0.25


def _points(grid):
    axes = [grid.centres(i) for i in range(3)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)


def sphere_errors(h, b0="z", pad=2.0, margin=10.0):
    """(relative error, distance from the surface) at every grid point outside the sphere."""
    mesh = trimesh.creation.icosphere(subdivisions=5, radius=R_MM)
    grid = grid_around(mesh.bounds, margin, h)
    field = field_offset_ppm(DCHI * occupancy(mesh, grid), h, b0, pad_factor=pad)
    p = _points(grid)
    r = np.linalg.norm(p, axis=-1)
    err = np.abs(field - sphere_offset_ppm(p, R_MM, DCHI, b0)) / (2 * DCHI / 3)
    out = r > R_MM
    return err[out], r[out] - R_MM


@pytest.mark.parametrize("b0", ["z", "x"])
def test_sphere_within_2_percent_beyond_one_voxel(b0):
    err, d = sphere_errors(CONVERGED_MM, b0)
    assert err[d >= CONVERGED_MM].max() < 0.02


def test_sphere_oblique_b0_within_2_percent_beyond_1_mm():
    """An oblique B0 converges more slowly: 2 % holds beyond 1 mm (4 voxels); one voxel out
    the error is up to 6 % (measured). Its cross terms b_i b_j k_i k_j / k^2 are odd in k and
    jump at the edge of the sampled spectrum, where the axis terms are even and continuous;
    in a trial, cross terms made periodic (sin(π k h)/(π h) for k) halved the error, but the
    kernel is kept as published."""
    err, d = sphere_errors(CONVERGED_MM, "0,1,1")
    assert err[d >= 1.0].max() < 0.02


def _beyond(errors_and_distances, distance_mm):
    err, d = errors_and_distances
    return err[d >= distance_mm].max()


def test_sphere_converges_with_resolution():
    """At a fixed 1 mm from the surface the error falls as the voxel shrinks."""
    errors = [_beyond(sphere_errors(h, "x"), 1.0) for h in (1.0, 0.5, 0.25)]
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] < 0.3 * errors[0]


def test_sphere_converges_with_padding():
    """Without padding the periodic images spoil the far field (a 10 mm margin here, the
    sensor's default is 30 mm); the default factor 1.5 is within 0.5 % of the peak offset of
    three times the padding, twice the padding within 0.1 %."""
    far = {pad: _beyond(sphere_errors(0.5, "z", pad), 2.0) for pad in (1.0, 1.5, 2.0, 3.0)}
    assert far[1.0] > 2 * far[2.0]
    assert abs(far[1.5] - far[3.0]) < 5e-3 and abs(far[2.0] - far[3.0]) < 1e-3


def test_sphere_inside_is_zero():
    """Lorentz-corrected, the field inside a sphere equals the medium's (offset 0)."""
    h = 0.5
    mesh = trimesh.creation.icosphere(subdivisions=5, radius=R_MM)
    grid = grid_around(mesh.bounds, 10.0, h)
    field = field_offset_ppm(DCHI * occupancy(mesh, grid), h, "y")
    r = np.linalg.norm(_points(grid), axis=-1)
    assert np.abs(field[r < R_MM - 2 * h]).max() < 0.02 * DCHI


@pytest.mark.parametrize("b0", ["z", "x"])
def test_infinite_cylinder_within_2_percent_beyond_one_voxel(b0):
    """A cylinder along y through a grid left periodic along y is infinite."""
    h, radius, length = CONVERGED_MM, 3.0, 4.0
    mesh = trimesh.creation.cylinder(radius=radius, segment=[[0, -length, 0], [0, length, 0]], sections=512)
    n_xz = int(2 * (radius + 8.0) / h)
    grid = Grid((-n_xz * h / 2, -length / 2, -n_xz * h / 2), h, (n_xz, int(length / h), n_xz))
    field = field_offset_ppm(DCHI * occupancy(mesh, grid), h, b0, pad_factor=(2.0, 1.0, 2.0))
    p = _points(grid)
    r = np.hypot(p[..., 0], p[..., 2])
    err = np.abs(field - cylinder_offset_ppm(p, radius, DCHI, "y", b0)) / (DCHI / 2)
    assert err[r >= radius + h].max() < 0.02
    assert np.abs(field[r < radius - 2 * h] + DCHI / 6).max() < 0.02 * DCHI  # inside: -Δchi/6


def test_kernel_is_zero_on_average_over_directions():
    """D = 1/3 - (k·b)^2/k^2 averages to zero over a sphere of k: a uniform sphere of
    susceptibility makes no offset inside it (checked above); here D(0) = 0 and the range."""
    d = dipole_kernel((32, 32, 32), 0.5, "0,0,1")
    assert d[0, 0, 0] == 0.0
    assert d.min() >= -2 / 3 - 1e-6 and d.max() <= 1 / 3 + 1e-6


def test_b0_directions():
    assert np.allclose(b0_unit("y"), [0, 1, 0])
    assert np.allclose(b0_unit("0,3,4"), [0, 0.6, 0.8])
    assert np.allclose(b0_unit([1, 1, 0]), np.array([1, 1, 0]) / np.sqrt(2))
    for bad in ("w", "0,0,0", "1,2", "a,b,c", [np.nan, 0, 1]):
        with pytest.raises(ArtefactError, match="b0_direction"):
            b0_unit(bad)


def test_padding_and_hz():
    assert padded_shape((10, 20, 30), (2.0, 1.0, 1.5))[1] == 20
    with pytest.raises(ArtefactError, match="pad_factor"):
        padded_shape((10, 10, 10), 0.5)
    # 1 ppm at 3 T is 127.7 Hz for protons
    assert offset_hz(1.0, 3.0) == pytest.approx(127.73, abs=0.01)


def test_field_is_quadratic_in_the_b0_direction():
    """D = 1/3 - b_i b_j k_i k_j / k^2 is linear in b b^T: the fields for B0 along
    (x + y)/√2 and (x - y)/√2 add up to those along x and y (the cross terms cancel)."""
    chi = np.random.default_rng(1).normal(size=(12, 10, 8)).astype(np.float32)
    f = {b: field_offset_ppm(chi, 0.5, b) for b in ("x", "y", "1,1,0", "1,-1,0")}
    assert np.allclose(f["1,1,0"] + f["1,-1,0"], f["x"] + f["y"], atol=1e-5)
    assert not np.allclose(f["1,1,0"], f["1,-1,0"], atol=1e-3)
