"""A picture of the arm reaching around obstacles: the scene and the ranges that remain.

``scene_picture`` draws the obstacles of a ``handarm.scene.Scene`` (boxes as their faces,
spheres and capsules as wire surfaces), the target, and for every solution range of an
``IKResult`` solved in that scene the arm's centre line at several points along the range
(thin) and at its representative (thick), one colour per range. Two views: a perspective one
and the view from above.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from handarm._figures import new_figure, save_png
from handarm.design import ArmDesign
from handarm.ik.exact import configurations_along
from handarm.ik.results import IKResult
from handarm.kinematics import joint_positions
from handarm.scene import Scene

__all__ = ["scene_picture"]

_COLOURS = ("tab:blue", "tab:orange", "tab:green", "tab:purple", "tab:brown", "tab:pink")
_BOX_FACES = ((0, 1, 3, 2), (4, 5, 7, 6), (0, 1, 5, 4), (2, 3, 7, 6), (0, 2, 6, 4), (1, 3, 7, 5))


def _box_faces(row: np.ndarray) -> list[np.ndarray]:
    centre, rot, half = row[1:4], row[4:13].reshape(3, 3), row[13:16]
    signs = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], float)
    corners = centre + (signs * half) @ rot.T
    return [corners[list(face)] for face in _BOX_FACES]


def _sphere_mesh(centre, radius: float, n: int = 14):
    u, v = np.meshgrid(np.linspace(0, 2 * math.pi, n), np.linspace(0, math.pi, n // 2 + 1))
    return (
        centre[0] + radius * np.cos(u) * np.sin(v),
        centre[1] + radius * np.sin(u) * np.sin(v),
        centre[2] + radius * np.cos(v),
    )


def _draw_scene(ax, scene: Scene) -> None:
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    for row in scene.obstacles:
        kind = int(row[0])
        if kind == 2:
            box = Poly3DCollection(_box_faces(row), facecolor="0.6", edgecolor="0.3", alpha=0.35)
            ax.add_collection3d(box)
        elif kind == 0:
            ax.plot_wireframe(*_sphere_mesh(row[1:4], row[4]), color="0.45", linewidth=0.4)
        else:
            for end in (row[1:4], row[4:7]):
                ax.plot_wireframe(*_sphere_mesh(end, row[7], 10), color="0.45", linewidth=0.3)
            ax.plot(*np.stack([row[1:4], row[4:7]]).T, color="0.45", linewidth=4, alpha=0.6)


def _extent(lines: list[np.ndarray], scene: Scene, target: np.ndarray):
    """Centre and half-width of a cube holding the arm lines, the obstacles and the target."""
    pts = [np.zeros((1, 3)), target[None]] + list(lines)
    for row in scene.obstacles:
        kind = int(row[0])
        if kind == 2:
            pts.append(np.concatenate(_box_faces(row)))
        elif kind == 0:
            pts.append(row[1:4] + row[4] * np.vstack([np.eye(3), -np.eye(3)]))
        else:
            for end in (row[1:4], row[4:7]):
                pts.append(end + row[7] * np.vstack([np.eye(3), -np.eye(3)]))
    pts = np.concatenate(pts)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    return 0.5 * (lo + hi), 0.55 * float(np.max(hi - lo)) + 0.01


def _range_configurations(design: ArmDesign, result: IKResult, k: int, samples: int):
    lo, hi = result.intervals[k]
    us = np.linspace(lo, hi, samples + 2)[1:-1] if hi > lo else np.array([lo])
    q, ok = configurations_along(
        design,
        result.achieved_position,
        result.achieved_direction,
        result.branches[k],
        us,
        azimuth=result.azimuth,
    )
    return q[ok]


def scene_picture(
    design: ArmDesign,
    scene: Scene,
    result: IKResult,
    path: str | os.PathLike[str],
    *,
    samples: int = 5,
    title: str | None = None,
) -> Path:
    """Draw the scene, the target and the arm along every range of ``result`` into ``path``.

    Parameters
    ----------
    design : ArmDesign
    scene : Scene
        The obstacles the result was solved with (handle frame).
    result : IKResult
        From ``ik.solve(..., scene=scene)``.
    path : path
        PNG file (written atomically).
    samples : int
        Configurations drawn inside each range besides its representative (>= 0).
    title : str, optional

    Returns
    -------
    Path
    """
    if isinstance(samples, bool) or not isinstance(samples, int) or samples < 0:
        raise ValueError(f"samples: expected an integer >= 0, got {samples!r}")
    fig = new_figure((11.0, 5.2))
    target = np.asarray(result.achieved_position, float)
    lines = []
    for k in range(result.count):
        colour = _COLOURS[k % len(_COLOURS)]
        for q in _range_configurations(design, result, k, samples):
            lines.append((joint_positions(design, q), colour, 0.8, 0.45))
        lines.append((joint_positions(design, result.solutions[k]), colour, 2.6, 1.0))
    centre, half = _extent([pts for pts, *_ in lines], scene, target)
    for i, (elev, azim) in enumerate(((24, -60), (90, -90))):
        ax = fig.add_subplot(1, 2, i + 1, projection="3d")
        _draw_scene(ax, scene)
        for pts, colour, width, alpha in lines:
            ax.plot(*pts.T, color=colour, linewidth=width, alpha=alpha)
        ax.scatter(*target, color="red", s=30, depthshade=False, label="target")
        ax.scatter(0, 0, 0, color="black", s=20, depthshade=False, label="joint 1")
        ax.set(**{f"{a}lim": (c - half, c + half) for a, c in zip("xyz", centre, strict=True)})
        ax.set_box_aspect((1, 1, 1))
        ax.view_init(elev=elev, azim=azim)
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        if i == 0:
            ax.set_zlabel("z (m)")
        else:
            ax.set_zticks([])
        ax.set_title("perspective" if i == 0 else "from above", fontsize=9)
    if title is None:
        kept = f"{result.count} range{'s' if result.count != 1 else ''}"
        title = f"{kept} clear of {len(scene)} obstacle{'s' if len(scene) != 1 else ''}"
        if 0 < result.reached_dof < 5:
            title += f" (degraded to {result.reached_dof} DoF)"
        if result.blocked_by:
            title += f"; exact solutions blocked by {', '.join(result.blocked_by)}"
    fig.suptitle(title, fontsize=10)
    return save_png(fig, path)
