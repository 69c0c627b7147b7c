"""The report of a study (``results.csv``) or an optimization (``trials.csv``) folder.

Sections: the Pareto front(s) of the objectives (hover shows a design's variables; a click
opens the design's build report when one exists under the folder), the hypervolume of the
front as trials accumulate (optimizations), parallel coordinates of variables and
measurements, sensitivity (rank correlation of each variable with each objective, and the
study's per-joint sensitivity when present), and a side-by-side comparison of two designs
chosen in the page: their variables, measurements, achieved limits and the difference of
their workspace maps (slices) when the maps are in the folder.
"""

from __future__ import annotations

import csv
import dataclasses
import itertools
import json
import math
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from handarm.report._data import read_json, unit_of
from handarm.report._page import Page
from handarm.workspace.study_results import PARETO_OBJECTIVES

__all__ = ["Objective", "study_report", "hypervolume", "hypervolume_history"]


@dataclasses.dataclass(frozen=True)
class Objective:
    """One objective: column ``key`` of the table, ``direction`` "maximize" or "minimize"."""

    key: str
    direction: str
    unit: str = ""
    reference: float | None = None


#: A study's front: the objectives of handarm.workspace.study_results.pareto_front, read
#: from there (volumes and the thinnest cross-section up, mass down), in physical units.
STUDY_OBJECTIVES = tuple(
    Objective(key, "maximize" if sign > 0 else "minimize", unit_of(key)[1])
    for key, sign in PARETO_OBJECTIVES
)

_COMPARE_JS = r"""
(function() {
  const D = %(data)s;
  const a = document.getElementById('cmpA'), b = document.getElementById('cmpB');
  D.rows.forEach((r, i) => { [a, b].forEach(s => {
    const o = document.createElement('option');
    o.value = i; o.textContent = r.name; s.appendChild(o); }); });
  if (D.rows.length > 1) b.value = 1;
  function fmt(v) {
    if (typeof v === 'number') return Math.abs(v) >= 1e4 || (Math.abs(v) < 1e-3 && v !== 0) ?
      v.toExponential(3) : (+v.toPrecision(4)).toString();
    return v === null || v === undefined ? '' : String(v);
  }
  function update() {
    const A = D.rows[+a.value], B = D.rows[+b.value];
    let h = '<table><tr><th class="t">quantity</th><th>' + A.name + '</th><th>' + B.name +
      '</th><th>B − A</th></tr>';
    D.columns.forEach(c => {
      const x = A.values[c.key], y = B.values[c.key];
      const d = (typeof x === 'number' && typeof y === 'number') ? fmt(y - x) : '';
      h += '<tr><td class="t">' + c.label + '</td><td>' + fmt(x) + '</td><td>' + fmt(y) +
        '</td><td>' + d + '</td></tr>';
    });
    document.getElementById('cmpTable').innerHTML = h + '</table>';
    const note = document.getElementById('cmpNote');
    if (D.maps && A.map !== null && B.map !== null) {
      const ma = D.maps[A.map], mb = D.maps[B.map], out = [];
      ['xy', 'xz'].forEach((p, n) => {
        const z = ma[p].map((row, i) => row.map((v, j) => mb[p][i][j] - v));
        Plotly.restyle('cmpMap', {z: [z]}, [n]);
      });
      note.textContent = 'Map difference: index of B minus index of A.';
    } else {
      note.textContent = 'No maps of these two designs in this folder.';
    }
    window.handarmCompare = {a: +a.value, b: +b.value};
  }
  a.addEventListener('change', update); b.addEventListener('change', update);
  update();
})();
"""

_CLICK_JS = r"""
(function() {
  const gd = document.getElementById(%(div)s);
  gd.on('plotly_click', ev => {
    const url = ev.points[0].customdata && ev.points[0].customdata[0];
    if (url) window.open(url, '_blank');
  });
})();
"""


def _number(text: str):
    """A CSV cell as a number where it is one; True/False as bool."""
    if text in ("True", "False"):
        return text == "True"
    try:
        v = float(text)
    except ValueError:
        return text
    return int(v) if v.is_integer() and "." not in text and "e" not in text.lower() else v


def _read_csv(path: Path, columns: Iterable[str] = ()) -> list[dict]:
    """The rows of a results table, numbers as numbers; ValueError naming the file.

    ``columns``: those the page needs (a table from another tool, or cut short, lacks them).
    """
    try:
        with path.open(newline="") as fh:
            reader = csv.DictReader(fh)
            rows = [{k: _number(v) for k, v in row.items()} for row in reader]
            header = reader.fieldnames or []
    except (UnicodeDecodeError, csv.Error) as exc:
        raise ValueError(f"{path}: not a readable CSV table ({exc})") from None
    missing = [c for c in columns if c not in header]
    if missing:
        raise ValueError(f"{path}: column {missing[0]!r} missing (columns: {list(header)})")
    return rows


