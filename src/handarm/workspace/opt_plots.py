"""Pictures of an optimization: PNG (matplotlib) and one interactive HTML page (plotly).

Pareto fronts (every point labelled with its trial number in the PNG, hoverable in the
HTML), hypervolume history, parallel coordinates, parameter importance per objective.
"""

from __future__ import annotations

import itertools
import warnings
from pathlib import Path

import numpy as np

from handarm._io import write_bytes_atomic, write_text_atomic

__all__ = ["optimization_pictures"]


def _label(o) -> str:
    return f"{o.name} ({o.unit})" if o.unit else o.name


def _hv_history(opt, rows) -> list[float]:
    from handarm.workspace.optimize import _pareto, _values, hypervolume

    out = []
    ordered = sorted(rows, key=lambda r: r["trial"])
    for n in range(1, len(ordered) + 1):
        part = ordered[:n]
        front = [r for r, p in zip(part, _pareto(opt, part), strict=True) if p]
        out.append(hypervolume(opt, [_values(opt, r["measurements"]) for r in front]))
    return out


def _importances(opt, study) -> dict:
    import optuna

    out = {}
    complete = [t for t in study.get_trials(deepcopy=False) if t.state.name == "COMPLETE"]
    if len(complete) < 3 or len(opt.variables) < 2:
        return out
    for i, o in enumerate(opt.objectives):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                out[o.name] = optuna.importance.get_param_importances(
                    study, target=lambda t, i=i: t.values[i]
                )
        except (ValueError, RuntimeError, ZeroDivisionError):
            continue
    return out


def optimization_pictures(opt, study, rows, pareto, folder: Path) -> list[Path]:
    """Write the pictures into ``folder``; returns their paths.

    ``pareto.png``, ``hypervolume.png``, ``parallel.png``, ``importance.png`` and
    ``optimize.html`` (the same, interactive: hover a point for its trial and variables).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import plotly.graph_objects as go
    import plotly.io as pio

    from handarm.workspace.optimize import _values

    folder = Path(folder)
    paths, figures = [], []
    feas = [r for r in rows if r["feasible"]]
    front_ids = {r["trial"] for r, p in zip(rows, pareto, strict=True) if p}
    pairs = list(itertools.combinations(range(len(opt.objectives)), 2)) or [(0, 0)]

    def save(fig, name):
        buf = __import__("io").BytesIO()
        fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
        plt.close(fig)
        write_bytes_atomic(folder / name, buf.getvalue())
        paths.append(folder / name)

    # Pareto fronts
    fig, axes = plt.subplots(1, len(pairs), figsize=(5.5 * len(pairs), 4.5), squeeze=False)
    for ax, (a, b) in zip(axes[0], pairs, strict=True):
        oa, ob = opt.objectives[a], opt.objectives[b]
        for r in feas:
            v = _values(opt, r["measurements"])
            on = r["trial"] in front_ids
            ax.scatter(v[a], v[b], c="tab:red" if on else "0.6", s=30 if on else 14, zorder=3)
            ax.annotate(
                str(r["trial"]), (v[a], v[b]), fontsize=6, xytext=(2, 2), textcoords="offset points"
            )
        ax.set_xlabel(_label(oa))
        ax.set_ylabel(_label(ob))
        ax.grid(alpha=0.3)
    axes[0][0].set_title(f"{opt.name}: feasible trials (front in red)")
    save(fig, "pareto.png")
    for a, b in pairs:
        oa, ob = opt.objectives[a], opt.objectives[b]
        vals = [_values(opt, r["measurements"]) for r in feas]
        figures.append(
            go.Figure(
                go.Scatter(
                    x=[v[a] for v in vals],
                    y=[v[b] for v in vals],
                    mode="markers",
                    marker={"color": ["red" if r["trial"] in front_ids else "grey" for r in feas]},
                    hovertext=[
                        f"trial {r['trial']}<br>"
                        + "<br>".join(f"{k} = {v}" for k, v in r["params"].items())
                        for r in feas
                    ],
                ),
                layout={
                    "title": "Pareto front",
                    "xaxis_title": _label(oa),
                    "yaxis_title": _label(ob),
                },
            )
        )

    # hypervolume history
    hv = _hv_history(opt, rows)
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(range(1, len(hv) + 1), hv, "-o", ms=3)
    ax.set_xlabel("trials finished")
    ax.set_ylabel("hypervolume (product of objective units)")
    ax.grid(alpha=0.3)
    save(fig, "hypervolume.png")
    figures.append(
        go.Figure(
            go.Scatter(x=list(range(1, len(hv) + 1)), y=hv),
            layout={"title": "hypervolume history", "xaxis_title": "trials finished"},
        )
    )

    # parallel coordinates (numeric variables and objectives of feasible trials)
    numeric = [v.name for v in opt.variables if v.choices is None]
    cols = numeric + [_label(o) for o in opt.objectives]
    table = np.array(
        [[r["params"][k] for k in numeric] + _values(opt, r["measurements"]) for r in feas]
    ).reshape(len(feas), len(cols))
    fig, ax = plt.subplots(figsize=(1.6 * len(cols) + 2, 4))
    if len(feas):
        lo, hi = table.min(axis=0), table.max(axis=0)
        scaled = (table - lo) / np.where(hi > lo, hi - lo, 1.0)
        for r, row in zip(feas, scaled, strict=True):
            on = r["trial"] in front_ids
            ax.plot(
                row, color="tab:red" if on else "0.7", lw=1.4 if on else 0.6, zorder=3 if on else 1
            )
    ax.set_xticks(range(len(cols)), cols, rotation=20, fontsize=7)
    ax.set_yticks([])
    ax.set_title("parallel coordinates (each axis from its min to its max; front in red)")
    save(fig, "parallel.png")
    if len(feas):
        figures.append(
            go.Figure(
                go.Parcoords(
                    dimensions=[{"label": c, "values": table[:, i]} for i, c in enumerate(cols)],
                    line={
                        "color": [1 if r["trial"] in front_ids else 0 for r in feas],
                        "colorscale": [[0, "grey"], [1, "red"]],
                    },
                ),
                layout={"title": "parallel coordinates"},
            )
        )

    # importance
    imp = _importances(opt, study)
    fig, ax = plt.subplots(figsize=(6, 0.5 + 0.4 * max(1, len(opt.variables)) * max(1, len(imp))))
    labels, values = [], []
    for obj, d in imp.items():
        for k, v in d.items():
            labels.append(f"{obj}: {k}")
            values.append(v)
    ax.barh(labels or ["(too few trials)"], values or [0.0])
    ax.set_xlabel("importance (fANOVA share of variance)")
    save(fig, "importance.png")
    if labels:
        figures.append(
            go.Figure(
                go.Bar(x=values, y=labels, orientation="h"),
                layout={"title": "parameter importance"},
            )
        )

    parts = [
        pio.to_html(f, full_html=False, include_plotlyjs=(i == 0)) for i, f in enumerate(figures)
    ]
    html = (
        f"<!doctype html><html><head><meta charset='utf-8'><title>{opt.name}</title></head>"
        f"<body><h1>{opt.name}</h1>" + "\n".join(parts) + "</body></html>"
    )
    write_text_atomic(folder / "optimize.html", html)
    paths.append(folder / "optimize.html")
    return paths
