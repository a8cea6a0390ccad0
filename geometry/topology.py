"""The planar beam model of a design (pure numpy, no CadQuery) and its JSON schema.

This is what the chain-algorithm solver consumes (thesis section 6.2.1, Figure 46): nodes,
members (each a compliant hinge, a link, or a rigid connection inside a plate or block), the
clamped support, the input port and the output port.

JSON schema ``dacm-beam-model/1`` (units mm, MPa)::

    {"schema": "dacm-beam-model/1",
     "units": {"length": "mm", "modulus": "MPa"},
     "material": {"name": str, "E_MPa": float, "nu": float},
     "nodes": [[x, y], ...],
     "members": [{"kind": "hinge"|"link"|"rigid", "start": int, "end": int,
                  "thickness_mm": float, "depth_mm": float, "hinge": int (0 if none),
                  "name": str}, ...],
     "supports": [{"node": int, "dofs": ["x", "y", "rz"]}, ...],
     "input": {"node": int, "direction": [dx, dy]},
     "output": {"node": int, "direction": [dx, dy]}}

``thickness_mm`` is the in-plane size (bending about z), ``depth_mm`` the out-of-plane size
(the sheet thickness); ``rigid`` members join nodes of one rigid body and have no
compliance. ``direction`` is a unit vector: the input force acts along it, and the output
travel is measured along it.
"""

from __future__ import annotations

import json
import math
import reprlib
from dataclasses import dataclass, field

import numpy as np

from geometry.errors import GeometryError
from geometry.layout import Layout, make_layout, side_members
from geometry.params import MAX_LENGTH_MM, Design
from geometry.validation import Number, is_integer, is_real

SCHEMA = "dacm-beam-model/1"
MEMBER_KINDS = ("hinge", "link", "rigid")
DOF_NAMES = ("x", "y", "rz")

#: Depth, in hinge thicknesses t, at which a hinge is effectively clamped inside each body or
#: link it joins. A strip built into a wider elastic body is not clamped at the body's face:
#: the material round its root turns and shears with it, which adds a root compliance that
#: scales with t (the same elasticity problem at every root, so one constant for all: the
#: hinge's bending length grows by 2 k t). k is the beam model's one calibrated parameter:
#: the least-squares fit of k_out to the continuum FE of 6 presets and 12 sweep cells
#: (tests/mechanics/data/continuum_table.json; refit by tests/mechanics/test_continuum_table.py).
ROOT_DEPTH_PER_THICKNESS = 0.35


@dataclass(frozen=True, eq=False)
class BeamModel:
    """A planar frame: arrays indexed by node (``nodes``) and by member (the rest)."""

    nodes: np.ndarray                 # (n, 2) mm
    member_nodes: np.ndarray          # (m, 2) int: start, end
    member_kind: tuple[str, ...]      # "hinge" | "link" | "rigid"
    thickness_mm: np.ndarray          # (m,) in-plane thickness
    depth_mm: np.ndarray              # (m,) out-of-plane depth
    hinge_number: np.ndarray          # (m,) thesis hinge number, 0 if not a hinge
    member_name: tuple[str, ...]
    supports: tuple[tuple[int, tuple[str, ...]], ...]   # (node, fixed dofs)
    input_node: int
    input_direction: np.ndarray       # (2,) unit vector of the input force
    output_node: int
    output_direction: np.ndarray      # (2,) unit vector of the measured output travel
    E_MPa: float
    nu: float
    material_name: str = "custom"
    labels: dict = field(default_factory=dict)  # optional named nodes, for reports

    @property
    def lengths_mm(self) -> np.ndarray:
        a, b = self.nodes[self.member_nodes[:, 0]], self.nodes[self.member_nodes[:, 1]]
        return np.linalg.norm(b - a, axis=1)

    @property
    def hinge_members(self) -> np.ndarray:
        """Member indices of the hinges, ordered by thesis hinge number."""
        idx = np.flatnonzero(self.hinge_number > 0)
        return idx[np.argsort(self.hinge_number[idx])]


