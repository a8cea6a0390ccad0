"""``dacm render``: the displacement field built from the solved beam model, its strain
energy density, the off-screen picture (no display) and the CLI's bad-input handling."""

import numpy as np
import pytest

from geometry.layout import Part, bar, make_layout, make_parts
from geometry.params import preset
from geometry.topology import BeamModel, build_beam_model
from sensor.cli import main
from sensor.errors import SensorInputError
from sensor.mechanics.render import (
    auto_scale,
    body_mesh,
    displacement_field,
    member_strain_energy,
    overlapping_parts,
    part_motions,
    picture_scale,
    rigid_outlines,
    strain_energy_density,
)
from sensor.mechanics.solver import solve


@pytest.fixture(scope="module")
def sample_b():
    design = preset("sample-b")
    model = build_beam_model(design)
    parts = make_parts(make_layout(design))
    return design, model, solve(model), parts


def test_field_reproduces_the_solved_nodes(sample_b):
    """At every model node (rigid-body nodes, and member ends inside hinges and links) the
    field equals the solver's node displacement. Both are the same rigid motion or member
    end, so only rounding separates them: 1e-9 mm against displacements of about 1 mm. The
    input point is the exception: it sinks into the plate by the contact's compression
    (geometry.topology.contact_compliance, 3e-4 mm here), which the drawn plate does not show."""
    _, model, result, parts = sample_b
    u = displacement_field(model.nodes, parts, part_motions(parts, model), model, result)
    solved = result.deformed_nodes - model.nodes
    plate = np.arange(len(model.nodes)) != model.input_node
    np.testing.assert_allclose(u[plate], solved[plate], rtol=0, atol=1e-9)
    sink = u[model.input_node, 1] - solved[model.input_node, 1]
    assert 0 < sink < 2e-3 * np.abs(solved).max()
    # and each hinge's and link's own interpolation at both of its end nodes
    motions = part_motions(parts, model)
    for p, mo in zip(parts, motions):
        if mo.member >= 0:
            ends = [mo.start, mo.end]
            f = displacement_field(model.nodes[ends], [p], [mo], model, result)
            np.testing.assert_allclose(f, result.deformed_nodes[ends] - model.nodes[ends],
                                       rtol=0, atol=1e-9, err_msg=p.name)
    assert sum(mo.member >= 0 for mo in motions) == 26    # 12 hinges, 6 links, 2 plate, 2 platform, 4 knee halves


def test_field_is_continuous_across_part_boundaries(sample_b):
    """Points just either side of every member end (0.1 um apart, across the whole
    section) move alike: rigid body -> hinge -> link -> hinge -> rigid body, no tearing.
    The field's gradient is about (scale of rotations) ~0.15 rad, so 1e-7 mm apart they
    differ by < 1e-7 mm."""
    _, model, result, parts = sample_b
    motions = part_motions(parts, model)
    for p, mo in zip(parts, motions):
        if p.kind != "hinge":
            continue
        a, b = p.axis
        u = (b - a) / np.linalg.norm(b - a)
        n = np.array([-u[1], u[0]])
        for end in (a, b):
            across = end + np.outer(np.linspace(-0.45, 0.45, 7) * p.width, n)
            f = displacement_field(np.vstack([across - 1e-7 * u, across + 1e-7 * u]), parts,
                                   motions, model, result)
            np.testing.assert_allclose(f[:7], f[7:], rtol=0, atol=1e-7)


