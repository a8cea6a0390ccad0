"""Exported files re-read with independent readers: ezdxf (DXF), trimesh (STL), CadQuery's
STEP importer, and the beam-model JSON reader."""

import cadquery as cq
import ezdxf
import ezdxf.bbox
import ezdxf.path
import numpy as np
import pytest
import trimesh

from geometry.cad import profile_face
from geometry.errors import GeometryError, InfeasibleDesignError, ParameterError
from geometry.export import LAYER_HOLES, LAYER_OUTLINE, export_design, kerf_path
from geometry.params import make_design, preset
from geometry.topology import build_beam_model, load_model

KERF = 0.8
DESIGNS = {"basis": preset("basis"), "sample-a": preset("sample-a"),
           "steep": make_design(20.0, 30.0, "03-03", name="steep")}
HOLES = {"basis": 1, "sample-a": 2, "steep": 2}


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    out = tmp_path_factory.mktemp("export")
    for d in DESIGNS.values():
        export_design(d, out)
    kerf_dir = out / "kerf"
    kerf_dir.mkdir()
    export_design(DESIGNS["sample-a"], kerf_dir, ["dxf"], kerf_mm=KERF)
    return out


def _polylines(path):
    doc = ezdxf.readfile(path)
    return doc, list(doc.modelspace())


def _area(entity, distance=1e-4):
    """Signed area (mm^2) of a closed polyline, arcs flattened to within ``distance``."""
    xy = np.array([(v.x, v.y) for v in ezdxf.path.make_path(entity).flattening(distance)])
    return 0.5 * float(np.dot(xy[:-1, 0], xy[1:, 1]) - np.dot(xy[:-1, 1], xy[1:, 0]))


@pytest.mark.parametrize("name", DESIGNS)
def test_dxf_closed_polylines_one_outline_and_holes(files, name):
    doc, entities = _polylines(files / f"{name}.dxf")
    assert doc.header["$INSUNITS"] == 4  # millimetres
    assert {e.dxftype() for e in entities} == {"LWPOLYLINE"}
    assert all(e.closed for e in entities)
    layers = [e.dxf.layer for e in entities]
    assert layers.count(LAYER_OUTLINE) == 1
    assert layers.count(LAYER_HOLES) == HOLES[name]
    for e in entities:  # no repeated vertex (zero-length or doubled segments)
        pts = np.array(e.get_points("xy"))
        assert len(np.unique(np.round(pts, 9), axis=0)) == len(pts)
    # no duplicate entity: every contour encloses a different area
    areas = [abs(_area(e)) for e in entities]
    assert len(set(np.round(areas, 6))) == len(areas)


@pytest.mark.parametrize("name", DESIGNS)
def test_dxf_bounding_box_is_the_footprint(files, name):
    d = DESIGNS[name]
    _, entities = _polylines(files / f"{name}.dxf")
    box = ezdxf.bbox.extents(entities)
    assert (box.extmin.x, box.extmax.x) == pytest.approx((-d.width_mm / 2, d.width_mm / 2), abs=1e-9)
    assert (box.extmin.y, box.extmax.y) == pytest.approx((0.0, d.height_mm), abs=1e-9)


@pytest.mark.parametrize("name", DESIGNS)
def test_dxf_area_equals_profile_area(files, name):
    _, entities = _polylines(files / f"{name}.dxf")
    outline = next(e for e in entities if e.dxf.layer == LAYER_OUTLINE)
    holes = [e for e in entities if e.dxf.layer == LAYER_HOLES]
    assert _area(outline) > 0 and all(_area(h) < 0 for h in holes)  # CCW outline, CW holes
    area = _area(outline) + sum(_area(h) for h in holes)
    # straight edges only: the shoelace area is exact; OCC's surface integral agrees to 1e-9
    assert area == pytest.approx(profile_face(DESIGNS[name]).Area(), rel=1e-9)


def test_kerf_offset_changes_area_by_perimeter_times_half_kerf(files):
    _, nominal = _polylines(files / "sample-a.dxf")
    _, cut = _polylines(files / "kerf" / "sample-a.dxf")
    assert len(cut) == len(nominal)  # no gap closed: same outline and holes
    assert all(e.closed for e in cut)
    assert any(b != 0 for e in cut for b in e.get_points("b"))  # convex corners became arcs
    net = lambda ents: sum(_area(e) for e in ents)  # noqa: E731
    perimeter = sum(_length(e) for e in nominal)
    half = KERF / 2
    change = net(cut) - net(nominal)
    corners = sum(len(e) for e in nominal)
    # exact up to the corner terms: + half^2 * turn/2 per convex corner (arc sector), minus
    # half^2 * tan(turn/2) per concave one; |each| <= 3 half^2 for corners under 140 deg turn
    assert abs(change - perimeter * half) <= 3 * half**2 * corners
    assert change == pytest.approx(perimeter * half, rel=0.05)
    # the outline moved out, the holes in
    outline = lambda ents: next(e for e in ents if e.dxf.layer == LAYER_OUTLINE)  # noqa: E731
    box_n, box_c = ezdxf.bbox.extents([outline(nominal)]), ezdxf.bbox.extents([outline(cut)])
    assert box_c.size.x == pytest.approx(box_n.size.x + KERF, abs=1e-6)
    hole_n = sorted(abs(_area(e)) for e in nominal if e.dxf.layer == LAYER_HOLES)
    hole_c = sorted(abs(_area(e)) for e in cut if e.dxf.layer == LAYER_HOLES)
    assert all(c < n for c, n in zip(hole_c, hole_n))


