"""The voxelised sensor: the body's volume, and the fiber and mirror where the design puts them."""

import numpy as np
import pytest

from geometry.export import checked_mesh
from geometry.layout import make_layout
from geometry.params import preset
from sensor.artefact.scene import mirror_box, sensor_scene
from sensor.artefact.susceptibility import FIBER_DIAMETER_MM, SUSCEPTIBILITY_PPM
from sensor.errors import ArtefactError


@pytest.fixture(scope="module")
def scene():
    return sensor_scene(preset("sample-b"), "water", resolution_mm=0.5, margin_mm=6.0)


def test_volume_is_body_plus_fiber_outside_it(scene):
    d = preset("sample-b")
    g = scene.grid
    below = -g.lower_mm[1]  # fiber length below the body (y < 0), to the box's edge
    expected = checked_mesh(d).volume + np.pi * (FIBER_DIAMETER_MM / 2) ** 2 * below
    assert scene.solid.sum() * g.voxel_mm**3 == pytest.approx(expected, rel=0.01)


def test_fiber_and_mirror_sit_where_the_design_puts_them(scene):
    d, g = preset("sample-b"), scene.grid
    lay = make_layout(d)
    zc = d.sheet_thickness_mm / 2
    chi = dict(scene.parts)
    # in the fiber post below its tip: the fiber's PMMA at the mid-plane; the gap above it is water
    fiber = scene.chi_ppm[g.index((0.0, lay.post_top - 1.0, zc))]
    assert fiber == pytest.approx(chi["fiber"], abs=0.2)
    gap = scene.chi_ppm[g.index((0.0, (lay.post_top + lay.output_point[1]) / 2, zc))]
    assert gap == pytest.approx(SUSCEPTIBILITY_PPM["water"], abs=1e-5)
    lo, hi = mirror_box(d)
    assert lo[1] == pytest.approx(lay.output_point[1])
    assert scene.chi_ppm[g.index((lo + hi) / 2)] == pytest.approx(chi["mirror"], abs=0.5)


def test_air_and_other_bodies():
    d = preset("basis")
    s = sensor_scene(d, "air", resolution_mm=1.0, margin_mm=6.0, body_material="aluminium")
    assert s.chi_medium_ppm == 0.36 and dict(s.parts)["body"] == 20.7
    assert s.delta_chi_ppm.max() == pytest.approx(20.7 - 0.36, abs=1e-4)  # voxels wholly in the plates
    with pytest.raises(ArtefactError, match="medium = 'oil'"):
        sensor_scene(d, "oil")
