"""Pictures of workspace maps and trade studies (matplotlib PNG, real axes in mm)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from handarm._figures import new_figure, save_png
from handarm.workspace.maps import ReachabilityMap

__all__ = ["slice_picture", "pareto_picture", "sensitivity_picture"]


def slice_picture(
    wmap: ReachabilityMap, plane: str, path: str | os.PathLike[str], title: str = ""
) -> Path:
    """Heat map of the reachability index in the plane z = 0 ("xy") or y = 0 ("xz")."""
    c = wmap.centres * 1000.0
    mid = len(c) // 2  # the voxels just above the plane (the grid has no voxel on it)
    if plane == "xy":
        data, ylabel = wmap.index[:, :, mid].T, "y (mm)"
    elif plane == "xz":
        data, ylabel = wmap.index[:, mid, :].T, "z (mm)"
    else:
        raise ValueError(f"plane: expected 'xy' or 'xz', got {plane!r}")
    h = wmap.voxel * 500.0
    fig = new_figure((6, 5))
    ax = fig.add_subplot()
    masked = np.ma.masked_where(data <= 0, data)
    im = ax.imshow(
        masked,
        origin="lower",
        extent=(c[0] - h, c[-1] + h, c[0] - h, c[-1] + h),
        cmap="viridis",
        vmin=0,
        vmax=1,
    )
    ax.plot([-wmap.handle * 1000, 0], [0, 0], color="0.2", lw=3, label="handle (l0)")
    fig.colorbar(im, ax=ax, label="reachability index (fraction of directions)")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel(ylabel)
    ax.set_xlim(c[0] - h, c[-1] + h)
    ax.set_ylim(c[0] - h, c[-1] + h)
    ax.set_title(title or f"reachability, {plane} slice, {wmap.voxel * 1000:g} mm voxels")
    ax.legend(loc="lower left", fontsize=8)
    return save_png(fig, path)


def pareto_picture(rows, path, x="mass_kg", y="dexterous_volume_m3") -> Path:
    """Every design as a point (dexterous volume against link mass), the front marked.

    The front is over four objectives (``study_results.PARETO_OBJECTIVES``), so front
    points in this projection need not form a staircase.
    """
    fig = new_figure((6.5, 4.5))
    ax = fig.add_subplot()
    xs = np.array([r[x] for r in rows]) * (1000.0 if x == "mass_kg" else 1.0)
    ys = np.array([r[y] for r in rows]) * (1000.0 if y.endswith("_m3") else 1.0)
    front = np.array([r["pareto"] for r in rows], dtype=bool)
    ax.scatter(xs[~front], ys[~front], color="0.6", label="dominated")
    order = np.argsort(xs[front])
    ax.plot(xs[front][order], ys[front][order], "o", color="tab:red", label="Pareto front")
    for r, px, py in zip(rows, xs, ys, strict=True):
        if r["pareto"]:
            ax.annotate(r["name"], (px, py), fontsize=7, xytext=(3, 3), textcoords="offset points")
    ax.set_xlabel("carved link mass (g)" if x == "mass_kg" else x)
    ax.set_ylabel("dexterous volume (L)" if y == "dexterous_volume_m3" else y)
    ax.legend()
    ax.set_title("trade study: workspace against mass")
    return save_png(fig, path)


def sensitivity_picture(sensitivity: dict, path) -> Path:
    """Bar chart: Morris mu* of each joint's limit on both volumes, with 95 % intervals."""
    rows = sensitivity["joints"]
    joints = [r["joint"] for r in rows]
    fig = new_figure((6, 4))
    ax = fig.add_subplot()
    w = 0.38
    x = np.arange(len(joints))
    for off, name in ((-w / 2, "reachable"), (w / 2, "dexterous")):
        ax.bar(
            x + off,
            [r[f"{name}_mu_star_L"] for r in rows],
            w,
            yerr=[r[f"{name}_mu_star_conf_L"] for r in rows],
            capsize=3,
            label=name,
        )
    ax.set_xticks(x, [f"joint {j}" for j in joints])
    ax.set_ylabel("Morris mu* (L)")
    lo, hi = sensitivity["range_deg"]
    ax.set_title(f"global sensitivity, limits in {lo:g}..{hi:g} deg")
    ax.legend()
    return save_png(fig, path)