def _length(entity):
    xy = np.array([(v.x, v.y) for v in ezdxf.path.make_path(entity).flattening(1e-4)])
    return float(np.linalg.norm(np.diff(xy, axis=0), axis=1).sum())


def test_kerf_that_closes_a_gap_is_refused():
    d = DESIGNS["sample-a"]  # 1.5 mm between the fiber post and the platform
    with pytest.raises(GeometryError, match=r"kerf = 1.6 mm: a gap narrower than the kerf closes"):
        kerf_path(d, profile_face(d), 1.6)


def test_kerf_that_blunts_a_hinge_is_refused():
    d = DESIGNS["sample-a"].replace(hinge_length_mm=0.8)
    with pytest.raises(GeometryError, match=r"kerf = 1 mm: hinge \d+ would be cut"):
        kerf_path(d, profile_face(d), 1.0)
    with pytest.raises(ParameterError, match="kerf = -0.1"):
        kerf_path(d, profile_face(d), -0.1)


@pytest.mark.parametrize("name", DESIGNS)
def test_stl_watertight_one_body_volume(files, name):
    d = DESIGNS[name]
    mesh = trimesh.load(files / f"{name}.stl")
    assert mesh.is_watertight and mesh.is_winding_consistent
    assert mesh.body_count == 1
    # a prism with g through-holes is a genus-g surface: Euler number 2 - 2 g
    assert mesh.euler_number == 2 - 2 * HOLES[name]
    _, entities = _polylines(files / f"{name}.dxf")
    area = sum(_area(e) for e in entities)  # from the DXF, independent of the mesh
    assert mesh.volume == pytest.approx(area * d.sheet_thickness_mm, rel=1e-3)
    assert mesh.extents == pytest.approx([d.width_mm, d.height_mm, d.sheet_thickness_mm], abs=1e-5)


def test_step_reads_back(files):
    d = DESIGNS["sample-a"]
    shape = cq.importers.importStep(str(files / "sample-a.step")).val()
    assert shape.isValid()
    assert shape.Volume() == pytest.approx(profile_face(d).Area() * d.sheet_thickness_mm, rel=1e-9)


@pytest.mark.parametrize("name", DESIGNS)
def test_json_round_trip(files, name):
    d = DESIGNS[name]
    back, ref = load_model(files / f"{name}.json"), build_beam_model(d)
    np.testing.assert_array_equal(back.nodes, ref.nodes)
    np.testing.assert_array_equal(back.member_nodes, ref.member_nodes)
    np.testing.assert_array_equal(back.thickness_mm, ref.thickness_mm)
    np.testing.assert_array_equal(back.depth_mm, ref.depth_mm)
    np.testing.assert_array_equal(back.hinge_number, ref.hinge_number)
    assert back.member_kind == ref.member_kind and back.supports == ref.supports
    assert (back.input_node, back.output_node) == (ref.input_node, ref.output_node)
    assert (back.E_MPa, back.nu) == (d.material.E_MPa, d.material.nu)


def test_infeasible_design_writes_nothing(tmp_path):
    bad = make_design(40.0, 17.2)  # side links run into the fiber post
    with pytest.raises(InfeasibleDesignError, match="angle_limits"):
        export_design(bad, tmp_path)
    with pytest.raises(GeometryError, match="gap narrower than the kerf"):
        export_design(DESIGNS["sample-a"], tmp_path, kerf_mm=1.6)
    assert list(tmp_path.iterdir()) == []


def test_unknown_format_and_output_folder(tmp_path):
    with pytest.raises(ParameterError, match="format 'igs'"):
        export_design(DESIGNS["basis"], tmp_path, ["dxf", "igs"])
    assert list(tmp_path.iterdir()) == []
    assert export_design(DESIGNS["basis"], tmp_path / "new" / "dir", ["json"]) == [
        tmp_path / "new" / "dir" / "basis.json"]
    (tmp_path / "file").write_text("")
    with pytest.raises(OSError, match="cannot create output folder"):
        export_design(DESIGNS["basis"], tmp_path / "file" / "dir", ["json"])


def test_dxf_and_step_are_byte_identical_when_written_again(tmp_path):
    """The SHA-256 a report records checks a rerun: nothing in the files depends on when,
    how often (OCCT numbers products by a per-process counter) or in which process (ezdxf
    orders classes by string hashes, which change with PYTHONHASHSEED) they were written."""
    import os
    import subprocess
    import sys

    first = export_design(preset("sample-b"), tmp_path / "a", formats=("dxf", "step"))
    script = ("import sys; from geometry.export import export_design; from geometry.params import preset\n"
              "for out in sys.argv[1:]: export_design(preset('sample-b'), out, formats=('dxf', 'step'))")
    for seed in ("1", "2"):  # each process writes twice, seconds after the first write above
        again = [tmp_path / f"{seed}-{k}" for k in (1, 2)]
        subprocess.run([sys.executable, "-c", script, *map(str, again)], check=True,
                       env={**os.environ, "PYTHONHASHSEED": seed})
        for folder in again:
            for path in first:
                assert (folder / path.name).read_bytes() == path.read_bytes(), (seed, path.name)
    step = first[1].read_text()
    assert "FILE_NAME('sample-b','2000-01-01T00:00:00'" in step and "PRODUCT('sample-b','sample-b'" in step
    assert not ezdxf.readfile(first[0]).audit().has_errors
