"""The report of one ``handarm build`` folder: ``report.html``.

Read only from the files the build wrote (nothing is carved or mapped again):

- the carved arm in 3D from the URDF's mesh visuals, posed in the page by the URDF's chain
  (forward kinematics in JavaScript), one slider per joint over its usable range (the
  achieved limits of ``carve.json`` within the design's), the verdict of the printed-link
  model with the colliding pairs evaluated live in the page (``handarm.report._live``), and
  named poses (straight, the paper's fold, every joint at each end of its range) with their
  verdicts also computed here, in Python;
- the workspace map (``workspace/workspace.npz``) as iso-surfaces of the reachability index
  and two slices, with the handle marked; its scores;
- per link and per joint tables, the transmission and controller settings, and whatever
  else is there (``sizing.json``, ``bom.csv``, ``assembly.html``, ``tendons.json``, an MJCF);
- the design TOML.
"""

from __future__ import annotations

import csv
import html
import json
import math
import zipfile
from pathlib import Path

import numpy as np

from handarm._outdir import INCOMPLETE
from handarm.report._data import display_mesh, read_json, read_urdf, unit_of
from handarm.report._live import COLLISION_JS, collision_data
from handarm.report._page import Page

__all__ = ["build_report", "named_poses", "LINK_COLOURS"]

LINK_COLOURS = ["#5b6770", "#2f7ebc", "#e0892b", "#3a9e5c", "#c0392b", "#8e5cc2", "#d4a017"]
_EXTRA_COLOUR = "#9aa5ad"

