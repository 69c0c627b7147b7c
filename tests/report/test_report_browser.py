"""The reports in headless Chromium: no JavaScript errors, plots drawn, sliders pose the arm."""

import csv
import io
import json
import math

import numpy as np
import pytest
import trimesh
from selenium.webdriver.common.by import By
from selenium.webdriver.common.keys import Keys

import handarm
from handarm.report._data import read_urdf

from .conftest import open_page

pytestmark = pytest.mark.slow  # a browser, a carved build and a study: about a minute


def _errors(log):
    return [e for e in log if e["level"] == "SEVERE"]


def _not_blank(png: bytes, min_colours: int = 200) -> bool:
    from PIL import Image

    img = np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).reshape(-1, 3)
    return len(np.unique(img, axis=0)) >= min_colours and img.std() > 10


def _plots_drawn(drv) -> list[str]:
    """Ids of plot divs Plotly has laid out and drawn (an SVG or a WebGL canvas)."""
    return drv.execute_script(
        "return [...document.querySelectorAll('.plot')].filter(d => d._fullLayout &&"
        " d.querySelector('svg.main-svg, canvas')).map(d => d.id);"
    )


def test_build_report_renders_without_errors(browser, build_dir):
    log = open_page(browser, build_dir / "report.html")
    assert _errors(log) == []
    # the arm, the 3D workspace and its two slices
    assert sorted(_plots_drawn(browser)) == ["arm3d", "ws3d", "ws_0", "ws_1"]
    assert _not_blank(browser.get_screenshot_as_png())
    arm = browser.find_element(By.ID, "arm3d")
    assert _not_blank(arm.screenshot_as_png, min_colours=50)  # the WebGL scene, not a blank box
    tables = browser.find_elements(By.TAG_NAME, "table")
    assert len(tables) >= 4  # poses, links, joints, scores, controller


def test_slider_moves_the_arm_where_the_python_kinematics_puts_it(browser, build_dir):
    open_page(browser, build_dir / "report.html")
    before = browser.execute_script("return Array.from(document.getElementById('arm3d').data[6].x)")
    slider = browser.find_element(By.ID, "q2")
    for _ in range(20):  # 0.5 deg a step: 10 deg
        slider.send_keys(Keys.ARROW_RIGHT)
    q_deg = browser.execute_script("return window.handarmReport.q_deg")
    assert q_deg == pytest.approx([0, 10, 0, 0, 0, 0])
    after = browser.execute_script("return Array.from(document.getElementById('arm3d').data[6].x)")
    assert not np.allclose(before, after)
    # every link's first vertex where joint_frames puts it: the STL through the URDF origin
    design = handarm.ArmDesign.from_toml(build_dir / "design.toml")
    frames = handarm.joint_frames(design, np.radians(q_deg))
    model = read_urdf(build_dir / "paper_arm.urdf")
    data = browser.execute_script(
        "return document.getElementById('arm3d').data.map(t => [t.x[0], t.y[0], t.z[0]])"
    )
    for k, vis in enumerate(model.visuals):
        v0 = trimesh.load_mesh(build_dir / vis["mesh"]).vertices[0] * 1e-3
        m = np.asarray(vis["origin"]) if k == 0 else frames[k - 1] @ np.asarray(vis["origin"])
        expected = (m[:3, :3] @ v0 + m[:3, 3]) * 1e3
        assert np.allclose(data[k], expected, atol=1e-2), k  # mm; the page rounds to 1 um


def test_js_chain_matches_joint_frames(browser, build_dir, rng):
    open_page(browser, build_dir / "report.html")
    design = handarm.ArmDesign.from_toml(build_dir / "design.toml")
    for _ in range(5):
        q = rng.uniform(-math.pi, math.pi, 6)
        got = browser.execute_script(
            "const F = window.handarmReport.frames(arguments[0]);"
            "return ['link1','link2','link3','link4','link5','link6','tool'].map(n => F[n]);",
            q.tolist(),
        )
        assert np.allclose(got, handarm.joint_frames(design, q), atol=1e-12)


def test_named_pose_buttons_set_the_sliders_and_show_the_verdict(browser, build_dir):
    open_page(browser, build_dir / "report.html")
    poses = browser.execute_script("return window.handarmReport.model.poses")
    fold = next(n for n, p in enumerate(poses) if p["name"] == "paper's fold")
    browser.find_element(By.ID, f"pose{fold}").click()
    q = browser.execute_script("return window.handarmReport.q_deg")
    assert q == pytest.approx(poses[fold]["q_deg"], abs=0.5)  # sliders step 0.5 deg
    verdict = browser.find_element(By.ID, "verdict").text
    expected = "valid" if poses[fold]["valid"] else "invalid"
    assert verdict.startswith(f"paper's fold: {expected}")


