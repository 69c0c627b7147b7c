"""Plotly figures of reachability maps (lengths in mm)."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["workspace_figures", "slice_heatmap", "MAX_CELLS"]

#: Largest number of grid points per axis drawn in 3D; finer maps are subsampled for display.
MAX_CELLS = 40


def _handle_trace_3d(handle_m: float):
    import plotly.graph_objects as go

    return go.Scatter3d(
        x=[-handle_m * 1000.0, 0.0],
        y=[0.0, 0.0],
        z=[0.0, 0.0],
        mode="lines+markers",
        line={"color": "black", "width": 10},
        marker={"size": 4, "color": "black"},
        name="handle (l0)",
    )


def slice_heatmap(centres, index, plane: str, handle_m: float, title: str):
    """Heatmap of the reachability index on the plane z = 0 ("xy") or y = 0 ("xz")."""
    import plotly.graph_objects as go

    mid = int(np.argmin(np.abs(centres)))
    mm = np.asarray(centres) * 1000.0
    if plane == "xy":
        values, ylabel = index[:, :, mid].T, "y (mm)"
    else:
        values, ylabel = index[:, mid, :].T, "z (mm)"
    fig = go.Figure(
        go.Heatmap(
            x=mm,
            y=mm,
            z=np.where(values > 0, values, np.nan),
            zmin=0.0,
            zmax=1.0,
            colorscale="Viridis",
            colorbar={"title": "index"},
            hovertemplate="x %{x:.0f} mm<br>%{y:.0f} mm<br>index %{z:.2f}<extra></extra>",
        )
    )
    fig.add_trace(
        go.Scatter(
            x=[-handle_m * 1000.0, 0.0],
            y=[0.0, 0.0],
            mode="lines+markers",
            line={"color": "red", "width": 5},
            name="handle (l0)",
        )
    )
    fig.update_layout(
        title=title,
        xaxis={"title": "x (mm)"},
        yaxis={"title": ylabel, "scaleanchor": "x"},
        legend={"x": 0, "y": 1},
    )
    return fig


def workspace_figures(centres, index, handle_m: float) -> list:
    """3D iso-surfaces of the reachability index, then the xy and xz slices.

    Parameters
    ----------
    centres : ndarray, shape (n,)
        Voxel centres along each axis (m).
    index : ndarray, shape (n, n, n)
        Reachability index (fraction of directions reached, 0..1).
    handle_m : float
        Length of the handle l0 (m), drawn from (-handle, 0, 0) to the base joint.

    Returns
    -------
    list of plotly.graph_objects.Figure
    """
    import plotly.graph_objects as go

    centres = np.asarray(centres, dtype=float)
    index = np.asarray(index, dtype=float)
    step = max(1, math.ceil(len(centres) / MAX_CELLS))
    c = centres[::step] * 1000.0
    sub = index[::step, ::step, ::step]
    x, y, z = np.meshgrid(c, c, c, indexing="ij")
    fig = go.Figure(
        go.Isosurface(
            x=x.ravel().astype(np.float32),
            y=y.ravel().astype(np.float32),
            z=z.ravel().astype(np.float32),
            value=sub.ravel().astype(np.float32),
            isomin=0.05,
            isomax=0.9,
            surface_count=3,
            opacity=0.35,
            colorscale="Viridis",
            cmin=0.0,
            cmax=1.0,
            caps={"x_show": False, "y_show": False, "z_show": False},
            colorbar={"title": "index"},
            name="reachability index",
        )
    )
    fig.add_trace(_handle_trace_3d(handle_m))
    fig.update_layout(
        title="workspace: iso-surfaces of the reachability index, 3 levels from 0.05 to 0.9 (mm)",
        scene={
            "aspectmode": "data",
            "xaxis": {"title": "x (mm)"},
            "yaxis": {"title": "y (mm)"},
            "zaxis": {"title": "z (mm)"},
        },
    )
    return [
        fig,
        slice_heatmap(centres, index, "xy", handle_m, "slice z = 0: reachability index"),
        slice_heatmap(centres, index, "xz", handle_m, "slice y = 0: reachability index"),
    ]


def obstacle_traces(rows, names) -> list:
    """Plotly meshes of a scene's obstacles (``handarm.scene`` rows, m) in mm.

    Each obstacle is drawn as the convex hull of points on its surface: a box's corners, a
    sphere's and a capsule's end spheres sampled on a latitude-longitude grid.
    """
    import plotly.graph_objects as go

    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 16), np.linspace(0, np.pi, 9))
    unit = np.stack([np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v)], -1).reshape(-1, 3)
    corners = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], float)
    traces = []
    for row, name in zip(np.asarray(rows, float), names, strict=True):
        kind = int(row[0])
        if kind == 2:
            pts = row[1:4] + (corners * row[13:16]) @ row[4:13].reshape(3, 3).T
        elif kind == 0:
            pts = row[1:4] + row[4] * unit
        else:
            pts = np.concatenate([row[1:4] + row[7] * unit, row[4:7] + row[7] * unit])
        x, y, z = (pts * 1000.0).T
        traces.append(go.Mesh3d(x=x, y=y, z=z, alphahull=0, color="grey", opacity=0.55, name=name))
    return traces
