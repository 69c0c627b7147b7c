"""Output folders for the report tests: a small build, a study and an optimization."""

import csv
import json
import shutil
from pathlib import Path

import pytest

import handarm
from handarm.pipeline import carve_design, export_controller, map_workspace
from handarm.report.browser import find_chromium, headless_chromium, wait_for_plots
from handarm.summary import design_summary


@pytest.fixture(scope="session")
def build_dir(tmp_path_factory):
    """What `handarm build` writes for the paper's arm, on a coarse carve and map.

    The same steps as handarm.build without the per-joint sensitivity (minutes); then the
    report, as build writes it last.
    """
    from handarm.report import write_report

    out = tmp_path_factory.mktemp("build")
    d = handarm.ArmDesign()
    d.to_toml(out / "design.toml")
    (out / "summary.txt").write_text(design_summary(d))
    carving, _ = carve_design(d, out, resolution_deg=3.0)
    export_controller(d, out / "controller", achieved_limits=[j.achieved for j in carving.joints])
    map_workspace(d, out / "workspace", voxel=0.05, directions=16, sensitivity=False)
    write_report(out)
    return out


@pytest.fixture(scope="session")
def study_dir(tmp_path_factory):
    """A real three-design study on a coarse map."""
    from handarm.workspace.study_file import load_study
    from handarm.workspace.study_run import run_study

    root = tmp_path_factory.mktemp("study")
    (root / "study.toml").write_text(
        'name = "elbow"\nvoxel = 0.05\ndirections = 16\n\n[grid]\nlimit_deg_2 = [110, 130, 150]\n'
    )
    run_study(load_study(root / "study.toml"), root / "results", workers=1)
    return root / "results"


#: The optimization output layout documented by ``handarm optimize`` (trials.csv, front.json).
OPT_VARIABLES = ("a1", "limit_deg_5")
OPT_MEASURED = ("reachable_volume_L", "dexterous_volume_L", "mass_g", "payload_kg")


@pytest.fixture(scope="session")
def optimize_dir(tmp_path_factory, build_dir):
    """An optimization folder in the documented layout, one front design built."""
    out = tmp_path_factory.mktemp("optimize")
    trials = [
        # trial, a1, limit, reach L, dext L, mass g, payload kg, feasible
        (0, 0.05, 120, 40.0, 5.0, 70.0, 0.20, True),
        (1, 0.06, 150, 55.0, 8.0, 75.0, 0.18, True),
        (2, 0.04, 130, 30.0, 3.0, 60.0, 0.25, True),
        (3, 0.05, 140, 20.0, 2.0, 90.0, 0.10, False),
        (4, 0.07, 150, 60.0, 9.0, 88.0, 0.15, True),
    ]
    front = {1, 2, 4}
    with (out / "trials.csv").open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(
            [
                "trial",
                "state",
                *OPT_VARIABLES,
                *OPT_MEASURED,
                "feasible",
                "violated",
                "pareto",
                "error",
            ]
        )
        for t in trials:
            w.writerow(
                [t[0], "COMPLETE", *t[1:7], t[7], "" if t[7] else "payload", t[0] in front, ""]
            )
    objectives = [
        {
            "name": "reach",
            "key": "reachable_volume_L",
            "unit": "L",
            "direction": "maximize",
            "reference": 0.0,
        },
        {"name": "mass", "key": "mass_g", "unit": "g", "direction": "minimize", "reference": 100.0},
    ]
    designs = [
        {
            "trial": t[0],
            "params": dict(zip(OPT_VARIABLES, t[1:3], strict=True)),
            "measurements": dict(zip(OPT_MEASURED, t[3:7], strict=True)),
            "toml": f"front/trial-{t[0]:04d}.toml",
        }
        for t in trials
        if t[0] in front
    ]
    (out / "front.json").write_text(
        json.dumps(
            {"name": "opt", "objectives": objectives, "hypervolume": 0.0, "designs": designs}
        )
    )
    shutil.copytree(build_dir, out / "front" / "trial-0004")
    return out


@pytest.fixture(scope="module")
def browser():
    if find_chromium() is None:
        pytest.skip("no browser: install chromium and chromium-driver (CI does)")
    drv = headless_chromium()
    yield drv
    drv.quit()


def open_page(drv, path: Path):
    """Load a report from disk; returns the console entries logged while loading."""
    drv.get_log("browser")  # drop what earlier pages logged
    drv.get(path.resolve().as_uri())
    wait_for_plots(drv)
    return drv.get_log("browser")
