"""The parameters of one DACM design, its presets (thesis Tables 5 and 7) and TOML I/O.

Units: lengths in mm, moduli in MPa (N/mm^2), angles in degrees.
Hinges are numbered 1-12 as in thesis Figure 48 (reconstructed, DESIGN section 3): going
round the hexagon, 1 = left base, 2 = left knee (lower), 3 = left knee (upper), 4 = left top,
5 = right top, 6 = right knee (upper), 7 = right knee (lower), 8 = right base; on the middle
branch 9 = left knee side, 10 = left platform side, 11 = right platform side, 12 = right knee
side. This numbering makes Table 7's near-equal pairs (1, 8), (4, 5), (9, 12), (10, 11)
mirror images.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import tomli_w

from geometry.atomic import atomic_path
from geometry.errors import GeometryError, ParameterError
from geometry.validation import STEM_RULE, Number, check_fields, is_real, is_stem

N_HINGES = 12
#: Hinges of the basis body (1-8; the proposed body adds the middle branch's 9-12).
BASIS_HINGES = 8

#: Named hinge sets of thesis section 6.2.3: in-plane thickness (mm) of hinges 1-8 and 9-12.
HINGE_SETS: dict[str, tuple[float, float]] = {"05-03": (0.5, 0.3), "03-03": (0.3, 0.3)}

#: Measured hinge thicknesses (mm) of the water-jet-cut specimens, thesis Table 7.
TABLE7_HINGES: dict[str, tuple[float, ...]] = {
    "basis": (0.58, 0.54, 0.54, 0.54, 0.53, 0.53, 0.50, 0.58, 0.30, 0.30, 0.30, 0.30),
    "sample-a": (0.50, 0.48, 0.48, 0.52, 0.52, 0.51, 0.51, 0.50, 0.25, 0.30, 0.30, 0.25),
    "sample-b": (0.52, 0.55, 0.55, 0.53, 0.52, 0.51, 0.51, 0.50, 0.26, 0.30, 0.31, 0.26),
}


@dataclass(frozen=True)
class Material:
    """A linear elastic sheet material: Young's modulus ``E_MPa``, Poisson's ratio ``nu`` and
    the allowable stress ``allowable_stress_MPa`` (the largest peak hinge stress at full
    scale that the stress rule accepts, see :mod:`sensor.mechanics.stress`), and the volume
    magnetic susceptibility ``chi_ppm`` (SI, ppm; None when unknown), which sets the body's
    MRI artefact (:mod:`sensor.artefact`)."""

    name: str
    E_MPa: float
    nu: float
    allowable_stress_MPa: float = math.inf
    chi_ppm: float | None = None


#: Delrin's effective E is the beam model's one parameter calibrated on hardware: the basis
#: specimen as cut (Table 7 hinges, 0.8 mm kerf fillets) at its measured 0.227 mm/N
#: (Table 6), as the thesis calibrated its 2.3 GPa with its own model (section 6.2.4);
#: ``sensor.mechanics.table6.calibrate_modulus`` recomputes it (checked in
#: tests/mechanics/test_table6.py). ABS as printed (FDM), E about 1.8 GPa, the thesis'
#: softer second material (section 6.1.3), is not calibrated.
DELRIN_E_MPA = 1791.2
#: Allowable stresses are half the tensile yield stress, a margin for the creep and fatigue
#: of a sensor loaded for hours: acetal homopolymer (Delrin) reaches 72 MPa in tension
#: (J. M. Margolis (ed.), Engineering Plastics Handbook, McGraw-Hill 2006, Table 5.5), so
#: 36 MPa; moulded impact-grade ABS yields at 42.7 MPa (ASTM D638, guaranteed minimum of the
#: APAC Infrastructure ABS specification; FDM prints are weaker across layers), so 20 MPa.
#: Volume susceptibilities (SI, ppm, room temperature): POM (Delrin) -9.36, measured by
#: Wapler et al., Magnetic properties of materials for MR engineering, micro-MR and beyond,
#: J. Magn. Reson. 242 (2014) 233-242 (as quoted from that paper; its table not re-read
#: here). ABS -9.0 is not a sourced measurement: no published value was found, and it is
#: taken at the value typical of amorphous polymers (PMMA -9.06, POM -9.36, Wapler 2014),
#: so the artefact model cannot tell delrin from ABS. Both are within 0.5 ppm of water
#: (-9.05, Schenck 1996, Med. Phys. 23:815), the reason polymers are nearly artefact-free.
MATERIALS: dict[str, Material] = {
    "delrin": Material("delrin", DELRIN_E_MPA, 0.35, 36.0, chi_ppm=-9.36),
    "abs": Material("abs", 1800.0, 0.35, 20.0, chi_ppm=-9.0),
}


def hinge_set_thicknesses(name: str) -> tuple[float, ...]:
    """Thicknesses (mm) of hinges 1-12 for a named hinge set ("05-03" or "03-03")."""
    if not isinstance(name, str) or name not in HINGE_SETS:
        raise ParameterError(
            f"hinge_set = {name!r}: must be one of {', '.join(sorted(HINGE_SETS))}"
        )
    side, middle = HINGE_SETS[name]
    return (side,) * 8 + (middle,) * 4


@dataclass(frozen=True)
class Design:
    """One DACM design. ``phi2_deg = None`` is the basis (hexagon) body without middle branch.

    Angles: ``phi1_deg`` is the side links' lean from the vertical, ``phi2_deg`` the middle
    links' rise above the horizontal (Figure 48). ``hinge_thickness_mm`` holds hinges 1-12
    (9-12 are unused by the basis body). Defaults are documented in DESIGN section 3 and the
    README; ``hinge_length_mm`` is the one effective parameter calibrated on the basis
    specimen (see ``sensor.mechanics.table6``).

    The part is predicted as cut (DESIGN section 16): ``kerf_mm`` is the cutting jet's width
    (every re-entrant corner, every hinge root included, comes out rounded with radius
    kerf / 2; 0 predicts the drawing, sharp corners), ``root_radius_mm`` a root fillet drawn
    on purpose (the larger of the two is cut).
    """

    phi1_deg: float = 22.0
    phi2_deg: float | None = 17.2
    hinge_set: str = "05-03"
    hinge_thickness_mm: tuple[float, ...] = field(default_factory=lambda: hinge_set_thicknesses("05-03"))
    width_mm: float = 25.0
    height_mm: float = 30.0
    sheet_thickness_mm: float = 5.1
    hinge_length_mm: float = 2.82
    link_width_mm: float = 2.0
    plate_thickness_mm: float = 2.0
    knee_width_mm: float = 2.5
    knee_height_mm: float = 2.0
    platform_width_mm: float = 4.0
    platform_thickness_mm: float = 2.0
    fiber_post_width_mm: float = 3.0
    fiber_clearance_mm: float = 1.2
    material: Material = MATERIALS["delrin"]
    kerf_mm: float = 0.8
    root_radius_mm: float = 0.0
    min_feature_mm: float = 0.25
    name: str = "custom"

    def __post_init__(self):
        validate(self)

    @property
    def is_basis(self) -> bool:
        return self.phi2_deg is None

    @property
    def used_hinges(self) -> tuple[int, ...]:
        """The hinges the body has (Figure 48 numbers): 1-8 for the basis body, 1-12 for the
        proposed one (hinges 9-12 are the middle branch)."""
        return tuple(range(1, (BASIS_HINGES if self.is_basis else N_HINGES) + 1))

    @property
    def used_thickness_mm(self) -> tuple[float, ...]:
        """The in-plane thicknesses (mm) of :attr:`used_hinges`."""
        return self.hinge_thickness_mm[:len(self.used_hinges)]

    def replace(self, **changes) -> Design:
        """A copy with some fields changed (and validated)."""
        return dataclasses.replace(self, **changes)


#: Largest length accepted for any dimension (mm): an MRI bore is about 600 mm across.
MAX_LENGTH_MM = 1000.0
_LENGTH = Number(0.0, MAX_LENGTH_MM, lo_open=True, unit="mm")
_ANGLE = Number(0.0, 90.0, lo_open=True, hi_open=True, unit="deg")
#: Largest cutting kerf (mm): water-jet kerfs are 0.1-1.5 mm; wider ones close every gap.
MAX_KERF_MM = 5.0

#: The rule of every numeric field of :class:`Design` (``phi2_deg`` may also be None).
FIELD_RULES: dict[str, Number] = {
    "phi1_deg": _ANGLE, "phi2_deg": _ANGLE,
    **{name: _LENGTH for name in (
        "width_mm", "height_mm", "sheet_thickness_mm", "hinge_length_mm", "link_width_mm",
        "plate_thickness_mm", "knee_width_mm", "knee_height_mm", "platform_width_mm",
        "platform_thickness_mm", "fiber_post_width_mm", "fiber_clearance_mm", "min_feature_mm")},
    "kerf_mm": Number(0.0, MAX_KERF_MM, unit="mm"),
    "root_radius_mm": Number(0.0, MAX_KERF_MM, unit="mm"),
}
_MATERIAL_RULES = {"E_MPa": Number(0.0, 1e7, lo_open=True, unit="MPa"),
                   "nu": Number(0.0, 0.5, hi_open=True)}


def validate(d: Design) -> None:
    """Check each parameter on its own (types, ranges, the name); raise :class:`ParameterError`.

    Whether the parameters fit together is the job of :mod:`geometry.checks`.
    """
    check_fields(d, FIELD_RULES, ParameterError, skip_none=True)
    if not isinstance(d.hinge_set, str):
        raise ParameterError(f"hinge_set = {d.hinge_set!r}: must be a name such as "
                             f"{', '.join(HINGE_SETS)}")
    t = d.hinge_thickness_mm
    if not isinstance(t, tuple) or len(t) != N_HINGES:
        raise ParameterError(f"hinge_thickness_mm = {t!r}: must give hinges 1-{N_HINGES} "
                             f"as a tuple of {N_HINGES} numbers (mm)")
    for i, v in enumerate(t, start=1):
        _LENGTH.check(f"hinge {i} thickness", v, ParameterError)
    if not isinstance(d.material, Material):
        raise ParameterError(f"material = {d.material!r}: must be a Material")
    check_fields(d.material, _MATERIAL_RULES, ParameterError, prefix="material.")
    allow = d.material.allowable_stress_MPa
    if not (allow == math.inf or (is_real(allow) and allow > 0)):
        raise ParameterError(f"material.allowable_stress_MPa = {allow!r}: must be a positive number "
                             "(MPa; inf for no stress limit)")
    if not is_stem(d.name):
        raise ParameterError(f"name = {d.name!r}: must be {STEM_RULE}")


def cut_note(kerf_mm: float | None) -> str:
    """What a prediction at this kerf (mm) is of: the part as cut (DESIGN section 16) or the drawing."""
    if kerf_mm is None:
        return "beam model as given"
    return f"as cut, kerf {kerf_mm:g} mm" if kerf_mm > 0 else "as drawn (kerf 0: sharp hinge roots)"


def make_design(phi1_deg: float = 22.0, phi2_deg: float | None = 17.2, hinges: str = "05-03",
                **overrides) -> Design:
    """A design from angles and a named hinge set; other fields by keyword."""
    return Design(phi1_deg=phi1_deg, phi2_deg=phi2_deg, hinge_set=hinges,
                  hinge_thickness_mm=hinge_set_thicknesses(hinges), **overrides)


#: Angles of the thesis specimens, Table 5.
_TABLE5 = {"basis": (22.0, None), "sample-a": (21.0, 34.0), "sample-b": (22.0, 17.2)}

PRESETS = tuple(_TABLE5) + tuple(f"{k}-as-cut" for k in _TABLE5)


def preset(name: str) -> Design:
    """A thesis specimen: ``basis``, ``sample-a``, ``sample-b`` (Table 5, hinge set 05-03),
    or the same with ``-as-cut`` (the measured hinge thicknesses of Table 7)."""
    if name not in PRESETS:
        raise ParameterError(f"preset = {name!r}: unknown; choose one of {', '.join(PRESETS)}")
    base = name.removesuffix("-as-cut")
    phi1, phi2 = _TABLE5[base]
    if name.endswith("-as-cut"):
        return Design(phi1_deg=phi1, phi2_deg=phi2, hinge_set="as-cut",
                      hinge_thickness_mm=TABLE7_HINGES[base], name=name)
    return make_design(phi1, phi2, "05-03", name=name)


# --- TOML ------------------------------------------------------------------------------

#: The TOML key that says which body a design is (TOML has no null for ``phi2_deg``).
BODIES = ("basis", "proposed")


def design_to_dict(d: Design) -> dict:
    """A plain dict of the design (TOML/JSON friendly): ``body`` says basis or proposed;
    ``phi2_deg`` is omitted for the basis."""
    out = {"body": "basis" if d.is_basis else "proposed"}
    for f in dataclasses.fields(d):
        value = getattr(d, f.name)
        if f.name == "material":
            out["material"] = {k: v for k, v in dataclasses.asdict(value).items() if v is not None}
        elif f.name == "hinge_thickness_mm":
            out[f.name] = list(value)
        elif value is not None:
            out[f.name] = value
    return out


def _material_from(mat) -> Material:
    """A material from a preset name or a table with name, E_MPa and nu."""
    if isinstance(mat, str):
        if mat not in MATERIALS:
            raise ParameterError(f"material = {mat!r}: unknown; choose one of {', '.join(MATERIALS)} or give a table")
        return MATERIALS[mat]
    if not isinstance(mat, dict):
        raise ParameterError(f"material = {mat!r}: must be a name ({', '.join(MATERIALS)}) or a "
                             "table with name, E_MPa, nu")
    missing = [k for k in ("name", "E_MPa", "nu") if k not in mat]
    if missing:
        raise ParameterError(f"material table lacks {missing[0]!r} (needs name, E_MPa, nu)")
    unknown = sorted(set(mat) - {"name", "E_MPa", "nu", "allowable_stress_MPa", "chi_ppm"})
    if unknown:
        raise ParameterError(f"material table: unknown key(s) {', '.join(unknown)} "
                             "(known: name, E_MPa, nu, allowable_stress_MPa, chi_ppm)")
    for k in ("E_MPa", "nu", "allowable_stress_MPa", "chi_ppm"):
        if k in mat and not (is_real(mat[k]) or (k == "allowable_stress_MPa" and mat[k] == math.inf)):
            raise ParameterError(f"material {k} = {mat[k]!r}: must be a number")
    if not is_stem(mat["name"]):
        raise ParameterError(f"material name = {mat['name']!r}: must be {STEM_RULE}")
    chi = mat.get("chi_ppm")
    return Material(mat["name"], float(mat["E_MPa"]), float(mat["nu"]),
                    float(mat.get("allowable_stress_MPa", math.inf)),
                    None if chi is None else float(chi))


def design_from_dict(data: dict, source: str = "design") -> Design:
    """Build a design from a dict such as ``design_to_dict`` writes (unknown keys are errors).

    ``body`` is "basis" (no ``phi2_deg``) or "proposed" (the default; ``phi2_deg`` is then
    required). A ``phi2_deg`` of None (from Python) also means the basis. ``material`` may
    be a preset name ("delrin", "abs") or a table with name, E_MPa, nu. ``hinge_set`` alone
    sets the thicknesses of a named set.
    """
    if not isinstance(data, dict):
        raise ParameterError(f"{source}: the design must be a table of fields, got {type(data).__name__}")
    data = dict(data)
    body = data.pop("body", None)
    known = {f.name for f in dataclasses.fields(Design)}
    unknown = sorted(set(data) - known)
    if unknown:
        raise ParameterError(f"{source}: unknown key(s) {', '.join(map(str, unknown))}; known keys: "
                             f"body, {', '.join(sorted(known))}")
    if body is not None and body not in BODIES:
        raise ParameterError(f"{source}: body = {body!r}: must be one of {', '.join(BODIES)}")
    if body == "basis" and data.get("phi2_deg") is not None:
        raise ParameterError(f"{source}: phi2_deg = {data['phi2_deg']!r}: the basis body has no "
                             "middle branch (drop phi2_deg or set body = \"proposed\")")
    phi2_missing = "phi2_deg" not in data and body != "basis"
    data.setdefault("phi2_deg", None)
    if "material" in data:
        data["material"] = _material_from(data["material"])
    if "hinge_thickness_mm" in data:
        t = data["hinge_thickness_mm"]
        if not isinstance(t, (list, tuple)) or not all(is_real(v) for v in t):
            raise ParameterError(f"hinge_thickness_mm = {t!r}: must be a list of {N_HINGES} numbers "
                                 "(mm, hinges 1-12)")
        data["hinge_thickness_mm"] = tuple(float(v) for v in t)
    elif "hinge_set" in data:
        data["hinge_thickness_mm"] = hinge_set_thicknesses(data["hinge_set"])
    design = Design(**data)  # every key is a field: checks types and ranges of each
    if phi2_missing:
        raise ParameterError(f"{source}: phi2_deg is missing: the proposed body needs it "
                             "(or set body = \"basis\" for the body without middle branch)")
    return design


def load_design(path: str | Path) -> Design:
    """Read a design from a TOML file (the keys of :class:`Design`, at top level or in [design])."""
    path = Path(path)
    try:
        with path.open("rb") as fh:
            data = tomllib.load(fh)
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise GeometryError(f"{path}: malformed TOML: {exc}") from None
    if "design" in data:
        others = sorted(set(data) - {"design"})
        if others:
            raise ParameterError(f"{path}: key(s) {', '.join(others)} outside the [design] table")
        data = data["design"]
    return design_from_dict(data, source=str(path))


def save_design(design: Design, path: str | Path) -> None:
    """Write a design as TOML (atomically), under comments naming the dacm version and the
    command that wrote it."""
    from geometry.provenance import comment_header

    with atomic_path(path) as tmp:
        tmp.write_bytes((comment_header() + tomli_w.dumps({"design": design_to_dict(design)})).encode())
