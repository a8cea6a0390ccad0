"""Which 2D bound (plane stress or plane strain) a 5.1 mm delrin sheet's hinge is closer
to: one hinge (0.5 x 2.82 mm neck) between two blocks, the far block pushed sideways
without turning (the S-bending of a DACM hinge), solved in 3D (quadratic tetrahedra, half
the depth by symmetry) and in 2D (quadratic triangles) in both bounds, on meshes of the
same size. Prints one JSON object: stiffnesses (N/mm) and where 3D lies between the bounds
(0 = plane stress, 1 = plane strain). About a minute.

    python tests/benchmarks/plane_bound_3d.py [--size 0.12]
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
import scipy.sparse.linalg as spla
from skfem import (
    Basis,
    ElementTetP2,
    ElementTriP2,
    ElementVector,
    MeshTet,
    MeshTri,
    asm,
)
from skfem.models.elasticity import lame_parameters, linear_elasticity

from sensor.mechanics.continuum import gmsh_session, mesh_elements

E, NU, T, L, DEPTH, BLOCK = 2300.0, 0.35, 0.5, 2.82, 5.1, 3.0


def mesh(dim: int, size: float):
    """Block - neck - block along x (neck from x = 0 to L, |y| < T / 2), blocks BLOCK wide;
    3D: extruded to DEPTH / 2 (z = 0 is the symmetry plane)."""
    with gmsh_session("plane-bound") as gmsh:
        occ = gmsh.model.occ
        if dim == 2:
            parts = [occ.addRectangle(-BLOCK, -BLOCK / 2, 0, BLOCK, BLOCK), occ.addRectangle(-0.1, -T / 2, 0, L + 0.2, T),
                     occ.addRectangle(L, -BLOCK / 2, 0, BLOCK, BLOCK)]
        else:
            h = DEPTH / 2
            parts = [occ.addBox(-BLOCK, -BLOCK / 2, 0, BLOCK, BLOCK, h), occ.addBox(-0.1, -T / 2, 0, L + 0.2, T, h),
                     occ.addBox(L, -BLOCK / 2, 0, BLOCK, BLOCK, h)]
        occ.fuse([(dim, parts[0])], [(dim, p) for p in parts[1:]])
        occ.synchronize()
        gmsh.model.mesh.setSizeCallback(
            lambda d, tag, x, y, z, lc: size if (-T < x < L + T and abs(y) < 1.5 * T) else 4 * size)
        gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
        gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
        gmsh.model.mesh.generate(dim)
        pts, cells = mesh_elements(dim)
    if dim == 3:  # positive orientation for scikit-fem
        a = pts[cells]
        vol = np.einsum("ij,ij->i", np.cross(a[:, 1] - a[:, 0], a[:, 2] - a[:, 0]), a[:, 3] - a[:, 0])
        cells[vol < 0, 0], cells[vol < 0, 1] = cells[vol < 0, 1], cells[vol < 0, 0].copy()
    return pts, cells


def stiffness(dim: int, size: float, plane_strain: bool = False) -> tuple[float, int]:
    """Lateral force per lateral travel (N/mm) of the far block, the near block clamped."""
    pts, cells = mesh(dim, size)
    lam, mu = lame_parameters(E, NU)
    if dim == 2:
        m, e = MeshTri(pts.T.copy(), cells.T.copy()), ElementVector(ElementTriP2())
        if not plane_strain:
            lam = 2 * lam * mu / (lam + 2 * mu)
        thick = DEPTH
    else:
        m, e = MeshTet(pts.T.copy(), cells.T.copy()), ElementVector(ElementTetP2())
        thick = 2.0  # half model: twice its reaction
    basis = Basis(m, e, intorder=4)
    K = asm(linear_elasticity(lam, mu), basis)
    clamp = basis.get_dofs(m.facets_satisfying(lambda x: x[0] < -BLOCK + 1e-9, boundaries_only=True))
    push = basis.get_dofs(m.facets_satisfying(lambda x: x[0] > L + BLOCK - 1e-9, boundaries_only=True))
    fixed = [clamp.all(), push.all()]
    if dim == 3:
        fixed.append(basis.get_dofs(m.facets_satisfying(lambda x: x[2] < 1e-9, boundaries_only=True)).all("u^3"))
    idx = np.unique(np.concatenate(fixed))
    u = np.zeros(K.shape[0])
    u[push.all("u^2")] = 1e-3
    free = np.ones(K.shape[0], bool)
    free[idx] = False
    u[free] = spla.spsolve(K[free][:, free].tocsc(), -(K @ u)[free])
    return float((K @ u)[push.all("u^2")].sum()) * thick / 1e-3, int(K.shape[0])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=float, default=0.12, help="element size in the neck, mm")
    size = ap.parse_args().size
    t0 = time.time()
    k_stress, _ = stiffness(2, size)
    k_strain, _ = stiffness(2, size, plane_strain=True)
    k_3d, dofs = stiffness(3, size)
    print(json.dumps({"neck_mm": [T, L], "depth_mm": DEPTH, "element_size_mm": size, "dofs_3d": dofs,
                      "k_plane_stress_N_per_mm": k_stress, "k_plane_strain_N_per_mm": k_strain,
                      "k_3d_N_per_mm": k_3d,
                      "position_between_bounds": (k_3d - k_stress) / (k_strain - k_stress),
                      "seconds": round(time.time() - t0, 1)}))


if __name__ == "__main__":
    main()