def test_member_interpolation_matches_the_cantilever_closed_form():
    """A single slender member under a small tip force: the field along its axis is the
    Euler-Bernoulli deflection P x^2 (3L - x) / (6 EI) plus the shear term 6/5 P x / (G A).
    The cubic Hermite omits the shear profile (its share of the tip deflection is
    3.6 EI / (G A L^2) = 8.1e-5 here) and the load index F L^2 / EI = 1e-4 keeps the
    geometric nonlinearity at 1e-8, so the tolerance is 1e-4 of the tip deflection. The
    section at the tip turns with the tip rotation P L^2 / (2 EI): relative to the axis the
    top fibre moves along x by t/2 sin(slope) (shear leaves end rotations alone: 1e-6)."""
    L, t, b, E, nu = 10.0, 0.1, 5.0, 2300.0, 0.35
    EI, G = E * b * t**3 / 12, E / (2 * (1 + nu))
    F = 1e-4 * EI / L**2
    model = BeamModel(nodes=np.array([[0.0, 0.0], [L, 0.0]]), member_nodes=np.array([[0, 1]]),
                      member_kind=("hinge",), thickness_mm=np.array([t]), depth_mm=np.array([b]),
                      hinge_number=np.array([1]), member_name=("hinge 1",),
                      supports=((0, ("x", "y", "rz")),), input_node=1,
                      input_direction=np.array([0.0, -1.0]), output_node=1,
                      output_direction=np.array([0.0, -1.0]), E_MPa=E, nu=nu)
    result = solve(model, target_force_N=F)
    parts = [Part("hinge 1", "hinge", bar(model.nodes[0], model.nodes[1], t), 1,
                  model.nodes.copy(), t)]
    x = np.linspace(0.0, L, 21)
    points = np.column_stack([x, np.zeros_like(x)])
    u = displacement_field(points, parts, part_motions(parts, model), model, result)
    v = -(F * x**2 * (3 * L - x) / (6 * EI) + 1.2 * F * x / (G * t * b))
    np.testing.assert_allclose(u[:, 1], v, rtol=0, atol=1e-4 * abs(v[-1]))
    top = displacement_field(np.array([[L, t / 2]]), parts, part_motions(parts, model), model, result)
    slope = F * L**2 / (2 * EI)
    assert top[0, 0] - u[-1, 0] == pytest.approx(t / 2 * np.sin(slope), rel=1e-6)


def test_member_strain_energies_add_up_to_the_solver_total(sample_b):
    """U = q^T K^-1 q / 2 per member, summed, is the solver's SE (the same energy from the
    forces instead of the deformations; a matrix inversion apart: 1e-9 relative). Hinges
    hold the energy: the links' density is far below every hinge's."""
    _, model, result, _ = sample_b
    U = member_strain_energy(model, result)
    assert U.sum() == pytest.approx(result.strain_energy_mJ, rel=1e-9)
    assert (U[[k == "rigid" for k in model.member_kind]] == 0).all()
    sed = strain_energy_density(model, result)
    hinge = np.array([k == "hinge" for k in model.member_kind])
    plate = np.array([n.startswith("top plate ") for n in model.member_name])
    platform = np.array([n.startswith("platform ") for n in model.member_name])
    link = np.array([n.endswith(" link") for n in model.member_name])   # the chains' links
    assert sed[link].max() < 0.1 * sed[hinge].min()
    # the platform bends too, far less than the plate: it carries the middle hinges' moments
    assert 0 < U[platform].sum() < 0.2 * U[plate].sum()
    # the top plate bends (its two halves are compliant members): in a stiff, highly
    # amplifying body such as sample B as cut (its filleted hinges stiffer than drawn) it
    # holds about a fifth of the energy (measured 0.206 of 0.880 mJ), a third of what the
    # hinges hold
    assert 0 < U[plate].sum() < 0.4 * U[hinge].sum()


def test_mirror_symmetric_design_deforms_mirror_symmetrically(sample_b):
    """Sample B is mirror-symmetric about x = 0: on the mesh points and their mirror images
    u_x(-x, y) = -u_x(x, y) and u_y(-x, y) = u_y(x, y), and mirrored hinges have equal
    energy density. The solver's own symmetry is at its residual (1e-9), so 1e-7 relative."""
    design, model, result, parts = sample_b
    pts = np.unique(np.asarray(body_mesh(design).points[:, :2], dtype=float), axis=0)
    mirror = pts * [-1.0, 1.0]
    motions = part_motions(parts, model)
    u = displacement_field(pts, parts, motions, model, result)
    um = displacement_field(mirror, parts, motions, model, result)
    scale = np.abs(u).max()
    np.testing.assert_allclose(um * [-1.0, 1.0], u, rtol=0, atol=1e-7 * scale)
    sed = strain_energy_density(model, result)
    by_hinge = dict(zip(model.hinge_number, sed))
    for h1, h2 in ((1, 8), (2, 7), (3, 6), (4, 5), (9, 12), (10, 11)):
        assert by_hinge[h1] == pytest.approx(by_hinge[h2], rel=1e-7)


