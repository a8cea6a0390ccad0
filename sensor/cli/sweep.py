"""``dacm sweep``: the main job. phi1 x phi2 sweeps for both hinge sets, with Figure 49."""

from __future__ import annotations

import argparse
import sys
import time
import tomllib
from pathlib import Path


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "sweep", help="sweep phi1 x phi2 for both hinge sets: dataset, Figure 49, equal-range answer",
        description="Solve the proposed body at every (phi1, phi2) cell and the basis body at "
                    "every phi1 to the same output travel, for each hinge set; write the "
                    "labelled dataset (NetCDF + CSV), the Figure 49 ratio panels (PNG + SVG), "
                    "hysteresis and resolution against range with the basis family and the "
                    "(range, H) front, and print the equal-range answer at 1, 2, 5, 10 and 20 N. "
                    "With no arguments: both hinge sets, a 41 x 41 grid, ./dacm-out.")
    p.add_argument("--hinges", action="append", metavar="SET",
                   help="hinge set to sweep: 05-03 or 03-03 (repeatable; default both)")
    p.add_argument("--phi1", metavar="START:STOP:N", help="phi1 grid in degrees (default 5:33:41)")
    p.add_argument("--phi2", metavar="START:STOP:N", help="phi2 grid in degrees (default 4:56:41)")
    p.add_argument("--target-output", type=float, metavar="MM", help="output travel (default 1 mm)")
    p.add_argument("--config", type=Path, metavar="TOML",
                   help="sweep settings: hinges, phi1, phi2, target_output_mm, monte_carlo, "
                        "hinge_sd_mm, seed, and a [design] table of other design fields")
    p.add_argument("--out", type=Path, default=Path("dacm-out"), metavar="DIR",
                   help="output folder (default ./dacm-out)")
    p.add_argument("--workers", type=int, default=0, metavar="N",
                   help="local processes (default: one per core; 1 = serial)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run the cells on this Dask distributed scheduler (e.g. tcp://host:8786)")
    p.add_argument("--resume", action="store_true",
                   help="reuse the cells of an existing dataset in --out (same settings)")
    p.add_argument("--monte-carlo", type=int, metavar="N",
                   help="repeat each cell N times with hinge thicknesses drawn around nominal")
    p.add_argument("--hinge-sd", type=float, metavar="MM", help="standard deviation of the hinge thickness draws")
    p.add_argument("--seed", type=int, metavar="N", help="random seed of the Monte-Carlo draws (default 0)")
    p.add_argument("--no-plots", action="store_true", help="write the dataset only")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def spec_from_args(args: argparse.Namespace):
    """The sweep settings: defaults, then the TOML file, then the flags."""
    from geometry.errors import GeometryError
    from sensor.design_space.execution import check_run_options
    from sensor.design_space.spec import Grid, SweepSpec
    from sensor.errors import SweepError
    from sensor.validation import is_integer, is_real

    check_run_options(args.workers, args.scheduler)  # before anything is made in --out
    cfg: dict = {}
    if args.config is not None:
        try:
            with open(args.config, "rb") as fh:
                cfg = tomllib.load(fh)
        except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
            raise SweepError(f"{args.config}: malformed TOML: {exc}") from None
        known = {"hinges", "phi1", "phi2", "target_output_mm", "monte_carlo", "hinge_sd_mm", "seed", "design"}
        unknown = sorted(set(cfg) - known)
        if unknown:
            raise SweepError(f"{args.config}: unknown key(s) {', '.join(unknown)}; known: {', '.join(sorted(known))}")
    d = SweepSpec()
    hinges = args.hinges if args.hinges is not None else cfg.get("hinges", list(d.hinge_sets))
    if isinstance(hinges, str):
        hinges = [hinges]
    if not isinstance(hinges, list) or not hinges or not all(isinstance(h, str) for h in hinges):
        raise SweepError(f"hinges = {hinges!r}: must name at least one hinge set (05-03, 03-03)")
    phi1 = Grid.parse(args.phi1, "--phi1") if args.phi1 is not None else (Grid.parse(cfg["phi1"], "phi1") if "phi1" in cfg else d.phi1)
    phi2 = Grid.parse(args.phi2, "--phi2") if args.phi2 is not None else (Grid.parse(cfg["phi2"], "phi2") if "phi2" in cfg else d.phi2)

    def pick(flag, key, default, kind):
        value = flag if flag is not None else cfg.get(key, default)
        if not (is_integer(value) if kind is int else is_real(value)):
            raise SweepError(f"{key} = {value!r}: must be {'an integer' if kind is int else 'a finite number'}")
        return kind(value)

    if not isinstance(cfg.get("design", {}), dict):
        raise SweepError(f"design = {cfg['design']!r}: must be a table of design fields")
    try:
        return SweepSpec(
            hinge_sets=tuple(dict.fromkeys(hinges)), phi1=phi1, phi2=phi2,
            target_output_mm=pick(args.target_output, "target_output_mm", d.target_output_mm, float),
            base=dict(cfg.get("design", {})),
            monte_carlo=pick(args.monte_carlo, "monte_carlo", 0, int),
            hinge_sd_mm=pick(args.hinge_sd, "hinge_sd_mm", 0.0, float),
            seed=pick(args.seed, "seed", 0, int))
    except GeometryError as exc:
        raise SweepError(f"[design] table: {exc}") from None


