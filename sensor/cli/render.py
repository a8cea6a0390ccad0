"""``dacm render``: a PNG of the undeformed and the solved, deformed 3D body coloured by
strain energy density (pyvista, off-screen; works without a display)."""

from __future__ import annotations

import argparse
import re

from sensor.cli.design_args import (
    add_design_arguments,
    check_flags,
    design_from_args,
    travel_rule,
)
from sensor.cli.output import add_output_arguments, claim, print_json, staged
from sensor.cli.progress import add_quiet_argument, busy
from sensor.validation import Number, require_finite

DEFAULT_WINDOW = (1600, 1200)
#: Largest picture side (px) accepted by --window-size.
MAX_WINDOW_PX = 8000


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "render", help="PNG of the undeformed and deformed 3D body, coloured by strain energy",
        description="Solve a design to an output travel and draw the extruded body warped by "
                    "the solved displacements (the base plate and fiber post move rigidly; "
                    "hinges, links and the halves of the plates and knee blocks bend as cubic "
                    "beams between their end nodes), coloured by strain "
                    "energy density on a log scale, over the undeformed body in grey. The "
                    "displacements are magnified by the stated scale factor. Renders off-screen.")
    add_design_arguments(p)
    p.add_argument("--target-output", type=float, default=1.0, metavar="MM",
                   help="solve until the output port has travelled MM (default 1)")
    p.add_argument("--scale", type=float, metavar="N",
                   help="displacement scale factor (default: automatic, so the largest "
                        "displacement shows as 8%% of the body size, rounded down to 1, 2, "
                        "5 x 10^k, and lower while rigid parts would overlap; never below 1)")
    add_output_arguments(p, "the picture <name>-render.png")
    p.add_argument("--window-size", metavar="WxH", default=f"{DEFAULT_WINDOW[0]}x{DEFAULT_WINDOW[1]}",
                   help="picture size in pixels (default %(default)s)")
    p.add_argument("--json", action="store_true", help="print the solve and the file as JSON")
    add_quiet_argument(p)
    p.set_defaults(func=run)


def parse_window_size(text: str) -> tuple[int, int]:
    """``"WxH"`` -> (W, H) pixels, each in [100, MAX_WINDOW_PX]."""
    from sensor.errors import UsageError

    m = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", text)
    if not m or not all(100 <= int(v) <= MAX_WINDOW_PX for v in m.groups()):
        raise UsageError(f"--window-size = {text!r}: must be WxH in pixels, each between "
                             f"100 and {MAX_WINDOW_PX} (e.g. 1600x1200)")
    return int(m.group(1)), int(m.group(2))


def run(args: argparse.Namespace) -> int:
    from geometry.checks import assert_feasible
    from geometry.layout import make_layout, make_parts
    from geometry.topology import build_beam_model
    from sensor.mechanics.render import deformed_body, render_png
    from sensor.mechanics.solver import solve

    check_flags(args, {"scale": Number(0.0, 1e6, lo_open=True)})
    window = parse_window_size(args.window_size)
    design = design_from_args(args)
    check_flags(args, {"target_output": travel_rule(design.height_mm)})
    [out] = claim(args, [f"{design.name}-render.png"])
    assert_feasible(design)

    with busy(f"render {design.name}", args.quiet) as step:
        step("solving")
        model = build_beam_model(design)
        result = solve(model, target_output_mm=args.target_output)
        numbers = {k: getattr(result, k) for k in (
            "output_travel_mm", "input_force_N", "amplification", "strain_energy_mJ")}
        require_finite(f"solve of {design.name}", numbers)
        body = deformed_body(design, model, result, make_parts(make_layout(design)), args.scale)
        step("drawing")
        title, subtitle = _titles(design, result, body)
        with staged(args) as stage:
            render_png(body, stage / out.name, title, subtitle, window)
    if args.json:
        print_json({"design": design.name, **numbers, "displacement_scale": body.scale}, [out])
        return 0
    print(f"wrote {out}")
    return 0


def _titles(design, result, body) -> tuple[str, str]:
    title = (f"{design.name}: output travel {result.output_travel_mm:.2f} mm "
             f"at input force {result.input_force_N:.2f} N")
    scale = "displacements at true scale" if body.scale == 1 else f"displacements magnified × {body.scale:g}"
    subtitle = (f"{scale}   (A = {result.amplification:.2f}, "
                f"SE = {result.strain_energy_mJ:.3g} mJ; grey: undeformed)")
    return title, subtitle