_POSE_JS = r"""
(function() {
  const M = %(model)s;
  const div = document.getElementById('arm3d');
  const base = M.visuals.map(v => ({x: v.x.slice(), y: v.y.slice(), z: v.z.slice()}));
  function mul(a, b) {
    const c = [[0,0,0,0],[0,0,0,0],[0,0,0,0],[0,0,0,0]];
    for (let i = 0; i < 4; i++) for (let j = 0; j < 4; j++) {
      let s = 0; for (let k = 0; k < 4; k++) s += a[i][k] * b[k][j]; c[i][j] = s; }
    return c;
  }
  function rot(axis, t) {
    const [x, y, z] = axis, c = Math.cos(t), s = Math.sin(t), C = 1 - c;
    return [[c + x*x*C, x*y*C - z*s, x*z*C + y*s, 0], [y*x*C + z*s, c + y*y*C, y*z*C - x*s, 0],
            [z*x*C - y*s, z*y*C + x*s, c + z*z*C, 0], [0, 0, 0, 1]];
  }
  function frames(qrad) {
    const F = {}; F[M.root] = [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]];
    for (const j of M.joints) {
      let T = mul(F[j.parent], j.origin);
      if (j.q >= 0) T = mul(T, rot(j.axis, qrad[j.q]));
      F[j.child] = T;
    }
    return F;
  }
  // the pose shown: a slider snaps to its 0.5 degree steps, a named pose is kept exact
  let Q = M.sliders.map(s => parseFloat(document.getElementById(s.id).value));
  function pose() { return Q.slice(); }
  function verdictFor(qdeg) {
    for (const p of M.poses) {
      if (p.q_deg.every((v, i) => Math.abs(v - qdeg[i]) < 1e-6)) return p;
    }
    return null;
  }
  function update() {
    const qdeg = pose(), qrad = qdeg.map(v => v * Math.PI / 180), F = frames(qrad);
    const xs = [], ys = [], zs = [];
    M.visuals.forEach((v, n) => {
      const T = F[v.link], b = base[n], k = b.x.length;
      const x = new Array(k), y = new Array(k), z = new Array(k);
      for (let i = 0; i < k; i++) {
        const px = b.x[i], py = b.y[i], pz = b.z[i];
        x[i] = T[0][0]*px + T[0][1]*py + T[0][2]*pz + 1000*T[0][3];
        y[i] = T[1][0]*px + T[1][1]*py + T[1][2]*pz + 1000*T[1][3];
        z[i] = T[2][0]*px + T[2][1]*py + T[2][2]*pz + 1000*T[2][3];
      }
      xs.push(x); ys.push(y); zs.push(z);
    });
    Plotly.restyle(div, {x: xs, y: ys, z: zs}, M.visuals.map((v, n) => n));
    M.sliders.forEach((s, i) => {
      document.getElementById(s.id + '_v').textContent = qdeg[i].toFixed(1) + ' deg';
    });
    const out = document.getElementById('verdict'), p = verdictFor(qdeg);
    const inside = qdeg.every(
      (v, i) => v >= M.design_deg[i][0] - 1e-9 && v <= M.design_deg[i][1] + 1e-9);
    if (M.collision) {
      const hits = collidingPairs(M.collision, qrad), ok = inside && hits.length === 0;
      const why = [];
      if (!inside) why.push('outside the design limits');
      if (hits.length) why.push('collides: ' + hits.join(', '));
      out.className = 'verdict ' + (ok ? 'ok' : 'bad');
      out.textContent = (p ? p.name + ': ' : '') + (ok ? 'valid' : 'invalid') + ' (' +
        (ok ? 'within limits, no printed links collide' : why.join('; ')) + ')';
    } else if (p) {
      out.className = 'verdict ' + (p.valid ? 'ok' : 'bad');
      out.textContent = p.name + ': ' + (p.valid ? 'valid' : 'invalid') + ' (' + p.reason + ')';
    } else {
      out.className = 'verdict unknown';
      out.textContent = (inside ? 'within the design limits' : 'outside the design limits') +
        '; collisions are evaluated at the named poses only (pick one below)';
    }
    window.handarmReport.q_deg = qdeg;
  }
  function setPose(qdeg) {
    Q = qdeg.slice();
    M.sliders.forEach((s, i) => { document.getElementById(s.id).value = qdeg[i]; });
    update();
  }
  window.handarmReport = {setPose: setPose, frames: q => frames(q), update: update, model: M,
    collisions: q => M.collision ? collidingPairs(M.collision, q) : null};
  M.sliders.forEach((s, i) => document.getElementById(s.id).addEventListener('input', e => {
    Q[i] = parseFloat(e.target.value);
    update();
  }));
  M.poses.forEach((p, n) => document.getElementById('pose' + n).addEventListener(
    'click', () => setPose(p.q_deg)));
  update();
})();
"""


def named_poses(design, limits_rad) -> list[dict]:
    """Straight, the paper's fold and each joint at each end of ``limits_rad``, with verdicts.

    Parameters
    ----------
    design : ArmDesign
    limits_rad : sequence of 6 (lo, hi)
        The usable range of each joint (rad).

    Returns
    -------
    list of dict
        ``name``, ``q_deg`` (6), ``valid`` (``handarm.is_valid``: design limits and the
        design's collision model), ``within_limits``, ``colliding`` (names of the printed
        link pairs that collide) and ``reason`` (one line).
    """
    from handarm.cad_out.pictures import fold_from_limits
    from handarm.collision import LINK_PAIRS, printed_collisions
    from handarm.kinematics import is_valid, within_limits

    poses = [("straight", np.zeros(6)), ("paper's fold", fold_from_limits(limits_rad))]
    for k, (lo, hi) in enumerate(limits_rad):
        for side, v in (("lower", lo), ("upper", hi)):
            q = np.zeros(6)
            q[k] = v
            poses.append((f"joint {k + 1} {side} limit", q))
    qs = np.array([q for _, q in poses])
    valid = is_valid(design, qs)
    inside = within_limits(design, qs)
    hits = printed_collisions(design, qs)
    out = []
    for (name, q), ok, ins, hit in zip(poses, valid, inside, hits, strict=True):
        pairs = [f"l{a}–l{b}" for (a, b), h in zip(LINK_PAIRS, hit, strict=True) if h]
        if ok:
            reason = "within limits, no printed links collide"
        else:
            bits = [] if ins else ["outside the design limits"]
            bits += [f"collides: {', '.join(pairs)}"] if pairs else []
            reason = "; ".join(bits) or "collides (paper model)"
        out.append(
            {
                "name": name,
                "q_deg": [round(math.degrees(v), 9) for v in q],
                "valid": bool(ok),
                "within_limits": bool(ins),
                "colliding": pairs,
                "reason": reason,
            }
        )
    return out