def hypervolume(points, reference) -> float:
    """Hypervolume dominated by ``points`` up to ``reference`` (all objectives minimized).

    Parameters
    ----------
    points : array-like, shape (n, d)
    reference : array-like, shape (d,)
        Points not strictly below the reference in every objective add nothing.

    Returns
    -------
    float
        Exact, by slicing along the last objective (fine for tens of points, d <= 4).
    """
    p = np.asarray(points, dtype=float).reshape(-1, len(reference))
    ref = np.asarray(reference, dtype=float)
    p = p[np.all(p < ref, axis=1)]
    if len(p) == 0:
        return 0.0
    if p.shape[1] == 1:
        return float(ref[0] - p[:, 0].min())
    p = p[np.argsort(p[:, -1])]
    total = 0.0
    for i in range(len(p)):
        top = p[i + 1, -1] if i + 1 < len(p) else ref[-1]
        if top > p[i, -1]:
            total += hypervolume(p[: i + 1, :-1], ref[:-1]) * (top - p[i, -1])
    return total


def _minimized(rows, objectives) -> np.ndarray:
    vals = np.array([[float(r[o.key]) for o in objectives] for r in rows], dtype=float)
    sign = np.array([-1.0 if o.direction == "maximize" else 1.0 for o in objectives])
    return vals * sign


def _reference(rows, objectives) -> np.ndarray:
    """The objectives' reference point (minimized form); the worst value where none is set."""
    vals = _minimized(rows, objectives)
    ref = []
    for k, o in enumerate(objectives):
        if o.reference is not None:
            ref.append(-o.reference if o.direction == "maximize" else o.reference)
        else:
            span = np.ptp(vals[:, k]) if len(vals) else 0.0
            ref.append(float(vals[:, k].max() + 0.1 * span + 1e-12) if len(vals) else 0.0)
    return np.array(ref)


def hypervolume_history(rows, objectives, reference=None) -> np.ndarray:
    """Hypervolume of the rows' front after each row, in row order, shape (len(rows),)."""
    if not rows:
        return np.zeros(0)
    vals = _minimized(rows, objectives)
    ref = _reference(rows, objectives) if reference is None else np.asarray(reference, float)
    out, front = [], np.zeros((0, vals.shape[1]))
    for v in vals:
        if not np.any(np.all(front <= v, axis=1)):
            keep = ~np.all(v <= front, axis=1)
            front = np.vstack([front[keep], v])
        out.append(hypervolume(front, ref))
    return np.array(out)


def _spearman(x, y) -> float:
    from scipy.stats import spearmanr

    x, y = np.asarray(x, float), np.asarray(y, float)
    if len(x) < 3 or np.ptp(x) == 0 or np.ptp(y) == 0:
        return float("nan")
    return float(spearmanr(x, y).statistic)


@dataclasses.dataclass
class _Table:
    rows: list[dict]
    variables: list[str]
    measures: list[str]
    objectives: tuple[Objective, ...]
    title: str
    feasible: list[bool]


def _study_table(folder: Path) -> _Table:
    rows = _read_csv(folder / "results.csv", ["name", *(o.key for o in STUDY_OBJECTIVES)])
    records = {}
    for path in sorted((folder / "designs").glob("*.json")):
        data = read_json(path)
        records[data["name"]] = (data, path.with_suffix(".npz"))
    variables = sorted({k for data, _ in records.values() for k in data.get("params", {})})
    if not variables:  # the columns between the name and the first score
        names = list(rows[0]) if rows else []
        variables = names[1 : names.index("reachable_volume_m3")] if rows else []
    for r in rows:
        data, npz = records.get(r["name"], ({}, None))
        r["_map"] = npz if npz is not None and npz.exists() else None
        for k, (lo, hi) in enumerate(data.get("achieved_limits_deg", [])):
            r[f"joint_{k + 1}_achieved_deg"] = f"{lo:.1f} to {hi:.1f}"
    measures = [
        k for k in (rows[0] if rows else {}) if k not in variables and k not in ("name", "pareto")
    ]
    summary = read_json(folder / "summary.json") or {}
    title = f"handarm study report: {summary.get('study', folder.name)}"
    return _Table(rows, variables, measures, STUDY_OBJECTIVES, title, [True] * len(rows))


