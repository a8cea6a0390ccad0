"""The CadQuery profile agrees with the parameters: hinge necks, link angles, holes, symmetry.

Tolerances: the profile is a boolean union of straight-edged polygons, exact up to OCC's
modelling tolerance (1e-7 mm), so lengths are checked to 1e-6 mm and angles to 1e-6 deg.
"""

import math

import cadquery as cq
import numpy as np
import pytest

from geometry.cad import (
    chord_length_mm,
    face_loops,
    flatten_loop,
    hinge_neck_mm,
    hole_count,
    lean_from_vertical_deg,
    link_direction,
    offset_face,
    perimeter_mm,
    profile_face,
    rise_above_horizontal_deg,
)
from geometry.errors import GeometryError
from geometry.layout import make_layout, make_parts
from geometry.params import make_design, preset

NAMES = ("basis", "sample-a", "sample-b-as-cut", "proposed-40")


def _design(name):
    # a steep middle branch and the 03-03 hinge set, besides the thesis specimens
    return make_design(20.0, 40.0, "03-03", name=name) if name == "proposed-40" else preset(name)


@pytest.fixture(scope="module")
def profiles():
    out = {}
    for name in NAMES:
        d = _design(name)
        lay = make_layout(d)
        out[name] = (d, make_parts(lay), profile_face(d, lay))
    return out


@pytest.mark.parametrize("name", NAMES)
def test_hinge_necks_match_parameters(profiles, name):
    d, parts, face = profiles[name]
    hinges = [p for p in parts if p.kind == "hinge"]
    assert sorted(p.hinge for p in hinges) == list(d.used_hinges)
    for p in hinges:
        # the as-cut preset has 12 different thicknesses (Table 7): a neck in the wrong place
        # or with the wrong number would measure another hinge's value
        assert hinge_neck_mm(face, p) == pytest.approx(d.hinge_thickness_mm[p.hinge - 1], abs=1e-6)


@pytest.mark.parametrize("name", NAMES)
def test_link_angles_match_parameters(profiles, name):
    d, parts, face = profiles[name]
    links = [p for p in parts if p.kind == "link"]
    assert len(links) == (4 if d.is_basis else 6)
    for p in links:
        v = link_direction(face, p)
        if "middle" in p.name:
            assert rise_above_horizontal_deg(v) == pytest.approx(d.phi2_deg, abs=1e-6)
        else:
            assert lean_from_vertical_deg(v) == pytest.approx(d.phi1_deg, abs=1e-6)
        # the measured width across the link (perpendicular chord) is the link width
        a, b = p.axis
        mid = (a + b) / 2
        assert chord_length_mm(face, mid, (-v[1], v[0])) == pytest.approx(d.link_width_mm, abs=1e-6)


@pytest.mark.parametrize("name", NAMES)
def test_holes_and_mirror_symmetry(profiles, name):
    d, _, face = profiles[name]
    # basis: the hexagon's inside; proposed: the middle branch splits it in two (the fiber
    # post, rooted in the base, stays clear of the platform)
    assert hole_count(face) == (1 if d.is_basis else 2)
    if name.endswith("as-cut"):
        return  # measured hinges differ left to right
    mirrored = face.mirror("YZ")
    assert face.cut(mirrored).Area() == pytest.approx(0.0, abs=1e-6)
    assert mirrored.Area() == pytest.approx(face.Area(), rel=1e-12)


def test_loops_describe_the_face(profiles):
    """The outline/hole loops (written to the DXF) enclose the face's own area."""
    for d, _, face in profiles.values():
        for f in (face, offset_face(face, 0.4)):  # straight edges only, then with arcs
            outline, holes = face_loops(f)

            def area(xy):
                x, y = xy[:, 0], xy[:, 1]
                return 0.5 * (np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))

            a_out = area(flatten_loop(outline, 0.2))
            a_holes = [area(flatten_loop(h, 0.2)) for h in holes]
            assert a_out > 0 and all(a < 0 for a in a_holes)
            # chords of 0.2 deg arcs of radius 0.4 mm miss r^2 (t - sin t)/2 < 1e-9 mm^2 per
            # step; OCC integrates faces bounded by arcs numerically (about 1e-8 relative)
            assert a_out + sum(a_holes) == pytest.approx(f.Area(), rel=1e-7)


def test_offset_grows_by_perimeter_times_distance(profiles):
    """Area change of an offset by delta is P delta plus corner terms of order delta^2."""
    d, _, face = profiles["sample-a"]
    delta = 0.2
    grown = offset_face(face, delta)
    n_corners = len(face.Vertices())
    change = grown.Area() - face.Area()
    # each corner adds at most delta^2 * max(pi/2, tan(theta/2)) (arc sector or mitre
    # overlap); 3 delta^2 per corner bounds both for corners sharper than 20 deg
    assert abs(change - perimeter_mm(face) * delta) <= 3 * delta**2 * n_corners
    assert hole_count(grown) == hole_count(face)
    shrunk_back = offset_face(grown, -delta)  # a closing: only concave corners are filled
    assert face.Area() <= shrunk_back.Area() <= face.Area() + delta**2 * n_corners


def test_chord_outside_profile_is_an_error(profiles):
    _, _, face = profiles["basis"]
    with pytest.raises(GeometryError, match="not inside the profile"):
        chord_length_mm(face, (0.0, 100.0), (1.0, 0.0))


def test_split_by_offset_is_an_error():
    # two squares joined by a 0.2 mm neck: shrinking by 0.2 mm cuts the neck
    parts = [cq.Face.makeFromWires(cq.Wire.makePolygon([cq.Vector(*p, 0) for p in poly], close=True))
             for poly in ([(0, 0), (2, 0), (2, 2), (0, 2)], [(2, 0.9), (4, 0.9), (4, 1.1), (2, 1.1)],
                          [(4, 0), (6, 0), (6, 2), (4, 2)])]
    face = parts[0].fuse(parts[1], parts[2]).clean().Faces()[0]
    with pytest.raises(GeometryError, match="separate pieces"):
        offset_face(face, -0.2)


def test_extrusion_volume(profiles):
    from geometry.cad import extrude

    d, _, face = profiles["sample-a"]
    solid = extrude(face, d.sheet_thickness_mm)
    assert solid.isValid()
    assert solid.Volume() == pytest.approx(face.Area() * d.sheet_thickness_mm, rel=1e-9)
    assert math.isclose(solid.BoundingBox().zlen, d.sheet_thickness_mm, rel_tol=1e-9)
