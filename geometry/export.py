"""Files for making and solving a design (DESIGN section 9): DXF for the water-jet, STL and
STEP of the body, and the JSON beam model.

:func:`export_design` checks the design's feasibility (:func:`geometry.checks.assert_feasible`),
builds and checks every file's content, and only then writes them through
:func:`geometry.atomic.atomic_path`, so a failed export leaves no file behind. Lengths in mm.
"""

from __future__ import annotations

import contextlib
import errno
import os
from collections.abc import Iterable
from pathlib import Path

import cadquery as cq
import ezdxf
import numpy as np
import trimesh

from geometry.atomic import atomic_path, cut_short_errno
from geometry.cad import (
    extrude,
    face_loops,
    hinge_neck_mm,
    hole_count,
    offset_face,
    profile_face,
)
from geometry.checks import assert_feasible
from geometry.errors import GeometryError, ParameterError
from geometry.layout import make_layout, make_parts
from geometry.params import FIELD_RULES, Design
from geometry.topology import build_beam_model, model_to_json

FORMATS = ("dxf", "stl", "step", "json")

#: DXF layers by role: the outer contour and the through-holes (cut first, inside out).
LAYER_OUTLINE, LAYER_HOLES = "OUTLINE", "HOLES"

#: Relative volume tolerance of the STL check: the profile has only straight edges, so the
#: tessellation is exact up to rounding; 0.1 % leaves room for arcs in a future profile.
STL_VOLUME_RTOL = 1e-3

#: Tolerance (mm) on a hinge neck left by the simulated cut: offsets of straight edges are
#: exact, so any larger change means a notch was filled.
NECK_TOL_MM = 1e-3


def kerf_path(design: Design, face: cq.Face, kerf_mm: float) -> cq.Face:
    """The jet's centre path for a cut of width ``kerf_mm``: the profile grown by half the
    kerf (outline out, holes in), convex corners rounded.

    Checks that what the jet leaves (the path shrunk back by half the kerf) keeps every gap
    open (same number of holes) and every hinge neck at its drawn thickness and at least
    ``min_feature_mm``; raises :class:`GeometryError` naming the kerf otherwise.
    """
    FIELD_RULES["kerf_mm"].check("kerf", kerf_mm, ParameterError)
    half = kerf_mm / 2.0
    path = offset_face(face, half)
    holes = hole_count(face)
    if hole_count(path) != holes:
        raise GeometryError(f"kerf = {kerf_mm:g} mm: a gap narrower than the kerf closes "
                            f"(the profile's {holes} holes become {hole_count(path)})")
    cut = offset_face(path, -half)
    if hole_count(cut) != holes:
        raise GeometryError(f"kerf = {kerf_mm:g} mm: the cut part would have {hole_count(cut)} "
                            f"holes instead of {holes}")
    for part in make_parts(make_layout(design)):
        if part.kind != "hinge":
            continue
        neck = hinge_neck_mm(cut, part)
        if neck < design.min_feature_mm - NECK_TOL_MM or abs(neck - part.width) > NECK_TOL_MM:
            raise GeometryError(
                f"kerf = {kerf_mm:g} mm: hinge {part.hinge} would be cut {neck:.3f} mm thick "
                f"instead of {part.width:g} mm (min_feature_mm = {design.min_feature_mm:g}): the "
                f"jet's corner rounding reaches the middle of the neck; hinge_length_mm = "
                f"{design.hinge_length_mm:g} is too short for this kerf")
    return path


#: The date in every STEP header (ezdxf's fixed metadata writes the same date into the DXF):
#: a file depends only on its design, so its SHA-256 checks a rerun.
FIXED_TIMESTAMP = "2000-01-01T00:00:00"


@contextlib.contextmanager
def _fixed_dxf_metadata():
    """ezdxf's fixed metadata while a document is made and saved: creation and update dates
    2000-01-01, constant $VERSIONGUID and $FINGERPRINTGUID, no time in its CREATED_BY marker."""
    fixed = ezdxf.options.write_fixed_meta_data_for_testing
    ezdxf.options.write_fixed_meta_data_for_testing = True
    try:
        yield
    finally:
        ezdxf.options.write_fixed_meta_data_for_testing = fixed


def dxf_document(face: cq.Face) -> ezdxf.document.Drawing:
    """A DXF (R2010, $INSUNITS = mm) with the outline on layer OUTLINE and each hole on layer
    HOLES, each one closed LWPOLYLINE of lines and arcs (bulges), 1:1 in mm."""
    with _fixed_dxf_metadata():
        doc = ezdxf.new("R2010", units=ezdxf.units.MM)
    doc.layers.add(LAYER_OUTLINE, color=7)
    doc.layers.add(LAYER_HOLES, color=1)
    msp = doc.modelspace()
    outline, holes = face_loops(face)
    for loop, layer in [(outline, LAYER_OUTLINE)] + [(h, LAYER_HOLES) for h in holes]:
        msp.add_lwpolyline([tuple(v) for v in loop], format="xyb", close=True,
                           dxfattribs={"layer": layer})
    return doc