def _arm_section(page: Page, out: Path, design, carve: dict) -> None:
    page.section("Carved arm", "arm")
    urdf_path = out / f"{design.name}.urdf"
    if not urdf_path.exists():
        found = sorted(out.glob("*.urdf"))
        if not found:
            page.text("No URDF in this folder: the 3D arm needs the carving outputs.")
            return
        urdf_path = found[0]
    import plotly.graph_objects as go

    model = read_urdf(urdf_path)
    links = [model.root] + [j["child"] for j in model.joints]
    fig = go.Figure()
    visuals = []
    missing = [v["mesh"] for v in model.visuals if not (urdf_path.parent / v["mesh"]).exists()]
    if missing:
        page.text(
            f"Missing from this folder, so not drawn: {', '.join(missing)} (named by "
            f"{urdf_path.name}): the 3D arm below lacks those links."
        )
    for vis in model.visuals:
        if vis["mesh"] in missing:
            continue
        mesh_path = urdf_path.parent / vis["mesh"]
        v, f = display_mesh(mesh_path, vis["origin"], vis["scale"])
        k = links.index(vis["link"])
        chain_links = [model.root] + [j["child"] for j in model.joints if j["q"] >= 0]
        colour = (
            LINK_COLOURS[chain_links.index(vis["link"]) % len(LINK_COLOURS)]
            if vis["link"] in chain_links
            else _EXTRA_COLOUR
        )
        fig.add_trace(
            go.Mesh3d(
                x=v[:, 0],
                y=v[:, 1],
                z=v[:, 2],
                i=f[:, 0],
                j=f[:, 1],
                k=f[:, 2],
                color=colour,
                name=f"{vis['link']}: {Path(vis['mesh']).stem}",
                showlegend=True,
                flatshading=True,
                lighting={"ambient": 0.5, "diffuse": 0.8, "specular": 0.2},
                hovertemplate=f"{vis['link']}<br>x %{{x:.1f}} mm<br>y %{{y:.1f}} mm"
                "<br>z %{z:.1f} mm<extra></extra>",
            )
        )
        visuals.append({"link": vis["link"], "x": v[:, 0], "y": v[:, 1], "z": v[:, 2], "k": k})
    reach = float(np.sum(design.lengths[1:])) * 1000.0
    box = [-reach - design.lengths[0] * 1000.0, reach]
    fig.update_layout(
        title="carved arm (mm); drag to turn, scroll to zoom",
        scene={
            "aspectmode": "manual",  # equal scales on the three axes
            "aspectratio": {"x": (box[1] - box[0]) / (2 * reach), "y": 1.0, "z": 1.0},
            "camera": {"eye": {"x": 0.55, "y": -0.85, "z": 0.5}},
            "xaxis": {"title": "x (mm)", "range": box},
            "yaxis": {"title": "y (mm)", "range": [-reach, reach]},
            "zaxis": {"title": "z (mm)", "range": [-reach, reach]},
        },
        legend={"itemsizing": "constant"},
    )
    lo = np.array([j["achieved_deg"][0] for j in carve["joints"]], dtype=float)
    hi = np.array([j["achieved_deg"][1] for j in carve["joints"]], dtype=float)
    lo = np.maximum(lo, np.degrees(design.lower))
    hi = np.minimum(hi, np.degrees(design.upper))
    poses = named_poses(design, np.radians(np.stack([lo, hi], axis=1)))
    sliders = []
    controls = []
    for k in range(6):
        sid = f"q{k + 1}"
        sliders.append({"id": sid})
        # steps of 0.5 degrees from 0, inside the range (the named poses reach its ends)
        smin, smax = math.ceil(lo[k] / 0.5) * 0.5, math.floor(hi[k] / 0.5) * 0.5
        controls.append(
            f'<label class="slider">joint {k + 1} ({lo[k]:.1f} to {hi[k]:.1f} deg)'
            f'<input type="range" id="{sid}" min="{smin}" max="{smax}" step="0.5" value="0">'
            f'<span id="{sid}_v">0 deg</span></label>'
        )
    buttons = "".join(
        f'<button id="pose{n}" title="{html.escape(p["reason"])}">{html.escape(p["name"])}</button>'
        for n, p in enumerate(poses)
    )
    div = page.figure(fig, "arm3d", height=620, wrap=False)
    page.raw(
        f'<div class="row"><div style="flex: 2 1 600px">{div}</div><div>'
        "<p>Joint angles: each slider spans the joint's usable range, the limits the carved "
        "links achieve within the design's limits.</p>"
        + "".join(controls)
        + "<p>Verdict (design limits and the printed-link collision model, evaluated live): "
        '<span id="verdict" class="verdict unknown"></span></p>'
        f"<p>Named poses:<br>{buttons}</p>"
        "</div></div>"
    )
    page.table(
        ["pose", "q1..q6 (deg)", "valid", "why"],
        [
            (p["name"], " ".join(f"{v:.1f}" for v in p["q_deg"]), p["valid"], p["reason"])
            for p in poses
        ],
        text_columns=(0, 1, 3),
    )
    js_model = {
        "root": model.root,
        "joints": [
            {k: j[k] for k in ("parent", "child", "origin", "axis", "q")} for j in model.joints
        ],
        "visuals": [
            {
                "link": v["link"],
                "x": v["x"].round(3).tolist(),
                "y": v["y"].round(3).tolist(),
                "z": v["z"].round(3).tolist(),
            }
            for v in visuals
        ],
        "sliders": sliders,
        "poses": poses,
        "design_deg": np.degrees(np.stack([design.lower, design.upper], axis=1)).tolist(),
    }
    if design.collision_model == "printed":
        js_model["collision"] = collision_data(design)
    page.script(COLLISION_JS)
    page.script(_POSE_JS % {"model": json.dumps(js_model, separators=(",", ":"))})


