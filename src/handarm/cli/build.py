"""``handarm build``, ``handarm carve`` and ``handarm urdf``: the design's files."""

from __future__ import annotations

import argparse
import math
import sys

from handarm.cli._common import (
    MAP_OPTIONS,
    UsageError,
    add_design_arg,
    add_limits,
    add_map_options,
    add_quiet,
    add_scene_options,
    limits,
    load_design,
    load_scene,
    number,
    option_error,
    out_file,
)


def _add_resolution(p) -> None:
    p.add_argument(
        "--resolution",
        type=number(low=0.01, high=10.0),
        default=1.0,
        metavar="DEG",
        help="largest angle between swept poses, degrees, 0.01..10 (default 1)",
    )


def cmd_build(args: argparse.Namespace) -> int:
    """Everything for one design."""
    from handarm.pipeline import build

    design = load_design(args.design)
    scene, clearance = load_scene(args)
    try:
        result = build(
            design,
            args.out,
            resolution_deg=args.resolution,
            voxel=args.voxel,
            directions=args.directions,
            progress=not args.quiet,
            scene=scene,
            clearance=clearance,
            **limits(args),
        )
    except ValueError as exc:
        raise option_error(exc, MAP_OPTIONS) from None
    for path in result.files:
        print(path)
    warn_thin(result.carving, "handarm build")
    return 0


def cmd_carve(args: argparse.Namespace) -> int:
    """Carve the links and print the limits they allow."""
    from handarm._outdir import build_folder
    from handarm._resources import check_resources
    from handarm.cad_out.carve_files import printed_summary
    from handarm.carve import check_carvable
    from handarm.pipeline import CARVE_LAYOUT, carve_design, check_outputs

    design = load_design(args.design)
    try:
        check_carvable(design)  # before the folder is made or marked
        check_outputs(args.out, CARVE_LAYOUT, design)
        check_resources(design, resolution_deg=args.resolution, **limits(args))
        # as a build does: locked, marked until done, and the previous run's files that
        # this one does not write again removed (another design's parts mixed in before)
        with build_folder(args.out, design.to_dict()) as files:
            carving, paths = carve_design(
                design,
                args.out,
                resolution_deg=args.resolution,
                progress=not args.quiet,
                **limits(args),
            )
            files += paths
    except ValueError as exc:
        raise option_error(exc, {"out": "--out", "resolution_deg": "--resolution"}) from None
    print("joint  requested (deg)    parts allow (deg)   as built (deg)      stopped by (upper)")
    for j in carving.joints:
        req = [math.degrees(v) for v in j.requested]
        ach = [math.degrees(v) for v in j.achieved]
        built = [math.degrees(v) for v in j.as_built]
        print(
            f"{j.joint:>5}  {req[0]:7.2f} {req[1]:7.2f}    {ach[0]:7.2f} {ach[1]:7.2f}     "
            f"{built[0]:7.2f} {built[1]:7.2f}     {j.built_stop[1]}"
        )
    mass = sum(link.solid.volume() for link in carving.links) * 1e-9 * carving.design.density
    print(f"total link mass {mass * 1e3:.1f} g")
    print(printed_summary(carving.printed, design.min_wall).lstrip("\n"), end="")
    print(f"wrote {len(files)} files into {args.out}")
    warn_thin(carving, "handarm carve")
    return 0


def warn_thin(carving, name: str) -> None:
    """A warning on stderr when a carved link keeps a wall under the design's min_wall."""
    from handarm.cad_out.carve_files import thin_links

    thin = thin_links(carving.printed, carving.design.min_wall)
    if thin:
        walls = ", ".join(f"{link} {wall:.3g} mm" for link, wall in thin)
        print(
            f"{name}: warning: walls under min_wall ({carving.design.min_wall * 1e3:g} mm): "
            f"{walls}; these links may not print (see links/*.json)",
            file=sys.stderr,
        )


def cmd_urdf(args: argparse.Namespace) -> int:
    """Write the design as URDF."""
    from handarm.cad_out.urdf import write_urdf

    out = out_file(args.out, "--out")
    design = load_design(args.design)
    try:
        print(write_urdf(design, out))
    except OSError as exc:  # a folder that refuses files (/proc) though access() allowed it
        raise UsageError(f"--out: cannot write {args.out!r}: {exc.strerror or exc}") from None
    return 0


def register(sub) -> None:
    """Add the subcommands to the ``handarm`` parser."""
    p = sub.add_parser(
        "build",
        help="everything for one design (the main job)",
        description="Everything for one design: design TOML, summary, carved link meshes, "
        "3MF plate, link properties, pictures, URDF, servo-controller files and the "
        "workspace map.",
    )
    add_design_arg(p)
    p.add_argument("--out", default="build", help="output folder (default: build)")
    _add_resolution(p)
    add_map_options(p)
    add_scene_options(p)
    add_limits(p)
    add_quiet(p)
    p.set_defaults(func=cmd_build)

    p = sub.add_parser(
        "carve",
        help="carve printable links and measure their joint limits",
        description="Carve the links: STL per link, a 3MF plate, properties, pictures, "
        "URDF with meshes; prints the joint limits the carved links allow.",
    )
    add_design_arg(p)
    p.add_argument("--out", default="build/carve", help="output folder (default: build/carve)")
    _add_resolution(p)
    add_limits(p)
    add_quiet(p)
    p.set_defaults(func=cmd_carve)

    p = sub.add_parser(
        "urdf", help="write the design as URDF", description="Write the design as URDF."
    )
    add_design_arg(p)
    p.add_argument("--out", required=True, metavar="FILE", help="URDF file to write")
    p.set_defaults(func=cmd_urdf)
