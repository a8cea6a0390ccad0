"""Voxel fractions of closed meshes against their exact volumes and column lengths."""

import numpy as np
import pytest
import trimesh

from sensor.artefact.voxels import Grid, grid_around, occupancy
from sensor.errors import ArtefactError


def test_box_aligned_with_the_voxels_is_exact():
    box = trimesh.creation.box(bounds=[[0.0, 0.0, 0.0], [2.0, 1.0, 1.5]])
    f = occupancy(box, Grid((-1.0, -1.0, -1.0), 0.5, (8, 6, 7)))
    assert set(np.unique(f)) <= {0.0, 1.0}
    assert f.sum() * 0.5**3 == pytest.approx(3.0, rel=1e-6)


def test_z_fractions_are_exact():
    """A box whose z faces cut voxels: the z partial volume is the exact length inside."""
    box = trimesh.creation.box(bounds=[[0.0, 0.0, 0.13], [1.0, 1.0, 0.87]])
    f = occupancy(box, Grid((0.0, 0.0, 0.0), 0.25, (4, 4, 4)))
    assert f[0, 0] == pytest.approx([0.48, 1.0, 1.0, 0.48], abs=1e-5)


@pytest.mark.parametrize("h", [1.0, 0.5, 0.25])
def test_sphere_volume(h):
    """The fractions add up to the mesh's volume within 0.5 % (1 mm voxels) to 0.05 %."""
    mesh = trimesh.creation.icosphere(subdivisions=5, radius=5.0)
    f = occupancy(mesh, grid_around(mesh.bounds, 1.0, h))
    assert 0.0 <= f.min() and f.max() <= 1.0
    assert f.sum() * h**3 == pytest.approx(mesh.volume, rel=0.005 * h**2)


def test_grid_around_and_blocks():
    g = grid_around(np.array([[0.0, 0.0, 0.0], [10.0, 5.0, 1.0]]), 2.0, 0.5, multiple=4)
    assert all(n % 4 == 0 for n in g.shape)
    assert g.lower_mm[0] <= -2.0 and g.edges(0)[-1] >= 12.0
    assert g.coarsened(4).voxel_mm == 2.0 and g.coarsened(4).shape[0] * 4 == g.shape[0]
    assert g.index((5.0, 2.5, 0.5)) == tuple(int(v) for v in (np.array([5.0, 2.5, 0.5]) - g.lower_mm) // 0.5)


def test_open_mesh_is_refused():
    mesh = trimesh.creation.box()
    mesh.update_faces(np.arange(len(mesh.faces) - 1))
    with pytest.raises(ArtefactError, match="watertight"):
        occupancy(mesh, Grid((-1.0, -1.0, -1.0), 0.5, (4, 4, 4)))