def _link_tables(page: Page, out: Path, carve: dict) -> None:
    page.section("Links and joints", "links")
    links = []
    for k in range(7):
        data = read_json(out / "links" / f"l{k}.json")
        if data is not None:
            links.append(data)
    if not links:
        links = carve.get("links", [])
    scalar_keys = []
    for data in links:
        for key, value in data.items():
            if key in ("link", "joints", "density_kg_m3") or key in scalar_keys:
                continue
            if isinstance(value, int | float) and not isinstance(value, bool):
                scalar_keys.append(key)
    headers = ["link"]
    for key in scalar_keys:
        label, unit = unit_of(key)
        headers.append(f"{label} ({unit})")
    rows = [[d.get("link", "")] + [d.get(key) for key in scalar_keys] for d in links]
    text_columns = (0,)
    if any("center_of_mass_m" in d for d in links):
        # the one vector of the files a reader wants beside the mass: in mm, in the link's frame
        headers.append("centre of mass (mm, link frame)")
        text_columns = (0, len(headers) - 1)
        for row, d in zip(rows, links, strict=True):
            com = d.get("center_of_mass_m")
            row.append("" if com is None else ", ".join(f"{v * 1e3:.2f}" for v in com))
    page.text("Per link (SI units as recorded in links/*.json):")
    page.table(headers, rows, text_columns=text_columns)
    page.text("Per joint (limits in degrees; what stops each side of the carved range):")
    page.table(
        [
            "joint",
            "requested (deg)",
            "carved (deg)",
            "achieved (deg)",
            "lower side stopped by",
            "upper side stopped by",
        ],
        [
            (
                j["joint"],
                " to ".join(f"{v:.1f}" for v in j["requested_deg"]),
                " to ".join(f"{v:.1f}" for v in j["carved_deg"]),
                " to ".join(f"{v:.1f}" for v in j["achieved_deg"]),
                j["stopped_by"]["lower"],
                j["stopped_by"]["upper"],
            )
            for j in carve["joints"]
        ],
        text_columns=(1, 2, 3, 4, 5),
    )
    total = carve.get("total_mass_kg")
    if total is not None:
        page.text(f"Total printed link mass: {total * 1e3:.1f} g.")