def _key(p) -> tuple[float, float]:
    """A point as a dict key, rounded to 1e-12 mm (so that equal points computed two ways
    meet)."""
    return round(float(p[0]), 12), round(float(p[1]), 12)


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def build_beam_model(design: Design, layout: Layout | None = None, input_guided: bool = True,
                     root_depth_per_thickness: float = ROOT_DEPTH_PER_THICKNESS) -> BeamModel:
    """The beam model of a design, hinges numbered as in Figure 48 (see geometry.params).

    Each hinge member starts ``root_depth_per_thickness`` x its thickness inside the body it
    joins and ends as far inside the link (see :data:`ROOT_DEPTH_PER_THICKNESS`).

    The base plate is clamped. With ``input_guided`` (the default) the input port is guided
    sideways (its x is held), as the thesis' X-stage held it when it pushed the specimens
    (section 6.2.4): without that guide a stiff amplifying body such as sample B can sway
    sideways under its own 1 mm load (a bifurcation the solver reports). Costs a few tens of
    microseconds: sweeps build thousands.
    """
    lay = layout or make_layout(design)
    d = design
    # scalar arithmetic on (x, y) tuples: a sweep builds thousands of models, and numpy's
    # per-call cost on 2-vectors is most of the work (same operations, same results)
    nodes: list[tuple[float, float]] = []
    members: list[tuple] = []  # (kind, start, end, thickness, hinge, name)

    def node(p) -> int:
        nodes.append((float(p[0]), float(p[1])))
        return len(nodes) - 1

    def mirrored(p) -> tuple[float, float]:
        return -float(p[0]), float(p[1])

    base_l, base_r = node(lay.P0), node(mirrored(lay.P0))
    knee_lo_l, knee_hi_l = node(lay.P1), node(lay.P2)
    knee_lo_r, knee_hi_r = node(mirrored(lay.P1)), node(mirrored(lay.P2))
    inp = node(lay.input_point)  # first node of the input body: its reference node
    yc = lay.y_top + d.plate_thickness_mm / 2           # the top plate's centre line
    plate_mid = node((0.0, yc))
    # the plate bends up to the top hinges' effective roots, inside it (see the side chains)
    lean = (lay.P3 - lay.P2) / np.linalg.norm(lay.P3 - lay.P2)
    k = root_depth_per_thickness
    plate_l = node((lay.P3[0] + lean[0] * k * d.hinge_thickness_mm[3], yc))
    plate_r = node((-lay.P3[0] - lean[0] * k * d.hinge_thickness_mm[4], yc))
    top_l, top_r = node(lay.P3), node(mirrored(lay.P3))
    anchor = {_key(nodes[i]): i for i in (base_l, base_r, knee_lo_l, knee_hi_l, knee_lo_r, knee_hi_r,
                                          top_l, top_r)}

    # the top plate bends between the top hinges: two members along its centre line, with
    # rigid offsets up to the input point and down to the hinge roots on its underside;
    # knee blocks and the platform are compact enough to be rigid bodies
    members += [("rigid", inp, plate_mid, d.plate_thickness_mm, 0, "top plate"),
                ("link", plate_mid, plate_l, d.plate_thickness_mm, 0, "top plate left"),
                ("link", plate_mid, plate_r, d.plate_thickness_mm, 0, "top plate right"),
                ("rigid", plate_l, top_l, d.plate_thickness_mm, 0, "top plate"),
                ("rigid", plate_r, top_r, d.plate_thickness_mm, 0, "top plate"),
                ("rigid", knee_lo_l, knee_hi_l, d.knee_width_mm, 0, "left knee"),
                ("rigid", knee_lo_r, knee_hi_r, d.knee_width_mm, 0, "right knee")]
    if d.is_basis:
        out = node(lay.output_point)
        members.append(("rigid", plate_mid, out, d.plate_thickness_mm, 0, "top plate"))
    else:
        k_l, k_r = node(lay.K), node(mirrored(lay.K))
        q_l, q_r = node(lay.Q), node(mirrored(lay.Q))
        out = node(lay.output_point)
        anchor.update({_key(nodes[i]): i for i in (k_l, k_r, q_l, q_r)})
        members += [("rigid", knee_lo_l, k_l, d.knee_width_mm, 0, "left knee"),
                    ("rigid", knee_lo_r, k_r, d.knee_width_mm, 0, "right knee"),
                    ("rigid", q_l, out, d.platform_thickness_mm, 0, "platform"),
                    ("rigid", out, q_r, d.platform_thickness_mm, 0, "platform")]

    lh = d.hinge_length_mm
    for name, (a, b), h1, h2 in side_members(lay):
        t1, t2 = d.hinge_thickness_mm[h1 - 1], d.hinge_thickness_mm[h2 - 1]
        (ax, ay), (bx, by) = a.tolist(), b.tolist()
        length = math.hypot(bx - ax, by - ay)
        ux, uy = (bx - ax) / length, (by - ay) / length
        ia = anchor[_key(a)]
        ib = anchor[_key(b)]
        # elastic roots: each hinge is clamped k t inside the body and inside the link it
        # joins (rigid offsets carry the bodies out to those points); the link's hinge ends
        # are a + l_h u and b - l_h u (member_chain)
        ra, rb = node((ax - ux * k * t1, ay - uy * k * t1)), node((bx + ux * k * t2, by + uy * k * t2))
        j1 = node(((ax + ux * lh) + ux * k * t1, (ay + uy * lh) + uy * k * t1))
        j2 = node(((bx - ux * lh) - ux * k * t2, (by - uy * lh) - uy * k * t2))
        members += [("rigid", ia, ra, t1, 0, f"hinge {h1} root"),
                    ("hinge", ra, j1, t1, h1, f"hinge {h1}"),
                    ("link", j1, j2, d.link_width_mm, 0, f"{name} link"),
                    ("hinge", j2, rb, t2, h2, f"hinge {h2}"),
                    ("rigid", ib, rb, t2, 0, f"hinge {h2} root")]

    kinds, starts, ends, thick, hinge, names = zip(*members)
    m = len(members)
    return BeamModel(
        nodes=np.array(nodes),
        member_nodes=np.column_stack([starts, ends]).astype(int),
        member_kind=tuple(kinds),
        thickness_mm=np.array(thick, dtype=float),
        depth_mm=np.full(m, d.sheet_thickness_mm),
        hinge_number=np.array(hinge, dtype=int),
        member_name=tuple(names),
        supports=((base_l, DOF_NAMES), (base_r, DOF_NAMES)) + (((inp, ("x", "rz")),) if input_guided else ()),
        input_node=inp,
        input_direction=np.array([0.0, -1.0]),
        output_node=out,
        output_direction=np.array([0.0, -1.0]),
        E_MPa=d.material.E_MPa,
        nu=d.material.nu,
        material_name=d.material.name,
        labels={"input": inp, "output": out, "base left": base_l, "base right": base_r},
    )


