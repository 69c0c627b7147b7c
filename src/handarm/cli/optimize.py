"""``handarm optimize``: constrained multi-objective design search (Optuna on Dask)."""

from __future__ import annotations

import argparse
from pathlib import Path

from handarm.cli._common import add_quiet, option_error

_OPTIONS = {
    "trials": "--trials",
    "workers": "--workers",
    "scheduler": "--scheduler",
    "out": "--out",
    "sampler": "--sampler",
}


def cmd_optimize(args: argparse.Namespace) -> int:
    """Search the design space of OPT.toml; resumable and extendable (see the guide)."""
    from tqdm import tqdm

    from handarm._outdir import check_out_dir
    from handarm.workspace._dask import check_scheduler
    from handarm.workspace.opt_file import load_opt
    from handarm.workspace.optimize import build_front, check_sampler, run_optimization

    opt = load_opt(args.opt)
    try:
        check_sampler(opt, args.sampler)
        check_scheduler(args.scheduler)
        check_out_dir(args.out)  # before the bar: a refusal is one line
    except ValueError as exc:
        raise option_error(exc, _OPTIONS) from None
    if args.trials is not None and args.trials < 1:
        raise option_error(ValueError(f"trials: expected >= 1, got {args.trials}"), _OPTIONS)
    if args.workers is not None and args.workers < 1:
        raise option_error(ValueError(f"workers: expected >= 1, got {args.workers}"), _OPTIONS)
    bars = []  # made at the first progress call: a refused resume stays one line

    def tick(done: int, total: int, front: int, hv: float) -> None:
        if not bars:
            bars.append(tqdm(total=total, desc=opt.name, unit="trial", disable=args.quiet))
        bar = bars[0]
        bar.total = total
        bar.set_postfix(front=front, hypervolume=f"{hv:.4g}")
        bar.update(done - bar.n)

    try:
        result = run_optimization(
            opt,
            args.out,
            trials=args.trials,
            sampler=args.sampler,
            scheduler=args.scheduler,
            workers=args.workers,
            progress=tick,
        )
    except ValueError as exc:
        raise option_error(exc, _OPTIONS) from None
    finally:
        for bar in bars:
            bar.close()
    print(
        f"{result['new']} trials run now, {result['finished']} in the journal; "
        f"front of {len(result['front'])}, hypervolume {result['hypervolume']:.4g}"
    )
    names = [o.name for o in opt.objectives]
    for d in result["front"]:
        vals = ", ".join(
            f"{n} {d['measurements'][o.key]:.4g}"
            for n, o in zip(names, opt.objectives, strict=True)
        )
        print(f"  trial {d['trial']}: {vals}")
    if args.build:
        for folder in build_front(opt, Path(args.out), progress=not args.quiet):
            print(f"built {folder}")
    print(f"wrote {args.out}")
    return 0


def register(sub) -> None:
    """Add the subcommand to the ``handarm`` parser."""
    p = sub.add_parser(
        "optimize",
        help="multi-objective design search (Optuna, Dask)",
        description="Search the design space of OPT.toml: objectives in physical units, "
        "constraints, resumable journal, Pareto front, pictures.",
    )
    p.add_argument("opt", metavar="OPT.toml", help="optimization file")
    p.add_argument("--out", default="build/optimize", help="output folder (resumable)")
    p.add_argument("--trials", type=int, help="total finished trials wanted (extends a run)")
    p.add_argument("--sampler", choices=("nsga2", "tpe", "gp", "grid"), help="Optuna sampler")
    p.add_argument(
        "--scheduler", metavar="tcp://HOST:8786", help="a Dask scheduler (default: local)"
    )
    p.add_argument("--workers", type=int, help="local worker processes (default 2)")
    p.add_argument("--build", action="store_true", help="fully build every front design")
    add_quiet(p)
    p.set_defaults(func=cmd_optimize)