def _json_block(page: Page, title: str, data) -> None:
    """A JSON file as a table when it is a list of flat records, else as text."""
    page.raw(f"<h3>{html.escape(title)}</h3>")
    if isinstance(data, list) and data and all(isinstance(r, dict) for r in data):
        keys = list(dict.fromkeys(k for r in data for k in r))
        headers = [f"{unit_of(k)[0]} ({unit_of(k)[1]})" for k in keys]
        page.table(headers, [[_cell(r.get(k)) for k in keys] for r in data], text_columns=())
    elif isinstance(data, dict) and all(not isinstance(v, dict) for v in data.values()):
        rows = []
        for key, value in data.items():
            label, unit = unit_of(key)
            if isinstance(value, list) and all(isinstance(v, int | float) for v in value):
                value = ", ".join(f"{v:.4g}" for v in value)
            rows.append((label, unit, _cell(value)))
        page.table(["quantity", "unit", "value"], rows, text_columns=(0, 1, 2))
    else:
        page.pre(json.dumps(data, indent=2))


def _cell(value):
    if isinstance(value, list | dict):
        return json.dumps(value)
    return value


def _controller_section(page: Page, out: Path) -> None:
    summary = out / "summary.txt"
    config = read_json(out / "controller" / "controller.json")
    sizing = read_json(out / "sizing.json") or read_json(out / "controller" / "sizing.json")
    if not (summary.exists() or config or sizing):
        return
    page.section("Transmission and controller", "controller")
    if summary.exists():
        page.text("Lengths, limits, joint torque and speed limits, the coupling K (summary.txt):")
        page.pre(summary.read_text())
    if config:
        tpr = config.get("ticks_per_rad")
        if tpr:
            page.text(f"Encoder: {tpr:.2f} ticks/rad ({tpr * math.pi / 180:.3f} ticks/deg).")
        page.table(
            [
                "servo id",
                "joint",
                "model",
                "mode",
                "cw limit (ticks)",
                "ccw limit (ticks)",
                "max torque (register)",
                "motor travel (deg)",
                "assembly position (ticks)",
                "baud (bit/s)",
            ],
            [
                (
                    s["id"],
                    s["joint"],
                    s["model"],
                    s["mode"],
                    s["cw_angle_limit"],
                    s["ccw_angle_limit"],
                    s["max_torque"],
                    " to ".join(f"{math.degrees(v):.1f}" for v in s["travel_rad"]),
                    s["assembly_ticks"],
                    s["baud_rate"],
                )
                for s in config.get("servos", [])
            ],
            text_columns=(2, 3, 7),
        )
    if sizing:
        _json_block(page, "Payload and pulley sizing (sizing.json)", sizing)