# --- JSON ------------------------------------------------------------------------------

def model_to_dict(model: BeamModel) -> dict:
    """The beam model as a dict of schema ``dacm-beam-model/1``."""
    return {
        "schema": SCHEMA,
        "units": {"length": "mm", "modulus": "MPa"},
        "material": {"name": model.material_name, "E_MPa": model.E_MPa, "nu": model.nu},
        "nodes": model.nodes.tolist(),
        "members": [
            {"kind": k, "start": int(s), "end": int(e), "thickness_mm": float(t),
             "depth_mm": float(b), "hinge": int(h), "name": n}
            for k, (s, e), t, b, h, n in zip(model.member_kind, model.member_nodes,
                                            model.thickness_mm, model.depth_mm,
                                            model.hinge_number, model.member_name)
        ],
        "supports": [{"node": int(n), "dofs": list(dofs)} for n, dofs in model.supports],
        "input": {"node": model.input_node, "direction": model.input_direction.tolist()},
        "output": {"node": model.output_node, "direction": model.output_direction.tolist()},
    }


_MODEL_KEYS = {"schema", "units", "material", "nodes", "members", "supports", "input", "output"}
_MEMBER_KEYS = {"kind", "start", "end", "thickness_mm", "depth_mm", "hinge", "name"}
_COORD = Number(-MAX_LENGTH_MM, MAX_LENGTH_MM, unit="mm")
_SIZE = Number(0.0, MAX_LENGTH_MM, lo_open=True, unit="mm")
#: Largest model accepted (nodes or members): the designs have a few dozen.
MAX_MODEL_ITEMS = 10_000