def test_study_report_fronts_and_comparison(browser, study_dir):
    from handarm.report import write_report

    write_report(study_dir)
    log = open_page(browser, study_dir / "report.html")
    assert _errors(log) == []
    # one front picture per pair of the study's four objectives (volumes, mass, section)
    assert sorted(_plots_drawn(browser)) == [
        "cmpMap",
        *[f"front{k}" for k in range(6)],
        "hvhistory",
        "parallel",
        "sensitivity",
    ]
    assert _not_blank(browser.get_screenshot_as_png())
    # hover text of the front names the design's variables
    text = browser.execute_script(
        "return document.getElementById('front0').data.flatMap(t => t.text)"
    )
    assert text and all("limit_deg_2 = " in t for t in text)
    # pick designs 0 and 2: the map difference is the difference of their npz maps
    browser.execute_script(
        "const a = document.getElementById('cmpA'), b = document.getElementById('cmpB');"
        "a.value = 0; b.value = 2; b.dispatchEvent(new Event('change'));"
    )
    rows = browser.execute_script("return document.querySelectorAll('#cmpTable tr').length")
    assert rows > 5
    names = browser.execute_script(
        "return [...document.querySelectorAll('#cmpTable th')].map(th => th.textContent)"
    )
    with (study_dir / "results.csv").open(newline="") as fh:
        results = [row["name"] for row in csv.DictReader(fh)]
    assert names[1:3] == [results[0], results[2]]
    maps = {}
    for path in (study_dir / "designs").glob("*.json"):
        with np.load(path.with_suffix(".npz")) as z:
            maps[json.loads(path.read_text())["name"]] = (z["index"], z["centres"])
    (ia, centres), (ib, _) = maps[results[0]], maps[results[2]]
    mid = int(np.argmin(np.abs(centres)))
    shown = browser.execute_script("return document.getElementById('cmpMap').data[0].z")
    assert np.allclose(shown, (ib - ia)[:, :, mid].T, atol=2e-3)  # the page rounds to 1e-3


def test_optimize_report_links_front_designs_to_their_build_report(browser, optimize_dir):
    from handarm.report import write_report

    write_report(optimize_dir)
    log = open_page(browser, optimize_dir / "report.html")
    assert _errors(log) == []
    assert sorted(_plots_drawn(browser)) == [
        "cmpMap",
        "front0",
        "hvhistory",
        "parallel",
        "sensitivity",
    ]
    # a click on the built front design opens its report
    url = browser.execute_script(
        "let opened = null; window.open = u => { opened = u; };"
        "const gd = document.getElementById('front0');"
        "const t = gd.data.findIndex(t => t.name === 'Pareto front');"
        "const k = gd.data[t].customdata.findIndex(c => c[0]);"
        "gd.emit('plotly_click', {points: [{customdata: gd.data[t].customdata[k]}]});"
        "return opened;"
    )
    assert url == "front/trial-0004/report.html"
    assert (optimize_dir / url).is_file()


def test_live_verdict_is_the_printed_link_model(browser, build_dir, rng):
    """The page's JavaScript names the same colliding pairs as printed_collisions."""
    from handarm.collision import LINK_PAIRS, printed_collisions

    open_page(browser, build_dir / "report.html")
    design = handarm.ArmDesign.from_toml(build_dir / "design.toml")
    wide = rng.uniform(-math.pi, math.pi, (1500, 6))
    inside = rng.uniform(design.lower, design.upper, (1500, 6))
    q = np.vstack([wide, inside])
    got = browser.execute_script(
        "return arguments[0].map(q => window.handarmReport.collisions(q))", q.tolist()
    )
    names = [f"l{a}–l{b}" for a, b in LINK_PAIRS]
    want = [
        [n for n, h in zip(names, row, strict=True) if h] for row in printed_collisions(design, q)
    ]
    assert got == want
    hits = sum(bool(w) for w in want)
    assert 100 < hits < len(q) - 100  # both verdicts are exercised
    # the verdict shown for a colliding pose inside the limits names its pairs
    k = next(i for i in range(1500, 3000) if want[i])
    browser.execute_script("window.handarmReport.setPose(arguments[0]);", np.degrees(q[k]).tolist())
    shown_q = np.radians(browser.execute_script("return window.handarmReport.q_deg"))  # 0.5 deg
    at = [n for n, h in zip(names, printed_collisions(design, shown_q), strict=True) if h]
    shown = browser.find_element(By.ID, "verdict").text
    assert shown.startswith("invalid" if at else "valid")
    assert all(n in shown for n in at)


def test_quitting_the_browser_removes_its_profile():
    """Every screenshot and test run left a 2.5 MB Chromium profile in /tmp."""
    from pathlib import Path

    from handarm.report.browser import find_chromium, headless_chromium

    if find_chromium() is None:
        pytest.skip("no browser: install chromium and chromium-driver (CI does)")
    drv = headless_chromium(200, 200)
    profile = Path(drv.capabilities["chrome"]["userDataDir"])
    assert profile.is_dir() and profile.name.startswith("handarm-chromium-")
    drv.quit()
    assert not profile.exists()