def _optimize_table(folder: Path) -> _Table:
    rows = _read_csv(folder / "trials.csv", ["trial"])
    front = read_json(folder / "front.json") or {}
    objectives = tuple(
        Objective(o["key"], o["direction"], o.get("unit", ""), o.get("reference"))
        for o in front.get("objectives", [])
    )
    names = list(rows[0]) if rows else []
    fixed = {"trial", "state", "feasible", "violated", "pareto", "error"}
    variables = sorted({k for d in front.get("designs", []) for k in d.get("params", {})})
    if not variables and names:
        first = next((o.key for o in objectives if o.key in names), None)
        variables = names[2 : names.index(first)] if first else []
    measures = [k for k in names if k not in fixed and k not in variables]
    if not objectives:  # an unknown layout: the first two measures, both maximized
        objectives = tuple(Objective(k, "maximize") for k in measures[:2])
    for r in rows:
        r["name"] = f"trial {r['trial']}"
        built = folder / "front" / f"trial-{int(r['trial']):04d}"
        npz = built / "workspace" / "workspace.npz"
        r["_map"] = npz if npz.exists() else None
    ok = [
        r.get("state", "COMPLETE") == "COMPLETE"
        and r.get("feasible", True) is True
        and all(isinstance(r.get(o.key), int | float) for o in objectives)
        for r in rows
    ]
    title = f"handarm optimization report: {front.get('name', folder.name)}"
    return _Table(rows, variables, measures, objectives, title, ok)


def _report_link(folder: Path, row: dict) -> str | None:
    """Relative URL of a row's build report, if the design was built under the folder."""
    name = row["name"]
    candidates = [folder / name, folder / "builds" / name]
    if "trial" in row:
        candidates.insert(0, folder / "front" / f"trial-{int(row['trial']):04d}")
    for c in candidates:
        if (c / "report.html").is_file():
            return (c / "report.html").relative_to(folder).as_posix()
    return None


def _label(key: str) -> str:
    label, unit = unit_of(key)
    return f"{label} ({unit})"


def _front_section(page: Page, folder: Path, t: _Table) -> None:
    import plotly.graph_objects as go

    page.section("Pareto front", "front")
    rows = [r for r, ok in zip(t.rows, t.feasible, strict=True) if ok]
    if len(t.objectives) < 2 or not rows:
        page.text("Fewer than two objectives or no finished designs: no front to draw.")
        return
    page.text(
        "Every finished design; the front is drawn in colour. Hover for a design's variables; "
        "a click opens its build report when it was built in this folder."
    )
    pairs = list(itertools.combinations(range(len(t.objectives)), 2))
    links = [_report_link(folder, r) for r in rows]
    hover = [
        "<br>".join(
            [f"<b>{r['name']}</b>"]
            + [f"{v} = {r.get(v)}" for v in t.variables]
            + (["(click: build report)"] if link else [])
        )
        for r, link in zip(rows, links, strict=True)
    ]
    divs = []
    for n, (i, j) in enumerate(pairs):
        oi, oj = t.objectives[i], t.objectives[j]
        fig = go.Figure()
        for on_front in (False, True):
            sel = [k for k, r in enumerate(rows) if bool(r.get("pareto")) == on_front]
            fig.add_trace(
                go.Scatter(
                    x=[rows[k][oi.key] for k in sel],
                    y=[rows[k][oj.key] for k in sel],
                    mode="markers",
                    marker={
                        "size": 11 if on_front else 8,
                        "color": "#c0392b" if on_front else "#9aa5ad",
                    },
                    name="Pareto front" if on_front else "other designs",
                    text=[hover[k] for k in sel],
                    customdata=[[links[k]] for k in sel],
                    hovertemplate="%{text}<extra></extra>",
                )
            )
        fig.update_layout(
            title=f"{_label(oj.key)} ({oj.direction}) against {_label(oi.key)} ({oi.direction})",
            xaxis={"title": _label(oi.key)},
            yaxis={"title": _label(oj.key)},
        )
        div_id = f"front{n}"
        divs.append(page.figure(fig, div_id, height=460, wrap=False))
        page.script(_CLICK_JS % {"div": json.dumps(div_id)})
    page.raw('<div class="row">' + "".join(f"<div>{d}</div>" for d in divs) + "</div>")
    built = [(r["name"], link) for r, link in zip(rows, links, strict=True) if link]
    if built:
        page.raw(
            "<p>Built designs: "
            + ", ".join(f'<a href="{link}">{name}</a>' for name, link in built)
            + "</p>"
        )