def model_from_dict(data: dict, source: str = "beam model") -> BeamModel:
    """Read a beam model from a schema ``dacm-beam-model/1`` dict, checking every field:
    types, finiteness, ranges, node indices (integers, not truncated), no unknown keys.
    Raises :class:`GeometryError` naming the field, the value and the rule."""
    def fail(msg):
        raise GeometryError(f"{source}: {msg}")

    def table(value, name, keys, required):
        if not isinstance(value, dict):
            fail(f"{name} = {reprlib.repr(value)}: must be a JSON object")
        unknown = sorted(set(value) - keys)
        if unknown:
            fail(f"{name}: unknown key(s) {', '.join(map(str, unknown))}; known: {', '.join(sorted(keys))}")
        missing = [k for k in required if k not in value]
        if missing:
            fail(f"{name}: missing {missing[0]!r}")
        return value

    def items(value, name):
        if isinstance(value, list) and not value and name == "supports":
            fail("no support: the model would move as a rigid body")
        if not isinstance(value, list) or not 0 < len(value) <= MAX_MODEL_ITEMS:
            fail(f"{name} = {reprlib.repr(value)}: must be a non-empty list of at most {MAX_MODEL_ITEMS} entries")
        return value

    def number(value, name, rule):
        if not rule.ok(value):
            fail(f"{name} = {reprlib.repr(value)}: must be {rule.rule}")
        return float(value)

    def index(value, name, n):
        if not (is_integer(value) and 0 <= value < n):
            fail(f"{name} = {value!r}: must be an integer node index in [0, {n})")
        return int(value)

    def direction(value, name):
        if not (isinstance(value, list) and len(value) == 2 and all(is_real(v) for v in value)
                and 1e-9 < math.hypot(*value) < math.inf):
            fail(f"{name} = {value!r}: must be a non-zero [dx, dy] of finite numbers")
        return _unit(value)

    table(data, "model", _MODEL_KEYS, sorted(_MODEL_KEYS - {"units"}))
    if data["schema"] != SCHEMA:
        fail(f"schema = {data['schema']!r}: expected {SCHEMA!r}")
    mat = table(data["material"], "material", {"name", "E_MPa", "nu"}, ("E_MPa", "nu"))
    E = number(mat["E_MPa"], "material E_MPa", Number(0.0, 1e7, lo_open=True, unit="MPa"))
    nu = number(mat["nu"], "material nu", Number(0.0, 0.5, hi_open=True))
    nodes = []
    for i, p in enumerate(items(data["nodes"], "nodes")):
        if not (isinstance(p, list) and len(p) == 2):
            fail(f"node {i} = {p!r}: must be [x, y] in mm")
        nodes.append([number(v, f"node {i} {c}", _COORD) for v, c in zip(p, "xy")])
    n = len(nodes)
    if n < 2:
        fail(f"nodes: {n} node; a model needs at least 2")
    members = []
    for i, m in enumerate(items(data["members"], "members")):
        table(m, f"member {i}", _MEMBER_KEYS, ("kind", "start", "end"))
        if m["kind"] not in MEMBER_KINDS:
            fail(f"member {i} kind = {m['kind']!r}: must be one of {', '.join(MEMBER_KINDS)}")
        start, end = (index(m[k], f"member {i} {k}", n) for k in ("start", "end"))
        if math.dist(nodes[start], nodes[end]) < 1e-9:
            fail(f"member {i}: start node {start} and end node {end} are at the same point "
                 "(a member needs a length)")
        size = {}
        for k in ("thickness_mm", "depth_mm"):
            if m["kind"] != "rigid" or k in m:
                if k not in m:
                    fail(f"member {i}: missing {k!r} (a {m['kind']} needs it)")
                size[k] = number(m[k], f"member {i} {k}", _SIZE)
        hinge = m.get("hinge", 0)
        if not (is_integer(hinge) and 0 <= hinge <= 99):
            fail(f"member {i} hinge = {hinge!r}: must be an integer hinge number (0 if none)")
        name = m.get("name", f"member {i}")
        if not isinstance(name, str):
            fail(f"member {i} name = {name!r}: must be a string")
        members.append((m["kind"], start, end, size.get("thickness_mm", 0.0),
                        size.get("depth_mm", 0.0), int(hinge), name))
    supports = []
    for i, sp in enumerate(items(data["supports"], "supports")):
        table(sp, f"support {i}", {"node", "dofs"}, ("node", "dofs"))
        dofs = sp["dofs"]
        if not (isinstance(dofs, list) and dofs and all(isinstance(d, str) and d in DOF_NAMES for d in dofs)):
            fail(f"support {i} dofs = {dofs!r}: must be a non-empty list from {', '.join(DOF_NAMES)}")
        supports.append((index(sp["node"], f"support {i} node", n), tuple(dofs)))
    ports = {}
    for port in ("input", "output"):
        p = table(data[port], port, {"node", "direction"}, ("node", "direction"))
        ports[port] = (index(p["node"], f"{port} node", n), direction(p["direction"], f"{port} direction"))
    kind, start, end, thick, depth, hinge, name = zip(*members)
    return BeamModel(
        nodes=np.array(nodes, dtype=float),
        member_nodes=np.array([start, end], dtype=int).T.reshape(-1, 2),
        member_kind=kind,
        thickness_mm=np.array(thick),
        depth_mm=np.array(depth),
        hinge_number=np.array(hinge, dtype=int),
        member_name=name,
        supports=tuple(supports),
        input_node=ports["input"][0],
        input_direction=ports["input"][1],
        output_node=ports["output"][0],
        output_direction=ports["output"][1],
        E_MPa=E,
        nu=nu,
        material_name=str(mat.get("name", "custom")),
    )


def model_to_json(model: BeamModel) -> str:
    return json.dumps(model_to_dict(model), indent=1)


def load_model(path) -> BeamModel:
    """Read a beam-model JSON file."""
    try:
        with open(path, "rb") as fh:
            data = json.load(fh)
    except (json.JSONDecodeError, UnicodeDecodeError, RecursionError) as exc:
        raise GeometryError(f"{path}: malformed JSON: {str(exc).splitlines()[0][:200]}") from None
    return model_from_dict(data, source=str(path))