def _workspace_section(page: Page, out: Path) -> None:
    npz = out / "workspace" / "workspace.npz"
    scores = read_json(out / "workspace" / "workspace.json")
    if not npz.exists() and not scores:
        return
    page.section("Workspace", "workspace")
    if npz.exists():
        from handarm.report._plots import workspace_figures

        try:
            with np.load(npz) as z:
                centres, index, handle = z["centres"], z["index"], float(z["handle"])
        except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as exc:
            raise ValueError(f"{npz}: not a workspace map that handarm wrote ({exc})") from None
        figs = workspace_figures(centres, index, handle)
        scene = scores.get("scene") if scores else None
        if scene:
            from handarm.report._plots import obstacle_traces

            figs[0].add_traces(obstacle_traces(scene["rows"], scene["obstacles"]))
            page.text(
                f"Mapped around {len(scene['obstacles'])} obstacle(s) "
                f"({', '.join(scene['obstacles'])}), keeping {scene['clearance_m'] * 1e3:g} mm "
                "from them: the grey shapes in the view below. The sensitivity screen is not "
                "made in a scene."
            )
        page.figure(figs[0], "ws3d", height=600)
        divs = [page.figure(f, f"ws_{n}", height=460, wrap=False) for n, f in enumerate(figs[1:])]
        page.raw('<div class="row">' + "".join(f"<div>{d}</div>" for d in divs) + "</div>")
    if scores:
        rows = [
            (*unit_of(k), v)
            for k, v in scores.get("scores", {}).items()
            if isinstance(v, int | float)
        ]
        page.table(["score", "unit", "value"], rows, text_columns=(0, 1))
        check = scores.get("min_reach_check")
        if check:
            _json_block(page, "The paper's minimum reach, checked", check)
        sens = scores.get("sensitivity")
        if sens:
            _json_block(page, "Sensitivity: volume lost per degree of limit removed", sens)


def _kit_section(page: Page, out: Path) -> None:
    bom = out / "bom.csv"
    assembly = out / "assembly.html"
    tendons = read_json(out / "tendons.json")
    mjcf = sorted(out.glob("*.mjcf")) + sorted(out.glob("*mjcf*.xml"))
    if not (bom.exists() or assembly.exists() or tendons or mjcf):
        return
    page.section("Kit: bill of materials, assembly, tendons", "kit")
    if bom.exists():
        with bom.open(newline="") as fh:
            rows = list(csv.reader(fh))
        if rows:
            page.raw("<h3>Bill of materials (bom.csv)</h3>")
            page.table(rows[0], rows[1:], text_columns=tuple(range(len(rows[0]))))
    if assembly.exists():
        page.raw('<p>Assembly steps: <a href="assembly.html">assembly.html</a></p>')
    if tendons:
        _json_block(page, "Tendons (tendons.json)", tendons)
    for path in mjcf:
        page.raw(
            f'<p>MuJoCo model: <a href="{html.escape(path.name)}">{html.escape(path.name)}</a></p>'
        )


def build_report(out: str | Path) -> Path:
    """Write ``report.html`` for the build folder ``out``; returns its path.

    Parameters
    ----------
    out : path
        A folder ``handarm build`` wrote (``design.toml`` and ``carve.json`` at least).

    Returns
    -------
    Path

    Raises
    ------
    ValueError
        If ``out`` is not a build folder (the message names the missing file).
    """
    from handarm.design import ArmDesign

    out = Path(out)
    for name in ("design.toml", "carve.json"):
        if not (out / name).is_file():
            raise ValueError(f"{out}: not a handarm build folder ({name} missing)")
    design = ArmDesign.from_toml(out / "design.toml")
    carve = read_json(out / "carve.json")
    page = Page(f"handarm build report: {design.name}")
    if (out / INCOMPLETE).exists():
        page.text(
            f"This build did not finish ({INCOMPLETE} is in the folder): some files below "
            "may be missing or left from an earlier build. Run handarm build again."
        )
    page.text(
        "Everything below is read from the files in this folder; lengths in the 3D views "
        "are millimetres, table values in the units their headers name."
    )
    _arm_section(page, out, design, carve)
    _workspace_section(page, out)
    _link_tables(page, out, carve)
    _controller_section(page, out)
    _kit_section(page, out)
    page.section("Design", "design")
    page.pre((out / "design.toml").read_text())
    return page.write(out / "report.html")