def test_auto_scale_rounds_down_to_1_2_5():
    assert auto_scale(1.0, 30.0) == 2.0          # ideal 2.4
    assert auto_scale(0.01, 30.0) == 200.0       # ideal 240
    assert auto_scale(0.05, 30.0) == 20.0        # ideal 48
    assert auto_scale(10.0, 30.0) == 1.0         # never shrinks
    assert auto_scale(0.0, 30.0) == 1.0


def test_magnified_picture_never_draws_the_platform_through_the_fiber_post(sample_b):
    """At 1 mm output travel sample B's platform comes to 0.2 mm of the fiber post (rest gap
    fiber_clearance_mm = 1.2 mm). Magnified by s its drawn gap is 1.2 - s x 1.0 mm: the
    outlines overlap from s = 1.2 on (the platform turns by 1e-9 rad at most, symmetric
    body: 1 % either side of the threshold is far outside that), so the automatic scale
    (ideal 2) steps down to 1, and an explicit --scale 2 is refused with the two parts named."""
    design, model, result, parts = sample_b
    outlines = rigid_outlines(parts, part_motions(parts, model), model, result)
    limit = design.fiber_clearance_mm / result.output_travel_mm
    assert overlapping_parts(outlines, 0.99 * limit) == []
    assert set(overlapping_parts(outlines, 1.01 * limit)) == {("fiber post", "platform left"),
                                                               ("fiber post", "platform right")}
    assert picture_scale(outlines, 1.0, max(design.width_mm, design.height_mm)) == 1.0
    with pytest.raises(SensorInputError, match="scale = 2: .*fiber post through the platform"):
        picture_scale(outlines, 1.0, 30.0, 2.0)
    assert picture_scale(outlines, 1.0, 30.0, 1.0) == 1.0


def test_render_without_display_writes_the_default_png(tmp_path, monkeypatch, capsys):
    """One off-screen render with no DISPLAY at all: the default path, the requested size,
    and a real picture (pixel variance; warm hinge colours and the grey rigid parts)."""
    import imageio.v3 as iio

    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.chdir(tmp_path)
    status = main(["render", "--preset", "sample-b", "--window-size", "640x480"])
    out, err = capsys.readouterr()
    path = tmp_path / "dacm-out" / "sample-b-render.png"
    assert status == 0 and out.strip() == f"wrote {path.relative_to(tmp_path)}"
    img = iio.imread(path)
    assert img.shape[:2] == (480, 640)
    rgb = img[..., :3].astype(float)
    assert rgb.std() > 20                                     # not blank
    assert ((rgb[..., 0] > 180) & (rgb[..., 2] < 120)).sum() > 100   # hinges (orange/yellow)
    assert sorted(p.name for p in path.parent.iterdir()) == ["render-manifest.json", path.name]  # no temp file


@pytest.mark.parametrize("argv, words", [
    (["--window-size", "10x10"], "--window-size = '10x10'"),
    (["--window-size", "big"], "--window-size = 'big'"),
    (["--scale", "-2"], "--scale = -2"),
    (["--target-output", "0"], "--target-output = 0"),
    (["--out", "{tmp}/x.png"], "--out is a folder now"),
    (["--scale", "2"], "scale = 2: the magnified displacements draw the fiber post through the platform"),
    (["--phi1", "80"], "phi1"),
    (["--preset", "sample-z"], "sample-z"),
])
def test_bad_input_exits_2_with_one_line_and_no_file(tmp_path, capsys, argv, words):
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    if "--out" not in argv:
        argv += ["--out", str(tmp_path / "r")]
    status = main(["render", *argv])
    out, err = capsys.readouterr()
    assert status == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith("dacm render: error: ") and words in err
    assert list(tmp_path.iterdir()) == []