def _history_section(page: Page, t: _Table, hv_recorded: float | None) -> None:
    import plotly.graph_objects as go

    rows = [r for r, ok in zip(t.rows, t.feasible, strict=True) if ok]
    if len(t.objectives) < 2 or len(rows) < 2:
        return
    page.section("Hypervolume history", "hypervolume")
    ref = _reference(t.rows if all(t.feasible) else rows, t.objectives)
    hist = hypervolume_history(rows, t.objectives, ref)
    x = [r.get("trial", n) for n, r in enumerate(rows)]
    fig = go.Figure(go.Scatter(x=x, y=hist, mode="lines+markers", name="hypervolume"))
    units = " × ".join(o.unit or unit_of(o.key)[1] for o in t.objectives)
    fig.update_layout(
        title="hypervolume of the front after each finished design",
        xaxis={"title": "trial" if "trial" in rows[0] else "design (study order)"},
        yaxis={"title": f"hypervolume ({units})"},
    )
    page.figure(fig, "hvhistory", height=380)
    ref_text = ", ".join(
        f"{o.key} {(-v if o.direction == 'maximize' else v):.4g}"
        for o, v in zip(t.objectives, ref, strict=True)
    )
    page.text(f"Reference point: {ref_text}.")
    if hv_recorded is not None:
        page.text(f"Hypervolume recorded by the optimization (front.json): {hv_recorded:.6g}.")


def _parallel_section(page: Page, t: _Table) -> None:
    import plotly.graph_objects as go

    keys = [
        k
        for k in t.variables + t.measures
        if all(isinstance(r.get(k), int | float) and not isinstance(r.get(k), bool) for r in t.rows)
    ]
    keys = [k for k in keys if len({r[k] for r in t.rows}) > 1] or keys
    if not t.rows or not keys:
        return
    page.section("Parallel coordinates", "parallel")
    page.text("Drag along an axis to select a range; Pareto designs in red.")
    fig = go.Figure(
        go.Parcoords(
            line={
                "color": [1.0 if r.get("pareto") else 0.0 for r in t.rows],
                "colorscale": [[0, "#9aa5ad"], [1, "#c0392b"]],
                "cmin": 0,
                "cmax": 1,
            },
            dimensions=[{"label": _label(k), "values": [r[k] for r in t.rows]} for k in keys],
        )
    )
    page.figure(fig, "parallel", height=460)


def _sensitivity_section(page: Page, folder: Path, t: _Table) -> None:
    import plotly.graph_objects as go

    rows = [r for r, ok in zip(t.rows, t.feasible, strict=True) if ok]
    numeric = [v for v in t.variables if all(isinstance(r.get(v), int | float) for r in rows)]
    joint = read_json(folder / "sensitivity.json")
    if not (numeric and len(rows) >= 3) and not joint:
        return
    page.section("Sensitivity", "sensitivity")
    if numeric and len(rows) >= 3:
        z = [
            [_spearman([r[v] for r in rows], [r[o.key] for r in rows]) for v in numeric]
            for o in t.objectives
        ]
        fig = go.Figure(
            go.Heatmap(
                x=numeric,
                y=[_label(o.key) for o in t.objectives],
                z=[[None if math.isnan(c) else c for c in row] for row in z],
                zmin=-1,
                zmax=1,
                colorscale="RdBu",
                colorbar={"title": "Spearman ρ"},
                texttemplate="%{z:.2f}",
                hovertemplate="%{x} vs %{y}: ρ = %{z:.2f}<extra></extra>",
            )
        )
        fig.update_layout(title="rank correlation of each variable with each objective (–1..1)")
        page.figure(fig, "sensitivity", height=360)
    if joint:
        rows_ = joint if isinstance(joint, list) else joint.get("joints", joint.get("rows", []))
        if isinstance(rows_, list) and rows_ and isinstance(rows_[0], dict):
            keys = list(rows_[0])
            page.text("Per-joint sensitivity of the study's base design (sensitivity.json):")
            page.table(
                [_label(k) for k in keys],
                [[r.get(k) for k in keys] for r in rows_],
                text_columns=(),
            )
        else:
            page.text("Per-joint sensitivity (sensitivity.json):")
            page.pre(json.dumps(joint, indent=2))


def _map_slices(npz: Path) -> dict:
    with np.load(npz) as z:
        index = np.asarray(z["index"], dtype=float)
        centres = np.asarray(z["centres"], dtype=float)
    mid = int(np.argmin(np.abs(centres)))
    return {
        "centres_mm": (centres * 1000.0).round(3).tolist(),
        "xy": index[:, :, mid].T.round(3).tolist(),
        "xz": index[:, mid, :].T.round(3).tolist(),
    }