def checked_mesh(design: Design, face: cq.Face | None = None) -> trimesh.Trimesh:
    """The body as a triangle mesh, checked: watertight, one body, and volume equal to
    profile area x sheet thickness within :data:`STL_VOLUME_RTOL`."""
    face = face or profile_face(design)
    solid = extrude(face, design.sheet_thickness_mm)
    vertices, triangles = solid.tessellate(1e-3, 0.1)
    mesh = trimesh.Trimesh(np.array([v.toTuple() for v in vertices]), np.array(triangles),
                           process=True)
    expected = face.Area() * design.sheet_thickness_mm
    if not mesh.is_watertight:
        raise GeometryError(f"STL of {design.name!r}: mesh is not watertight")
    if mesh.body_count != 1:
        raise GeometryError(f"STL of {design.name!r}: mesh has {mesh.body_count} bodies, expected 1")
    if abs(mesh.volume - expected) > STL_VOLUME_RTOL * expected:
        raise GeometryError(f"STL of {design.name!r}: volume {mesh.volume:.3f} mm^3 differs from "
                            f"area x thickness = {expected:.3f} mm^3 by more than 0.1 %")
    return mesh


def _save_dxf(doc: ezdxf.document.Drawing, tmp: Path) -> None:
    """Save with fixed metadata and the CLASSES section in a fixed order: ezdxf adds the
    classes of the entity types in use from a set, in an order that changes with Python's
    string hashing from one process to the next; here ezdxf's required classes come first in
    its order, then the others by name."""
    from ezdxf.sections.classes import REQ_R2004, REQUIRED_CLASSES

    with _fixed_dxf_metadata():
        doc.classes.add_required_classes(doc.dxfversion)
        rank = {name: i for i, name in enumerate(REQUIRED_CLASSES.get(doc.dxfversion, REQ_R2004))}
        doc.classes.classes = dict(sorted(doc.classes.classes.items(),
                                          key=lambda item: (rank.get(item[0][0], len(rank)), item[0])))
        doc.saveas(tmp)


def _save_stl(mesh: trimesh.Trimesh, tmp: Path) -> None:
    mesh.export(tmp, file_type="stl")


def _save_step(named: tuple[str, cq.Solid], tmp: Path) -> None:
    """An AP214 STEP file in mm (as CadQuery's ``exportStep``) that depends only on the solid:
    the header's FILE_NAME is the design's name at :data:`FIXED_TIMESTAMP`, and the product
    is named after the design (OCCT numbers it by a per-process counter otherwise)."""
    from OCP.APIHeaderSection import APIHeaderSection_MakeHeader
    from OCP.IFSelect import IFSelect_ReturnStatus
    from OCP.Interface import Interface_Static
    from OCP.StepBasic import StepBasic_Product
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer
    from OCP.TCollection import TCollection_HAsciiString

    name, solid = named
    writer = STEPControl_Writer()
    Interface_Static.SetIVal_s("write.surfacecurve.mode", 1)
    Interface_Static.SetIVal_s("write.precision.mode", 0)
    Interface_Static.SetCVal_s("xstep.cascade.unit", "MM")
    Interface_Static.SetCVal_s("write.step.unit", "MM")
    writer.Transfer(solid.wrapped, STEPControl_AsIs)
    model = writer.Model()
    for k in range(1, model.NbEntities() + 1):
        entity = model.Value(k)
        if isinstance(entity, StepBasic_Product):
            entity.SetId(TCollection_HAsciiString(name))
            entity.SetName(TCollection_HAsciiString(name))
    header = APIHeaderSection_MakeHeader(model)
    header.SetName(TCollection_HAsciiString(name))
    header.SetTimeStamp(TCollection_HAsciiString(FIXED_TIMESTAMP))
    if writer.Write(str(tmp)) != IFSelect_ReturnStatus.IFSelect_RetDone:
        # OCCT says only that it failed: the file's end tells why (size limit, full disk)
        code = cut_short_errno(Path(tmp)) if Path(tmp).exists() else errno.EIO
        raise OSError(code, os.strerror(code))


def _save_text(text: str, tmp: Path) -> None:
    tmp.write_text(text)


def export_design(design: Design, out_dir: str | Path, formats: Iterable[str] = FORMATS,
                  kerf_mm: float | None = None) -> list[Path]:
    """Write the chosen formats as ``<out_dir>/<design.name>.<ext>`` (the folder is created
    if needed); return the paths.

    ``dxf``: the water-jet profile (with ``kerf_mm``: the jet's centre path, see
    :func:`kerf_path`); ``stl`` and ``step``: the extruded body; ``json``: the beam model
    (schema ``dacm-beam-model/2``, see :mod:`geometry.topology`). The design's feasibility
    is checked and every file is built and checked before the first is written, so a bad
    design or kerf writes nothing (not even the folder).
    """
    formats = list(dict.fromkeys(formats))
    unknown = [f for f in formats if f not in FORMATS]
    if unknown:
        raise ParameterError(f"format {unknown[0]!r}: must be one of {', '.join(FORMATS)}")
    assert_feasible(design)
    face = profile_face(design)
    built = {}
    if "dxf" in formats:
        cut = face if kerf_mm is None else kerf_path(design, face, kerf_mm)
        built["dxf"] = (_save_dxf, dxf_document(cut))
    if "stl" in formats:
        built["stl"] = (_save_stl, checked_mesh(design, face))
    if "step" in formats:
        built["step"] = (_save_step, (design.name, extrude(face, design.sheet_thickness_mm)))
    if "json" in formats:
        built["json"] = (_save_text, model_to_json(build_beam_model(design)) + "\n")
    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OSError(f"cannot create output folder {out}: {exc.strerror}") from None
    written = []
    for fmt in formats:
        save, content = built[fmt]
        path = out / f"{design.name}.{fmt}"
        with atomic_path(path) as tmp:
            save(content, tmp)
        written.append(path)
    return written
