"""``handarm report``: the HTML report of an output folder, regenerated from its files."""

from __future__ import annotations

import argparse


def cmd_report(args: argparse.Namespace) -> int:
    """Write DIR/report.html from what DIR holds; optionally open it."""
    import sys
    from pathlib import Path

    from handarm._outdir import INCOMPLETE
    from handarm.report import write_report

    path = write_report(args.dir)
    if (Path(args.dir) / INCOMPLETE).exists():
        print(
            f"handarm report: warning: {args.dir} holds {INCOMPLETE}: the build did not finish "
            "(the page says so)",
            file=sys.stderr,
        )
    print(path)
    if args.open:
        import webbrowser

        webbrowser.open(path.resolve().as_uri())
    return 0


def register(sub) -> None:
    """Add the subcommand to the ``handarm`` parser."""
    p = sub.add_parser(
        "report",
        help="(re)write the HTML report of a build, study or optimization folder",
        description="Write DIR/report.html (one offline file) from the files a build, study "
        "or optimization wrote, without recomputing them.",
    )
    p.add_argument("dir", metavar="DIR", help="output folder of handarm build/study/optimize")
    p.add_argument("--open", action="store_true", help="open the page in the web browser")
    p.set_defaults(func=cmd_report)