def _compare_section(page: Page, t: _Table) -> None:
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots

    if len(t.rows) < 2:
        return
    page.section("Compare two designs", "compare")
    keys = t.variables + t.measures + sorted(k for k in t.rows[0] if k.startswith("joint_"))
    keys = list(dict.fromkeys(k for k in keys if not k.startswith("_")))
    maps, map_of = [], {}
    grid = None
    for r in t.rows:
        if r.get("_map") is None:
            continue
        slices = _map_slices(r["_map"])
        if grid is None:
            grid = slices["centres_mm"]
        if slices["centres_mm"] != grid:
            continue  # maps on another grid cannot be subtracted
        map_of[r["name"]] = len(maps)
        maps.append({"xy": slices["xy"], "xz": slices["xz"]})
    data = {
        "columns": [{"key": k, "label": _label(k)} for k in keys],
        "rows": [
            {
                "name": r["name"],
                "values": {k: r.get(k) for k in keys},
                "map": map_of.get(r["name"]),
            }
            for r in t.rows
        ],
        "maps": maps or None,
    }
    page.raw(
        '<p>Design A <select id="cmpA"></select> design B <select id="cmpB"></select></p>'
        '<div id="cmpTable"></div><p id="cmpNote"></p>'
    )
    if maps:
        fig = make_subplots(rows=1, cols=2, subplot_titles=("slice z = 0", "slice y = 0"))
        zero = np.zeros((len(grid), len(grid))).tolist()
        for col in (1, 2):
            fig.add_trace(
                go.Heatmap(
                    x=grid,
                    y=grid,
                    z=zero,
                    zmin=-1,
                    zmax=1,
                    colorscale="RdBu",
                    colorbar={"title": "B − A"},
                    showscale=col == 2,
                    hovertemplate="x %{x:.0f} mm, %{y:.0f} mm: %{z:.2f}<extra></extra>",
                ),
                row=1,
                col=col,
            )
        fig.update_xaxes(title_text="x (mm)")
        fig.update_yaxes(title_text="y (mm)", row=1, col=1)
        fig.update_yaxes(title_text="z (mm)", row=1, col=2)
        fig.update_layout(title="difference of the reachability index, B − A")
        page.figure(fig, "cmpMap", height=440)
    page.script(_COMPARE_JS % {"data": json.dumps(data, separators=(",", ":"))})


def _table_section(page: Page, t: _Table) -> None:
    page.section("All designs", "table")
    keys = ["name"] + t.variables + t.measures + ["pareto"]
    keys = [k for k in dict.fromkeys(keys) if any(k in r for r in t.rows)]
    page.table(
        [k if k == "name" else _label(k) for k in keys], [[r.get(k) for k in keys] for r in t.rows]
    )


def study_report(folder, kind: str = "study") -> Path:
    """Write ``report.html`` for a study or optimization folder; returns its path.

    Parameters
    ----------
    folder : path
        ``handarm study`` output (``results.csv``, ``designs/``, ``summary.json``,
        ``sensitivity.json``) or ``handarm optimize`` output (``trials.csv``,
        ``front.json``, ``front/``).
    kind : {"study", "optimize"}

    Returns
    -------
    Path

    Raises
    ------
    ValueError
        If ``kind`` is neither, or the folder's table is missing.
    """
    folder = Path(folder)
    if kind not in ("study", "optimize"):
        raise ValueError(f"kind: expected 'study' or 'optimize', got {kind!r}")
    table_name = "results.csv" if kind == "study" else "trials.csv"
    if not (folder / table_name).is_file():
        raise ValueError(f"{folder}: no {table_name}")
    t = _study_table(folder) if kind == "study" else _optimize_table(folder)
    page = Page(t.title)
    page.text(
        f"{len(t.rows)} designs, {sum(t.feasible)} finished and feasible; objectives: "
        + ", ".join(f"{_label(o.key)} ({o.direction})" for o in t.objectives)
        + ". Read from the files in this folder; nothing is recomputed."
    )
    _front_section(page, folder, t)
    hv = (read_json(folder / "front.json") or {}).get("hypervolume") if kind == "optimize" else None
    _history_section(page, t, hv)
    _parallel_section(page, t)
    _sensitivity_section(page, folder, t)
    _compare_section(page, t)
    _table_section(page, t)
    return page.write(folder / "report.html")
