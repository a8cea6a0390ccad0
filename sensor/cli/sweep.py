"""``dacm sweep``: the main job. phi1 x phi2 sweeps for both hinge sets, with Figure 49."""

from __future__ import annotations

import argparse
import signal
import time
import tomllib
import warnings
from pathlib import Path

from sensor.cli.output import add_output_arguments, claim, print_json, staged
from sensor.cli.progress import CountingBar, add_quiet_argument, shown


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
    add_output_arguments(p, "the dataset, tables and plots")
    p.add_argument("--workers", type=int, default=0, metavar="N",
                   help="local processes (default: one per core; 1 = serial)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run the cells on this Dask distributed scheduler (e.g. tcp://host:8786)")
    p.add_argument("--resume", action="store_true",
                   help=f"finish the checkpoint OUT/{CHECKPOINT} of an interrupted run (same "
                        "settings; it is checked before it is trusted)")
    p.add_argument("--monte-carlo", type=int, metavar="N",
                   help="repeat each cell N times with hinge thicknesses drawn around nominal")
    p.add_argument("--hinge-sd", type=float, metavar="MM", help="standard deviation of the hinge thickness draws")
    p.add_argument("--seed", type=int, metavar="N", help="random seed of the Monte-Carlo draws (default 0)")
    p.add_argument("--no-plots", action="store_true", help="write the dataset only")
    p.add_argument("--json", action="store_true", help="print the summary and the files as JSON")
    add_quiet_argument(p)
    p.set_defaults(func=run)


#: Design fields the sweep sets itself, not taken from a --config [design] table.
SWEPT_FIELDS = {"phi1_deg": "from --phi1 / phi1", "phi2_deg": "from --phi2 / phi2",
                "hinge_set": "from --hinges / hinges", "hinge_thickness_mm": "from --hinges / hinges",
                "name": "each cell is named after its angles"}


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
        from sensor.cli.design_args import input_file

        try:
            with open(input_file("--config", args.config), "rb") as fh:
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
    swept = sorted(set(cfg.get("design", {})) & set(SWEPT_FIELDS))
    if swept:
        raise SweepError(f"--config {args.config}: [design] {swept[0]}: the sweep sets it "
                         f"({SWEPT_FIELDS[swept[0]]}); remove it from the [design] table")
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


#: The dataset of a sweep that has not finished, in --out (saved every few seconds and when
#: the sweep is stopped); the finished set replaces it.
CHECKPOINT = "sweep-checkpoint.nc"


def output_names(spec, plots: bool) -> list[str]:
    """The files a sweep writes, in order: dataset, CSV, Pareto tables, then the plots."""
    names = ["sweep.nc", "sweep.csv", *(f"pareto-{h}.csv" for h in spec.hinge_sets)]
    if plots:
        # matplotlib is imported only when plots are made
        from sensor.design_space.plots import figure_names

        names += [f"{stem}.{fmt}" for stem in figure_names(bool(spec.monte_carlo)) for fmt in ("png", "svg")]
    return names


def _write_data(ds, fronts: dict, out: Path) -> list[Path]:
    """The dataset, its CSV and each hinge set's Pareto table, written in ``out``."""
    from sensor.design_space.dataset import save_dataset, write_csv, write_table

    save_dataset(ds, out / "sweep.nc")
    written = [out / "sweep.nc", write_csv(ds, out / "sweep.csv")]
    for h, front in fronts.items():
        units = {k: ds[k].attrs["units"] for k in front.columns}
        written.append(write_table(front, out / f"pareto-{h}.csv", units))
    return written


def run(args: argparse.Namespace) -> int:
    from importlib.metadata import version

    from sensor.design_space.execution import run_sweep
    from sensor.errors import SweepError

    spec = spec_from_args(args)
    if args.workers < 0:
        raise SweepError(f"--workers = {args.workers}: must be >= 0 (0 = one per core)")
    names = output_names(spec, not args.no_plots)
    claim(args, names, exclusive=True)
    out = args.out
    checkpoint = out / CHECKPOINT
    if checkpoint.exists() and not args.resume:
        if not args.force:
            raise SweepError(f"{checkpoint} is the checkpoint of an interrupted sweep: use "
                             "--resume to finish it, --force to start again, or another --out")
        checkpoint.unlink()
    t0 = time.monotonic()
    ds, n_new = run_sweep(spec, version("dacm"), checkpoint, resume=args.resume, workers=args.workers,
                          scheduler=args.scheduler, progress=CountingBar("sweep", "cells") if shown(args.quiet) else None)
    t_solve = time.monotonic() - t0
    from sensor.design_space.equal_range import pareto_front

    fronts = {str(h): pareto_front(ds, str(h)) for h in ds["hinges"].values}
    try:
        written = _write_set(args, ds, fronts)
    except KeyboardInterrupt as exc:  # every cell is done: keep them for --resume
        from sensor.design_space.dataset import save_dataset
        from sensor.errors import SweepInterrupted, Terminated

        save_dataset(ds, checkpoint)
        signum = signal.SIGTERM if isinstance(exc, Terminated) else signal.SIGINT
        raise SweepInterrupted(f"interrupted while writing the files; every cell is saved in "
                               f"{checkpoint}: finish with --resume", signum) from None
    from sensor.design_space.summary import summary, summary_text

    s = summary(ds, n_new, t_solve, time.monotonic() - t0, written)
    if args.json:
        print_json({k: v for k, v in s.items() if k != "files"}, written)
    else:
        print(summary_text(s))
    return 0


def _write_set(args: argparse.Namespace, ds, fronts: dict) -> list[Path]:
    """The dataset, tables and plots, into place together (:func:`staged`)."""
    with staged(args, remove=[CHECKPOINT]) as stage:  # the whole set, or none of it
        if args.no_plots:
            written = _write_data(ds, fronts, stage)
        else:
            from sensor.design_space.execution import task_pool
            from sensor.design_space.plots import start_figures
            from sensor.errors import ResourceNote

            with warnings.catch_warnings():  # a note on --workers was given by the sweep
                warnings.simplefilter("ignore", ResourceNote)
                with task_pool(args.workers) as pool:
                    figures = start_figures(ds, fronts, stage, pool)   # drawn while the data is written
                    written = _write_data(ds, fronts, stage) + figures()
    return [args.out / p.name for p in written]
