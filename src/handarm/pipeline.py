"""The main job as library calls: carve, export, map, and ``build`` that does all of them.

``handarm.build(design, out)`` writes everything for one design and returns a
``BuildResult`` listing what it wrote. The ``handarm`` command is a thin layer over these
functions: it parses arguments, calls them and prints.

Progress bars (tqdm, on standard error) are shown when ``progress=True``.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
from collections.abc import Sequence
from pathlib import Path

from tqdm import tqdm

from handarm._checks import check_design
from handarm._io import write_text_atomic
from handarm._outdir import build_folder, check_layout, check_out_dir
from handarm._resources import DEFAULT_MAX_MEMORY, DEFAULT_MAX_SECONDS, check_resources
from handarm.cad_out.carve_files import OUTPUT_STEPS, printed_summary, write_carve_outputs
from handarm.carve import CARVE_STEPS, CarveResult, carve, check_carvable
from handarm.design import ArmDesign
from handarm.firmware_bridge.export import (
    controller_config,
    write_controller_json,
    write_header,
)
from handarm.ik.exact import check_clearance
from handarm.summary import design_summary
from handarm.workspace.report import makes_sensitivity, write_workspace_outputs

__all__ = [
    "BuildResult",
    "build",
    "carve_design",
    "export_controller",
    "map_workspace",
]


@dataclasses.dataclass(frozen=True, eq=False)  # holds a CarveResult: identity equality
class BuildResult:
    """What ``build`` made.

    Attributes
    ----------
    design : ArmDesign
        The design built.
    out : Path
        The output folder.
    files : tuple of Path
        Every file written, in the order written.
    carving : handarm.carve.CarveResult
        The carved links and the joint reports (achieved limits).
    """

    design: ArmDesign
    out: Path
    files: tuple[Path, ...]
    carving: CarveResult

    @property
    def achieved_limits(self) -> list[tuple[float, float]]:
        """Joint limits the carved links allow (rad), joints 1..6."""
        return [j.achieved for j in self.carving.joints]


#: What ``carve_design`` writes at the top of its folder: (folders, files); ``{name}`` is
#: the design's name. A test holds it to the files a carving writes.
CARVE_LAYOUT = (
    ("links", "meshes", "parts", "pictures"),
    ("carve.json", "plate.3mf", "{name}.urdf", "{name}.mjcf.xml"),
)
#: What ``build`` writes at the top of its folder (``CARVE_LAYOUT`` and the rest).
BUILD_LAYOUT = (
    CARVE_LAYOUT[0] + ("assembly", "controller", "handle", "workspace"),
    CARVE_LAYOUT[1]
    + ("assembly.html", "bom.csv", "design.toml", "report.html", "sizing.json", "summary.txt")
    + ("tendons.json",),
)


def check_outputs(out, layout: tuple, design: ArmDesign) -> Path:
    """``check_out_dir``, then nothing in the way of ``layout`` (``_outdir.check_layout``)."""
    out = check_out_dir(out)
    folders, files = layout
    check_layout(out, folders, tuple(f.format(name=design.name) for f in files))
    return out


def carve_design(
    design: ArmDesign,
    out: str | os.PathLike[str],
    *,
    resolution_deg: float = 1.0,
    progress: bool = False,
    max_memory: float = DEFAULT_MAX_MEMORY,
    max_seconds: float = DEFAULT_MAX_SECONDS,
):
    """Carve the design's links and write the carving outputs into ``out``.

    Parameters
    ----------
    design : ArmDesign
    out : path
        Output folder: ``meshes/``, ``plate.3mf``, ``links/``, ``carve.json``, ``pictures/``
        and the URDF with meshes.
    resolution_deg : float
        Largest angle between swept poses (degrees, 0 < r <= 10).
    progress : bool
        Show a progress bar.
    max_memory, max_seconds : float
        Refuse (ValueError, with the estimate) a job estimated to need more memory (bytes)
        or time (s) than this; defaults 4 GiB and one hour.

    Returns
    -------
    carving : handarm.carve.CarveResult
    files : list of Path

    Raises
    ------
    ValueError
        If the design cannot be carved (the message names the field).
    """
    check_design(design)
    check_carvable(design)
    check_resources(
        design, resolution_deg=resolution_deg, max_memory=max_memory, max_seconds=max_seconds
    )
    out = check_outputs(out, CARVE_LAYOUT, design)
    total = CARVE_STEPS + OUTPUT_STEPS
    with tqdm(total=total, desc="carving", unit="step", disable=not progress, leave=False) as bar:

        def tick(label: str) -> None:
            bar.set_postfix_str(label)
            bar.update()

        result = carve(design, resolution_deg, progress=tick)
        return result, write_carve_outputs(result, Path(out), progress=tick)


def export_controller(
    design: ArmDesign,
    out: str | os.PathLike[str],
    *,
    calibration=None,
    achieved_limits: Sequence[tuple[float, float]] | None = None,
    max_torque_fraction: float = 1.0,
) -> list[Path]:
    """Write ``controller.json`` and ``arm_config.h`` into ``out``.

    Parameters
    ----------
    design : ArmDesign
    out : path
    calibration : handarm.firmware_bridge.calibration.Calibration, optional
    achieved_limits : sequence of 6 (lower, upper), optional
        Limits the carved links allow (rad); the exported limits are their intersection
        with the design's.
    max_torque_fraction : float
        Max Torque register as a fraction of its maximum (0 < f <= 1).

    Returns
    -------
    list of Path
    """
    out = check_out_dir(out)
    config = controller_config(
        design, calibration, achieved_limits, max_torque_fraction=max_torque_fraction
    )
    return [
        write_controller_json(config, out / "controller.json"),
        write_header(config, out / "arm_config.h"),
    ]


def map_workspace(
    design: ArmDesign,
    out: str | os.PathLike[str],
    *,
    voxel: float = 0.01,
    directions: int = 100,
    threshold: float = 0.5,
    sensitivity: bool = True,
    progress: bool = False,
    max_memory: float = DEFAULT_MAX_MEMORY,
    max_seconds: float = DEFAULT_MAX_SECONDS,
    scene=None,
    clearance: float = 0.0,
) -> list[Path]:
    """Map the workspace and write the map, scores and pictures into ``out``.

    Parameters
    ----------
    design : ArmDesign
    out : path
    voxel : float
        Voxel edge (m).
    directions : int
        Approach directions per voxel.
    threshold : float
        Reachability index counted as dexterous (0 < t <= 1).
    sensitivity : bool
        Also measure how much each joint's limit matters.
    progress : bool
        Show a progress bar over IK queries.
    max_memory, max_seconds : float
        Refuse (ValueError, with the estimate) a job estimated to need more memory (bytes)
        or time (s) than this; defaults 4 GiB and one hour.
    scene : handarm.scene.Scene, optional
        Obstacles (handle frame): map what the printed arm reaches keeping ``clearance``
        (m) from them (no sensitivity screen then).
    clearance : float

    Returns
    -------
    list of Path
    """
    check_design(design)
    check_clearance(clearance, scene)
    _check_map(design, voxel, directions, sensitivity, scene, max_memory, max_seconds)
    if not (isinstance(threshold, (int, float)) and 0.0 < threshold <= 1.0):
        raise ValueError(f"threshold: expected a number in (0, 1], got {threshold!r}")
    out = check_out_dir(out)
    with (
        tqdm(
            desc="workspace", unit="query", unit_scale=True, disable=not progress, leave=False
        ) as bar,
        tqdm(
            desc="sensitivity screen",
            unit="map",
            # no screen (asked off, or in a scene): no empty bar either
            disable=not (progress and makes_sensitivity(sensitivity, scene)),
            leave=False,
        ) as maps,
    ):

        def ticker(b):
            def tick(done: int, total: int) -> None:
                b.total = total
                b.update(done - b.n)

            return tick

        return write_workspace_outputs(
            design,
            Path(out),
            voxel=voxel,
            directions=directions,
            threshold=threshold,
            sensitivity=sensitivity,
            progress=ticker(bar),
            sensitivity_progress=ticker(maps),
            scene=scene,
            clearance=clearance,
        )


def _check_map(design, voxel, directions, sensitivity, scene, max_memory, max_seconds) -> None:
    """Refuse a workspace map (with its sensitivity screen) over the limits, before any work.

    The sensitivity screen costs about as much as the map again (28 coarser maps), and is
    not made in a scene; a scene's queries cost 1.4x (1 box) to 1.9x (10 boxes) a free
    one's (measured).
    """
    sensitivity = makes_sensitivity(sensitivity, scene)
    scene_cost = 1.5 + 0.05 * len(scene) if scene else 1.0
    check_resources(
        design,
        voxel=voxel,
        directions=directions,
        max_memory=max_memory,
        max_seconds=max_seconds,
        time_factor=(3 if sensitivity else 1) * scene_cost,
    )


def _limits_summary(design: ArmDesign, carving) -> str:
    """Summary lines: the joint limits the build uses, and what narrowed them."""
    lines = ["", "joint limits as printed (deg; the URDF, MJCF, controller and map use these):"]
    built = carving.as_built
    rows = zip(built.joint_limits, design.joint_limits, carving.joints, strict=True)
    for k, ((lo, hi), (a, b), report) in enumerate(rows):
        why = [
            s for s, narrowed in zip(report.stopped_by, (lo > a, hi < b), strict=True) if narrowed
        ]
        note = f"  narrowed: {'; '.join(dict.fromkeys(why))}" if why else ""
        lines.append(f"  joint {k + 1}: {math.degrees(lo):8.2f} .. {math.degrees(hi):7.2f}{note}")
    return "\n".join(lines) + "\n"


def _write_tendons(design: ArmDesign, carving, out: Path, summary: Path) -> Path:
    """``tendons.json`` (every cable traced at several poses) and its lines in the summary.

    Cut lengths from the handle's own cable runs, as the bill of materials gives them.
    """
    import json

    from handarm.handle import motor_runs
    from handarm.tendons import tendon_report, tendon_summary

    report = tendon_report(design, carving, samples=6, motor_run=motor_runs(design))
    path = out / "tendons.json"
    write_text_atomic(path, json.dumps(report, indent=2) + "\n")
    write_text_atomic(summary, summary.read_text() + tendon_summary(report))
    return path


def _write_handle(design: ArmDesign, carving, out: Path, summary: Path) -> list[Path]:
    """Handle meshes, bom.csv, assembly.html, the assembled picture; balance in the summary."""
    from handarm.cad_out.handle_files import handle_summary, write_handle_outputs
    from handarm.handle import handle

    h = handle(design, carving)
    paths = write_handle_outputs(h, carving, out)
    write_text_atomic(summary, summary.read_text() + handle_summary(h))
    return paths


def _write_sizing(design: ArmDesign, carving, out: Path) -> Path:
    """``sizing.json``: payload and pulley sizing with the carved link masses (cvxpy)."""
    from handarm.firmware_bridge.sizing import sizing_report

    path = out / "sizing.json"
    write_text_atomic(path, json.dumps(sizing_report(design, carving=carving), indent=2) + "\n")
    return path


def build(
    design: ArmDesign,
    out: str | os.PathLike[str],
    *,
    resolution_deg: float = 1.0,
    voxel: float = 0.01,
    directions: int = 100,
    progress: bool = False,
    max_memory: float = DEFAULT_MAX_MEMORY,
    max_seconds: float = DEFAULT_MAX_SECONDS,
    scene=None,
    clearance: float = 0.0,
) -> BuildResult:
    """Everything for one design, written into ``out``: the main job.

    Writes the design TOML, a text summary, the carving (meshes, 3MF plate, link
    properties, pictures, the URDF and the MuJoCo model), the handle (``handle/``: saddles,
    bed with grip, motor pulleys; ``bom.csv``, ``assembly.html``), ``tendons.json`` (every
    cable's path checked at several poses, its lengths and cut length), ``controller/``
    (the servo controller's files with the achieved limits), ``workspace/`` (the
    reachability map and scores) and, last, ``report.html`` (the interactive page of all
    of it, see ``handarm.report``).

    Parameters
    ----------
    design : ArmDesign
    out : path
        Output folder (created if missing).
    resolution_deg : float
        Carving resolution (degrees).
    voxel, directions : float, int
        Workspace map settings (m, count).
    progress : bool
        Show progress bars.
    max_memory, max_seconds : float
        Refuse (ValueError, with the estimate) a job estimated to need more memory (bytes)
        or time (s) than this; defaults 4 GiB and one hour.
    scene : handarm.scene.Scene, optional
        Obstacles (handle frame) around the arm: the workspace map counts only what the
        printed arm reaches keeping ``clearance`` (m) from them, and the report draws them.
    clearance : float

    Returns
    -------
    BuildResult

    Raises
    ------
    ValueError
        If the design cannot be built (the message names the field).

    Examples
    --------
    >>> import handarm, tempfile
    >>> result = handarm.build(handarm.ArmDesign(), tempfile.mkdtemp())  # doctest: +SKIP
    >>> sorted(p.name for p in result.files)[:2]  # doctest: +SKIP
    ['arm_config.h', 'arm_straight.png']
    """
    check_design(design)
    check_carvable(design)
    check_clearance(clearance, scene)  # before the carving: a minute of work
    out = check_outputs(out, BUILD_LAYOUT, design)
    limits = {"max_memory": max_memory, "max_seconds": max_seconds}
    _check_map(design, voxel, directions, True, scene, max_memory, max_seconds)
    check_resources(design, resolution_deg=resolution_deg, **limits)
    with build_folder(out, design.to_dict()) as files:
        files.append(design.to_toml(out / "design.toml"))
        summary = out / "summary.txt"
        write_text_atomic(summary, design_summary(design))
        files.append(summary)
        carving, paths = carve_design(
            design, out, resolution_deg=resolution_deg, progress=progress, **limits
        )
        files += paths
        # from here on the arm as printed: requested limits narrowed to what the links allow
        built = carving.as_built
        lines = _limits_summary(design, carving) + printed_summary(carving.printed, design.min_wall)
        write_text_atomic(summary, summary.read_text() + lines)
        files.append(_write_tendons(built, carving, out, summary))
        files += _write_handle(built, carving, out, summary)
        files += export_controller(built, out / "controller")
        files.append(_write_sizing(built, carving, out))
        files += map_workspace(
            built,
            out / "workspace",
            voxel=voxel,
            directions=directions,
            progress=progress,
            scene=scene,
            clearance=clearance,
            **limits,
        )
        from handarm.report import write_report  # plotly: loaded only when a report is made

        files.append(write_report(out))
    return BuildResult(design, out, tuple(files), carving)
