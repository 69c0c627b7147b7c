"""The main job as library calls: carve, export, map, and ``build`` that does all of them.

``handarm.build(design, out)`` writes everything for one design and returns a
``BuildResult`` listing what it wrote. The ``handarm`` command is a thin layer over these
functions: it parses arguments, calls them and prints.

Progress bars (tqdm, on standard error) are shown when ``progress=True``.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Sequence
from pathlib import Path

from tqdm import tqdm

from handarm._checks import check_design
from handarm._io import write_text_atomic
from handarm.cad_out.carve_files import OUTPUT_STEPS, write_carve_outputs
from handarm.carve import CARVE_STEPS, CarveResult, carve, check_carvable
from handarm.design import ArmDesign
from handarm.firmware_bridge.export import (
    controller_config,
    write_controller_json,
    write_header,
)
from handarm.summary import design_summary
from handarm.workspace.report import write_workspace_outputs

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


def carve_design(
    design: ArmDesign,
    out: str | os.PathLike[str],
    *,
    resolution_deg: float = 1.0,
    progress: bool = False,
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
    config = controller_config(
        design, calibration, achieved_limits, max_torque_fraction=max_torque_fraction
    )
    out = Path(out)
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

    Returns
    -------
    list of Path
    """
    with tqdm(
        desc="workspace", unit="query", unit_scale=True, disable=not progress, leave=False
    ) as bar:

        def tick(done: int, total: int) -> None:
            bar.total = total
            bar.update(done - bar.n)

        return write_workspace_outputs(
            design,
            Path(out),
            voxel=voxel,
            directions=directions,
            threshold=threshold,
            sensitivity=sensitivity,
            progress=tick,
        )


def build(
    design: ArmDesign,
    out: str | os.PathLike[str],
    *,
    resolution_deg: float = 1.0,
    voxel: float = 0.01,
    directions: int = 100,
    progress: bool = False,
) -> BuildResult:
    """Everything for one design, written into ``out``: the main job.

    Writes the design TOML, a text summary, the carving (meshes, 3MF plate, link
    properties, pictures, the URDF with meshes), ``controller/`` (the servo controller's
    files with the achieved limits) and ``workspace/`` (the reachability map and scores).

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
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    files = [design.to_toml(out / "design.toml")]
    summary = out / "summary.txt"
    write_text_atomic(summary, design_summary(design))
    files.append(summary)
    carving, paths = carve_design(design, out, resolution_deg=resolution_deg, progress=progress)
    files += paths
    achieved = [j.achieved for j in carving.joints]
    files += export_controller(design, out / "controller", achieved_limits=achieved)
    files += map_workspace(
        design, out / "workspace", voxel=voxel, directions=directions, progress=progress
    )
    return BuildResult(design, out, tuple(files), carving)
