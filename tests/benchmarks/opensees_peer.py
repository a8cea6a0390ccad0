"""The peer solver of the solve benchmark: OpenSeesPy on a dacm beam model JSON
(``dacm export --beam-model``, schema dacm-beam-model/2).

Each compliant member (hinge, link) is ``n_elements`` co-rotational force-based beam
elements with an elastic section that includes shear (G = E / 2(1 + nu), shear factor 5/6
of a rectangle: the terms of thesis eqs 80-82), three Gauss-Lobatto points each; a member
with a thickness ``profile`` (the hinges as cut: neck and root fillets, t linear between
stations) has the section of its thickness there at each point. Rigid
members are co-rotational elastic beams RIGID_FACTOR times stiffer than the material (a
rigid link constraint in OpenSees is linear in the rotation, which would be wrong at the
bodies' rotations). The input force is a dead load along the input direction; the output
port is driven to the target travel in ``steps`` equal displacement-control increments,
each a Newton iteration to a displacement increment below 1e-12 mm. Strain energy is the
sum over the elements of half their basic forces times basic deformations (exact for an
elastic element); the stiffened rigid members' share (about 1e-4 of the total) is left out,
as dacm's rigid bodies store none. Units: mm, N, MPa, mJ.
"""

from __future__ import annotations

import math

import numpy as np
import openseespy.opensees as ops

RIGID_FACTOR = 1e4
LOBATTO_POINTS = 3
LOBATTO_X, LOBATTO_W = (0.0, 0.5, 1.0), (1 / 6, 4 / 6, 1 / 6)
DOF = {"x": 1, "y": 2, "rz": 3}


def _axis(direction) -> tuple[int, float]:
    """The OpenSees dof (1 or 2) and sign of an axis-aligned unit direction."""
    dx, dy = direction
    if abs(dy) < 1e-12 and abs(abs(dx) - 1) < 1e-12:
        return 1, math.copysign(1.0, dx)
    if abs(dx) < 1e-12 and abs(abs(dy) - 1) < 1e-12:
        return 2, math.copysign(1.0, dy)
    raise ValueError(f"output direction {direction}: the displacement control needs an axis-aligned port")


def _centroid_offset(member: dict, fraction: float) -> float:
    """The sections' centroid offset (mm, to the left of the chord: the profile's third
    column) at a fraction of a member's length; 0 without one."""
    profile = member.get("profile")
    if not profile or len(profile[0]) < 3:
        return 0.0
    s, _, e = zip(*profile)
    return float(np.interp(fraction * s[-1], s, e))


def build(data: dict, n_elements: int) -> list[int]:
    """The OpenSees domain of the beam model; returns the tags of the compliant elements."""
    ops.wipe()
    ops.model("basic", "-ndm", 2, "-ndf", 3)
    nodes = data["nodes"]
    for i, (x, y) in enumerate(nodes):
        ops.node(i + 1, float(x), float(y))
    for s in data["supports"]:
        ops.fix(s["node"] + 1, *(int(d in s["dofs"]) for d in DOF))
    E, nu = data["material"]["E_MPa"], data["material"]["nu"]
    G = E / (2 * (1 + nu))
    ops.geomTransf("Corotational", 1)
    next_node, next_elem, next_section, compliant = len(nodes) + 1, 1, 1, []
    for k, m in enumerate(data["members"]):
        t, b = m["thickness_mm"], m["depth_mm"]
        A, I = t * b, b * t**3 / 12
        a, z = m["start"] + 1, m["end"] + 1
        if m["kind"] == "rigid":
            ops.element("elasticBeamColumn", next_elem, a, z, A, E * RIGID_FACTOR, I, 1)
            next_elem += 1
            continue
        (xa, ya), (xz, yz) = nodes[m["start"]], nodes[m["end"]]
        length = float(np.hypot(xz - xa, yz - ya))
        chain, points = [], []
        for j in range(n_elements + 1):
            off = _centroid_offset(m, j / n_elements)  # the nodes on the sections' centroid line
            end = a if j == 0 else z if j == n_elements else None
            if end is not None and off == 0.0:
                chain.append(end)
                points.append((xa, ya) if j == 0 else (xz, yz))
                continue
            points.append((xa + (xz - xa) * j / n_elements - off * (yz - ya) / length,
                           ya + (yz - ya) * j / n_elements + off * (xz - xa) / length))
            ops.node(next_node, *points[-1])
            if end is not None:  # an end section off its node (a leaning root): a rigid arm
                ops.element("elasticBeamColumn", next_elem, end, next_node, A, E * RIGID_FACTOR, I, 1)
                next_elem += 1
            chain.append(next_node)
            next_node += 1
        for e, (i, j) in enumerate(zip(chain, chain[1:])):
            tag = next_elem
            # an element inclined off the chord is longer than its share of it: its moduli
            # scale by that ratio, so that its compliance is the share's (as the frame reference)
            stretch = float(np.hypot(*np.subtract(points[e + 1], points[e]))) / (length / n_elements)
            if "profile" in m:  # the section at each Lobatto point of the element
                s_, t_ = zip(*[p[:2] for p in m["profile"]])
                secs = []
                for x in LOBATTO_X:
                    tx = float(np.interp((e + x) / n_elements * s_[-1], s_, t_))
                    ops.section("Elastic", next_section, E * stretch, tx * b, b * tx**3 / 12, G * stretch, 5 / 6)
                    secs.append(next_section)
                    next_section += 1
                ops.beamIntegration("UserDefined", tag, LOBATTO_POINTS, *secs, *LOBATTO_X, *LOBATTO_W)
            else:
                ops.section("Elastic", next_section, E, A, I, G, 5 / 6)
                ops.beamIntegration("Lobatto", tag, next_section, LOBATTO_POINTS)
                next_section += 1
            ops.element("forceBeamColumn", tag, i, j, 1, tag)
            compliant.append(tag)
            next_elem += 1
    return compliant


def solve(data: dict, n_elements: int, steps: int, target_output_mm: float = 1.0) -> dict:
    """Drive the output port to ``target_output_mm``; amplification, k_out (N/mm) and strain
    energy (mJ) as dacm's SolveResult defines them. Raises RuntimeError if a step fails."""
    compliant = build(data, n_elements)
    node_in, node_out = data["input"]["node"] + 1, data["output"]["node"] + 1
    din, dout = data["input"]["direction"], data["output"]["direction"]
    dof, sign = _axis(dout)
    ops.timeSeries("Linear", 1)
    ops.pattern("Plain", 1, 1)
    ops.load(node_in, float(din[0]), float(din[1]), 0.0)
    ops.constraints("Plain")
    ops.numberer("RCM")
    ops.system("BandGeneral")
    ops.test("NormDispIncr", 1e-12, 50)
    ops.algorithm("Newton")
    ops.integrator("DisplacementControl", node_out, dof, sign * target_output_mm / steps)
    ops.analysis("Static")
    if ops.analyze(steps) != 0:
        raise RuntimeError(f"OpenSees did not converge ({n_elements} elements per member, {steps} steps)")
    u_in = sum(c * ops.nodeDisp(node_in, i + 1) for i, c in enumerate(din))
    u_out = sum(c * ops.nodeDisp(node_out, i + 1) for i, c in enumerate(dout))
    force = ops.getLoadFactor(1)
    energy = sum(0.5 * sum(q * v for q, v in zip(ops.eleResponse(e, "basicForces"),
                                                 ops.eleResponse(e, "basicDeformation")))
                 for e in compliant)
    return {"amplification": u_out / u_in, "k_out_N_per_mm": force / u_out, "strain_energy_mJ": energy}
