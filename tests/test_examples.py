"""Every script in examples/ runs to the end (each asserts what it shows)."""

import csv
import json
import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = sorted((Path(__file__).resolve().parents[1] / "examples").glob("*.py"))


def test_there_are_examples():
    names = {p.name for p in EXAMPLES}
    assert {"design_variant.py", "solve_target.py", "small_study.py"} <= names
    assert "servos_on_emulator.py" in names


@pytest.mark.parametrize("script", EXAMPLES, ids=lambda p: p.name)
def test_example_runs(script, tmp_path):
    args = [str(tmp_path / "out")] if script.name in ("small_study.py",) else []
    if script.name == "design_variant.py":
        args = [str(tmp_path / "variant.toml")]
    done = subprocess.run(
        [sys.executable, str(script), *args],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip()
    assert "Traceback" not in done.stderr


@pytest.mark.slow
def test_optimize_example_runs_and_resumes(tmp_path):
    """examples/optimize.toml: a short run, then extended by one trial."""
    toml = EXAMPLES[0].parent / "optimize.toml"
    for trials in ("2", "3"):
        done = subprocess.run(
            [
                sys.executable,
                "-m",
                "handarm.cli",
                "optimize",
                str(toml),
                "--out",
                str(tmp_path / "run"),
                "--trials",
                trials,
                "--workers",
                "1",
                "--quiet",
            ],
            cwd=tmp_path,
            capture_output=True,
            text=True,
            timeout=900,
            check=False,
        )
        assert done.returncode == 0, done.stderr[-2000:]
        assert f"{trials} in the journal" in done.stdout
    # the example searches something: at 0.5 (its old threshold) every trial of the
    # printed arm, whose joints stop near 88 degrees, counted no dexterous volume at all
    front = json.loads((tmp_path / "run" / "front.json").read_text())
    assert front["hypervolume"] > 0
    rows = list(csv.DictReader((tmp_path / "run" / "trials.csv").open()))
    dexterous = {float(r["dexterous_volume_L"]) for r in rows}
    assert len(dexterous) > 1 and max(dexterous) > 0