class _Progress:
    """A rich progress bar: cells done, rate and time left."""

    def __init__(self):
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            TextColumn,
            TimeRemainingColumn,
        )
        self.bar = Progress(TextColumn("sweep"), BarColumn(), MofNCompleteColumn(),
                            TextColumn("{task.fields[rate]}"), TimeRemainingColumn(), transient=True)
        self.t0 = time.monotonic()

    def start(self, total):
        self.task = self.bar.add_task("cells", total=total, rate="")
        self.bar.start()

    def advance(self, n):
        done = self.bar.tasks[0].completed + n
        rate = done / max(time.monotonic() - self.t0, 1e-9)
        self.bar.update(self.task, advance=n, rate=f"{rate:.0f} cells/s")

    def stop(self):
        self.bar.stop()


def run(args: argparse.Namespace) -> int:
    from importlib.metadata import version

    from sensor.design_space.dataset import save_dataset, write_csv
    from sensor.design_space.execution import run_sweep
    from sensor.errors import SweepError

    spec = spec_from_args(args)
    if args.workers < 0:
        raise SweepError(f"--workers = {args.workers}: must be >= 0 (0 = one per core)")
    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    if not out.is_dir():
        raise SweepError(f"--out = {out}: not a folder")
    nc = out / "sweep.nc"
    t0 = time.monotonic()
    show = not args.quiet and sys.stderr.isatty()
    ds, n_new = run_sweep(spec, version("dacm"), nc, resume=args.resume, workers=args.workers,
                          scheduler=args.scheduler, progress=_Progress() if show else None)
    t_solve = time.monotonic() - t0
    save_dataset(ds, nc)
    written = [nc, write_csv(ds, out / "sweep.csv")]
    fronts = {}
    from sensor.design_space.dataset import write_table
    from sensor.design_space.equal_range import pareto_front
    for h in ds["hinges"].values:
        fronts[str(h)] = pareto_front(ds, str(h))
        units = {k: ds[k].attrs["units"] for k in fronts[str(h)].columns}
        written.append(write_table(fronts[str(h)], out / f"pareto-{h}.csv", units))
    if not args.no_plots:
        from sensor.design_space.plots import plot_figure49, plot_hysteresis_vs_range
        written += plot_figure49(ds, out)
        written += plot_hysteresis_vs_range(ds, fronts, out)
    print_summary(ds, n_new, t_solve, time.monotonic() - t0, written)
    return 0


def print_summary(ds, n_new, t_solve, t_total, written) -> None:
    from sensor.design_space.equal_range import (
        SAME_RANGE,
        SUMMARY_RANGES_N,
        admissible,
        answer_at,
    )

    n = int(ds["computed"].size)
    print(f"swept {n} cells ({n_new} computed now) in {t_solve:.1f} s; total {t_total:.1f} s")
    for h in ds["hinges"].values:
        feas, ok = ds["feasible"].sel(hinges=h).values, admissible(ds, str(h))
        print(f"hinge set {h}: {int(feas.sum())} of {feas.size} cells feasible, {int(ok.sum())} of them "
              "within the allowable hinge stress at full scale")
    print(f"equal range: the DACM cell with the lowest H within {100 * SAME_RANGE:g} % of each range, "
          "against the basis body of that range with the lowest H (any phi1, hinges 1-8 of any thickness)")
    for r in SUMMARY_RANGES_N:
        for h in ds["hinges"].values:
            print("  " + _answer_line(answer_at(ds, str(h), r)))
    print(f"wrote {', '.join(str(p.name) for p in written)} in {written[0].parent}")


def _answer_line(a) -> str:
    """One line of the equal-range summary."""
    head = f"{a.range_N:>4g} N, {a.hinges}: "
    if a.cell is None:
        return head + "no cell within the allowable stress reaches this range"
    c, b = a.cell, a.basis
    text = (head + f"DACM phi1 = {c['phi1_deg']:.2f}, phi2 = {c['phi2_deg']:.2f} deg, range {c['range_N']:.3g} N, "
            f"A = {c['amplification']:.2f}, H = {c['hysteresis']:.4f}, resolution {1e3 * c['resolution_N']:.3f} mN; ")
    if b["hysteresis"] == b["hysteresis"]:
        text += (f"basis phi1 = {b['phi1_deg']:.1f} deg, hinges {b['hinge_mm']:.3f} mm: H = {b['hysteresis']:.4f}, "
                 f"resolution {1e3 * b['resolution_N']:.3f} mN; H ratio {c['hysteresis'] / b['hysteresis']:.3f} "
                 f"(1/A = {1 / c['amplification']:.3f}), "
                 f"resolution ratio {c['resolution_N'] / b['resolution_N']:.3f}")
    else:
        loose = a.basis_any_stress
        text += "no basis body reaches it within the allowable stress" + (
            f" (best beyond it: H = {loose['hysteresis']:.4f} at {loose['stress_utilisation']:.2f} x the "
            f"allowable stress; H ratio {c['hysteresis'] / loose['hysteresis']:.3f})"
            if loose["hysteresis"] == loose["hysteresis"] else "")
    return text + (f" [edge: {a.edge}]" if a.edge else "")
