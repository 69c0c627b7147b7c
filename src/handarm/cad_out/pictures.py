"""PNG pictures of carved links and of the assembled arm (matplotlib, no screen needed)."""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
from matplotlib.colors import to_rgb
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

from handarm._figures import new_figure, save_png
from handarm.carve.carving import CarveResult
from handarm.carve.properties import to_trimesh
from handarm.kinematics import joint_frames

__all__ = ["link_picture", "arm_picture", "folded_pose", "fold_from_limits"]

_COLOURS = ["#5b6770", "#2f7ebc", "#e0892b", "#3a9e5c", "#c0392b", "#8e5cc2", "#d4a017"]


def _draw(ax, mesh, colour):
    tris = mesh.vertices[mesh.faces]
    normals = mesh.face_normals
    light = np.array([0.4, -0.5, 0.77])
    shade = 0.45 + 0.55 * np.clip(normals @ light, 0, 1)
    rgb = np.array(to_rgb(colour))
    faces = np.clip(rgb[None, :] * shade[:, None], 0, 1)
    ax.add_collection3d(Poly3DCollection(tris, facecolors=faces, edgecolors="none"))


def _frame_axes(ax, points, title):
    lo, hi = points.min(axis=0), points.max(axis=0)
    centre, half = (lo + hi) / 2, (hi - lo).max() / 2 * 1.05
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_zlim(centre[2] - half, centre[2] + half)
    ax.set_box_aspect((1, 1, 1))
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_zlabel("z (mm)")
    ax.set_title(title)


def link_picture(result: CarveResult, k: int, path: str | os.PathLike[str]) -> Path:
    """Picture of carved link k in its link frame (mm)."""
    link = result.links[k]
    mesh = to_trimesh(link.solid)
    fig = new_figure((5, 4.5))
    ax = fig.add_subplot(projection="3d")
    _draw(ax, mesh, _COLOURS[k])
    ax.view_init(elev=28, azim=-60)
    _frame_axes(ax, mesh.vertices, f"{link.name} (carved), {mesh.volume:.0f} mm³")
    return save_png(fig, path)


def folded_pose(result: CarveResult) -> np.ndarray:
    """The paper's fold (figure 4): joints 2 and 5 at their limit, 1, 3 and 4, 6 back by half."""
    return fold_from_limits([j.carved for j in result.joints])


def fold_from_limits(lim) -> np.ndarray:
    """The paper's fold (see ``folded_pose``) for joint limits ``lim``: 6 (lo, hi) pairs, rad."""
    q = np.zeros(6)
    for mid in (1, 4):
        h = min(lim[mid][1], math.radians(179.0))
        q[mid] = h
        q[mid - 1] = max(-h / 2, lim[mid - 1][0])
        q[mid + 1] = max(-h / 2, lim[mid + 1][0])
    return q


def arm_picture(result: CarveResult, q, path: str | os.PathLike[str], title: str) -> Path:
    """Picture of the assembled arm at configuration q (rad), in the base frame (mm)."""
    frames = joint_frames(result.design, np.asarray(q, dtype=float))
    fig = new_figure((7, 6))
    ax = fig.add_subplot(projection="3d")
    points = []
    for k, link in enumerate(result.links):
        mesh = to_trimesh(link.solid)
        if k > 0:
            m = frames[k - 1].copy()
            m[:3, 3] *= 1000.0
            mesh.apply_transform(m)
        _draw(ax, mesh, _COLOURS[k])
        points.append(mesh.vertices)
    ax.view_init(elev=30, azim=-55)
    _frame_axes(ax, np.concatenate(points), title)
    return save_png(fig, path)
