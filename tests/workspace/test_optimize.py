import csv
import json

import numpy as np
import pytest

import handarm
from handarm.cli import main
from handarm.workspace.maps import direction_set, nearest_direction_counts, reachability_map
from handarm.workspace.opt_file import load_opt
from handarm.workspace.optimize import feasibility, hypervolume, run_optimization
from handarm.workspace.sensitivity import paper_3r_section_check
from handarm.workspace.study_file import load_study
from handarm.workspace.study_results import pareto_front

OPT = """
name = "tiny"
trials = 3
[map]
voxel = 0.06
directions = 4
[variables]
limit_deg_5 = {low = 110, high = 160, step = 10}
beam_width = {low = 0.011, high = 0.013}
[objectives]
reachable_volume = "maximize"
mass = {direction = "minimize", reference = 200}
[constraints]
max_mass_g = 150
"""


@pytest.fixture
def opt_file(tmp_path):
    path = tmp_path / "opt.toml"
    path.write_text(OPT)
    return path


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("[objectives]\nbeauty = 'maximize'", "objectives.beauty: unknown objective"),
        ("[objectives]\nmass = 'smaller'", "objectives.mass: expected"),
        ("[map]\ndirections = 48", "map.directions: 48 .* nearest valid counts: 36 and 56"),
        ('[map]\nvoxel = "0.02"', "map.voxel: expected a number"),
        ("[variables]\nlimit_deg_9 = {low = 1, high = 2}", "number must be 1..6"),
        ("[variables]\nclearance = {low = -1.0, high = 0.001}", "clearance: must be > 0"),
        ("[variables]\nbeam_width = {low = 2, high = 1}", "expected low < high"),
        ("[constraints]\nmax_speed = 1", "constraints.max_speed: unknown constraint"),
        ("[constraints]\ntask_poses = 'none.csv'", "task_poses: file not found"),
        ("sampler = 'random'", "sampler: expected one of"),
        ("population = 1", "population: expected an integer >= 2, got 1"),
    ],
)
def test_bad_optimization_files_name_the_field(tmp_path, text, message):
    base = {
        "variables": "[variables]\nlimit_deg_2 = {low = 100, high = 150}",
        "objectives": "[objectives]\nmass = 'minimize'",
    }
    for table in list(base):
        if f"[{table}]" in text:
            del base[table]
    path = tmp_path / "o.toml"
    path.write_text(text + "\n" + "\n".join(base.values()))
    with pytest.raises((ValueError, FileNotFoundError), match=message):
        load_opt(path)


def test_nsga2_generation_size_comes_from_the_file(opt_file):
    """Every session of a run builds NSGA-II with the file's population (resumes agree)."""
    from handarm.workspace.optimize import _sampler

    opt_file.write_text("population = 7\n" + OPT)
    opt = load_opt(opt_file)
    assert opt.population == 7
    assert _sampler(opt, "nsga2", 0)._population_size == 7
    opt_file.write_text(OPT)
    assert load_opt(opt_file).population == 20  # ten generations in 200 trials


TWO_LIMITS = """
name = "two"
population = 2
[map]
voxel = 0.06
directions = 4
[variables]
limit_deg_2 = {low = 90, high = 170}
limit_deg_5 = {low = 90, high = 170}
[objectives]
reachable_volume = "maximize"
mass = {direction = "minimize", reference = 200}
"""


def test_nsga2_children_blend_their_parents_and_stay_in_the_box(tmp_path):
    """Children fill the gap between two parents and take small steps off their values.

    Optuna's default operators only swap the parents' values or draw a variable anew over
    its whole range, so a child is rarely near a good design: about half of the children
    below would copy a parent's limit_deg_2, and more than a third would lose the box edge
    (170) both parents share.
    """
    import optuna

    from handarm.workspace.optimize import _ask, _distributions, _sampler

    path = tmp_path / "two.toml"
    path.write_text(TWO_LIMITS)
    opt = load_opt(path)
    study = optuna.create_study(directions=["maximize", "minimize"])
    study.sampler = _sampler(opt, "nsga2", 0)
    dists = _distributions(opt)
    for a in (100.0, 140.0):  # the first generation: two parents on the box's upper edge
        study.enqueue_trial({"limit_deg_2": a, "limit_deg_5": 170.0})
        t = _ask(study, dists)
        study.tell(t, [a, 100.0 + a])  # neither dominates the other
    children = [study.ask(dists) for _ in range(400)]  # all of generation 1: not told
    kids = np.array([[t.params["limit_deg_2"], t.params["limit_deg_5"]] for t in children])
    a, b = kids.T
    assert np.all((kids >= 90) & (kids <= 170))  # in the box, though BLX reaches past 170
    assert np.mean(b >= 160) > 0.95  # the shared edge value moves by small steps only
    assert np.mean((a > 100) & (a < 140)) > 0.45  # new values between the parents ...
    assert np.mean(np.isin(a, (100.0, 140.0))) < 0.1  # ... rather than a parent's copied


def test_nsga2_breeds_from_the_space_filling_first_generation(tmp_path):
    """The queued first generation is NSGA-II's generation 0, so its designs are the parents.

    Optuna files a trial in a generation only when it samples it, and it never samples a
    queued trial: the corners and the Latin hypercube used to belong to no generation, and
    the first generation NSGA-II bred from was the next ``population`` random trials.
    """
    from handarm.workspace.optimize import _distributions, ask_new, first_generation, open_study

    path = tmp_path / "two.toml"
    path.write_text(TWO_LIMITS.replace("population = 2", "population = 4"))
    opt = load_opt(path)
    study = open_study(opt, tmp_path / "run", "nsga2")
    dists, seen = _distributions(opt), {}
    first = []
    for _ in range(4):
        t = ask_new(opt, study, dists, seen)
        first.append(t.params)
        study.tell(t, [t.params["limit_deg_2"], 100.0 + t.params["limit_deg_5"]])
    assert first == first_generation(opt, 4)
    child = ask_new(opt, study, dists, seen)
    sampler = study.sampler
    frozen = study.get_trials(deepcopy=False)
    key = sampler._get_generation_key()  # read, not computed: asking would file it
    assert [t.system_attrs.get(key) for t in frozen] == [0, 0, 0, 0, 1]
    parents = sampler.get_parent_population(study, 1)
    assert parents and all(p.params in first for p in parents)
    assert child.number == 4


def test_nsga2_elite_keeps_the_front_with_the_most_hypervolume(tmp_path):
    """The last front is cut by hypervolume, not by crowding distance.

    Crowding distance divides each objective by its range, so a design that is the best in
    payload by 0.04 % (D) is kept as an extreme; the hypervolume cut keeps the knee (C).
    An infeasible design is never preferred to a feasible one, however good its values.
    """
    import itertools

    import optuna
    from optuna.samplers.nsgaii._elite_population_selection_strategy import (
        NSGAIIElitePopulationSelectionStrategy,
    )

    from handarm.workspace.optimize import _HypervolumeElite

    path = tmp_path / "o.toml"
    path.write_text(
        "population = 3\n"
        + TWO_LIMITS.replace("population = 2", "").split("[objectives]")[0]
        + '[objectives]\nreachable_volume = "maximize"\nmin_cross_section = "maximize"\n'
        + 'payload = "maximize"\n'
    )
    opt = load_opt(path)
    points = {
        "A": (10.0, 1.0, 1.2100),
        "B": (1.0, 10.0, 1.2100),
        "C": (7.0, 7.0, 1.2100),
        "D": (6.0, 6.5, 1.2105),
        "E": (2.0, 9.0, 1.2101),
    }
    study = optuna.create_study(directions=["maximize"] * 3)
    for name, values in points.items():
        study.add_trial(
            optuna.trial.create_trial(
                values=list(values), user_attrs={"name": name}, constraints={"mass": -1.0}
            )
        )
    study.add_trial(  # best in everything, but infeasible
        optuna.trial.create_trial(
            values=[20.0, 20.0, 1.3], user_attrs={"name": "X"}, constraints={"mass": 5.0}
        )
    )
    trials = study.get_trials()

    def hv(elite):
        return hypervolume(opt, [t.values for t in elite])

    elite = _HypervolumeElite(opt)(study, list(trials))
    assert len(elite) == 3 and "X" not in {t.user_attrs["name"] for t in elite}
    feasible = [t for t in trials if t.user_attrs["name"] != "X"]
    best = max(hv(c) for c in itertools.combinations(feasible, 3))
    assert hv(elite) == pytest.approx(best)
    assert "C" in {t.user_attrs["name"] for t in elite}
    crowded = NSGAIIElitePopulationSelectionStrategy(population_size=3)(study, list(trials))
    assert hv(crowded) < 0.9 * best  # Optuna's own cut loses the knee here


def test_search_starts_from_the_corners_and_a_latin_hypercube(opt_file, tmp_path):
    """NSGA-II's first generation is space-filling, holds the box's corners, and is what runs."""
    from handarm.workspace.optimize import first_generation

    opt_file.write_text('sampler = "nsga2"\npopulation = 12\n' + OPT)
    opt = load_opt(opt_file)
    gen = first_generation(opt, 12)
    assert gen == first_generation(opt, 12)  # reproducible from the file's seed
    points = {(p["limit_deg_5"], p["beam_width"]) for p in gen}
    for corner in ((110, 0.011), (110, 0.013), (160, 0.011), (160, 0.013)):
        assert any(np.allclose(corner, p) for p in points), corner
    assert all(p["limit_deg_5"] in (110, 120, 130, 140, 150, 160) for p in gen)
    widths = np.array([p["beam_width"] for p in gen[4:]])  # the Latin hypercube part
    assert np.all((widths >= 0.011) & (widths <= 0.013))
    strata = np.floor((widths - 0.011) / 0.002 * len(widths)).astype(int)
    assert sorted(strata) == list(range(len(widths)))  # one point per stratum
    out = tmp_path / "run"
    run_optimization(opt, out, workers=1, trials=5)
    rows = list(csv.DictReader((out / "trials.csv").open()))
    ran = [(float(r["limit_deg_5"]), float(r["beam_width"])) for r in rows]
    assert len(ran) == 5
    want = [(p["limit_deg_5"], p["beam_width"]) for p in gen[:5]]
    assert np.allclose(sorted(ran), sorted(want))


def test_gp_sampler_without_pytorch_is_refused_before_any_trial(
    opt_file, tmp_path, monkeypatch, capsys
):
    import importlib.util

    find_spec = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util,
        "find_spec",
        lambda name, *a: None if name == "torch" else find_spec(name, *a),
    )
    out = tmp_path / "run"
    code = main(["optimize", str(opt_file), "--out", str(out), "--sampler", "gp"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1, err
    assert "--sampler: 'gp' (Gaussian-process search) needs PyTorch" in err
    assert "handarm[gp]" in err
    assert not out.exists()  # refused before the journal was made
    opt_file.write_text('sampler = "gp"\n' + OPT)
    with pytest.raises(ValueError, match=r"opt.toml: sampler: 'gp' .* needs PyTorch"):
        run_optimization(load_opt(opt_file), out)
    assert not out.exists()


def test_task_poses_csv(tmp_path, opt_file):
    (tmp_path / "poses.csv").write_text("x,y,z,ex,ey,ez\n0.1,0,0,1,0,0\n0.05,0.05,0,0,1,0\n")
    opt_file.write_text(OPT + 'task_poses = "poses.csv"\n')
    opt = load_opt(opt_file)
    assert opt.task_poses.shape == (2, 6)
    values, violated = feasibility(
        opt,
        {"printable": True, "motor_travel_ok": True, "mass_g": 160.0, "task_reached": 0.5},
    )
    assert violated == ["max_mass_g", "task_poses"]
    assert values["max_mass_g"] == pytest.approx(10.0) and values["task_poses"] == 0.5


def test_hypervolume_against_a_grid_count(opt_file):
    """2-D hypervolume checked by counting cells of a fine grid (independent of optuna)."""
    opt = load_opt(opt_file)  # reachable volume up (ref 0 L), mass down (ref 200 g)
    rng = np.random.default_rng(3)
    pts = np.column_stack([rng.uniform(0, 60, 12), rng.uniform(50, 250, 12)])
    vx = np.linspace(0, 60, 601)[:-1] + 0.05
    my = np.linspace(0, 200, 2001)[:-1] + 0.05
    X, Y = np.meshgrid(vx, my, indexing="ij")
    covered = np.zeros(X.shape, bool)
    for v, m in pts:
        covered |= (X <= v) & (Y >= m)
    expected = covered.sum() * 0.1 * 0.1
    assert hypervolume(opt, pts) == pytest.approx(expected, rel=0.01)
    assert hypervolume(opt, [[-1.0, 100.0]]) == 0.0  # worse than the reference adds nothing


def test_direction_count_is_honoured_or_refused():
    for n in (4, 12, 16, 36, 56, 100):
        assert len(direction_set(n)) == n
    with pytest.raises(ValueError, match="nearest valid counts: 36 and 56"):
        direction_set(48)
    below, above = nearest_direction_counts(48)
    assert (below, above) == (36, 56)
    # brute force: no count strictly between them is valid
    for n in range(below + 1, above):
        with pytest.raises(ValueError):
            direction_set(n)
    with pytest.raises(ValueError, match="directions"):
        reachability_map(handarm.ArmDesign(), 0.05, 48)


def test_map_records_its_settings_and_narrow_ranges_do_not_count(tmp_path):
    d = handarm.ArmDesign()
    m = reachability_map(d, 0.05, 16)
    assert m.collision_model == d.collision_model and m.min_width > 0
    with np.load(m.save_npz(tmp_path / "m.npz")) as z:
        assert str(z["collision_model"]) == d.collision_model
        assert float(z["min_width"]) == m.min_width
    # mirrored and full maps agree in the mean solution count too (no one-sided ranges)
    full = reachability_map(d, 0.05, 16, use_symmetry=False)
    np.testing.assert_array_equal(m.mean_solutions, full.mean_solutions)
    # counting every range (min_width 0) can only add reachable voxels
    zero = reachability_map(d, 0.05, 16, min_width=0.0)
    assert np.all(zero.reachable >= m.reachable)


def test_jittered_and_rotated_maps_are_full_and_close():
    d = handarm.ArmDesign()
    base = reachability_map(d, 0.05, 16)
    rot = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]]) @ np.array(
        [[np.cos(0.3), -np.sin(0.3), 0], [np.sin(0.3), np.cos(0.3), 0], [0, 0, 1]]
    )
    m = reachability_map(d, 0.05, 16, offset=(0.01, -0.02, 0.005), rotation=rot)
    assert m.mirrored == (False, False) and m.offset == (0.01, -0.02, 0.005)
    v0, v1 = base.reachable.sum(), m.reachable.sum()
    assert abs(v1 - v0) <= 0.15 * v0


def test_paper_3r_section_check_is_a_subset_count():
    s = paper_3r_section_check(handarm.ArmDesign(), samples=200_000)
    assert s["area_mm2"] > 0
    assert all(v >= 0 for v in s["area_lost_mm2"].values())
    # narrowing more never loses less (same samples, nested subsets)
    more = paper_3r_section_check(handarm.ArmDesign(), delta_deg=20.0, samples=200_000)
    for k in ("1", "2", "3"):
        assert more["area_lost_mm2"][k] >= s["area_lost_mm2"][k]
    # joint 1 at +-10 deg narrowed by 10 deg: a single line of directions is left
    narrow = handarm.ArmDesign().with_limits_deg([10, 150, 150, 150, 150, 150])
    n = paper_3r_section_check(narrow, delta_deg=10.0, samples=200_000)
    assert n["area_lost_mm2"]["1"] > 0.8 * n["area_mm2"]


def test_study_pareto_is_physical_and_not_size_normalised():
    # a bigger arm with more volume and the same mass is never dominated by a smaller one
    small = {"reachable_volume_m3": 0.03, "dexterous_volume_m3": 0.01, "mass_kg": 0.07}
    big = {"reachable_volume_m3": 0.05, "dexterous_volume_m3": 0.02, "mass_kg": 0.07}
    for r in (small, big):
        r["min_cross_section_m2"] = 50e-6
    assert pareto_front([small, big]) == [False, True]
    # strength counts: a lighter design with a weaker link does not dominate
    weak = dict(big, mass_kg=0.06, min_cross_section_m2=40e-6)
    assert pareto_front([big, weak]) == [True, True]
    # brute-force check on random rows
    rng = np.random.default_rng(0)
    rows = [
        dict(
            zip(
                ["reachable_volume_m3", "dexterous_volume_m3", "mass_kg", "min_cross_section_m2"],
                rng.integers(0, 3, 4).tolist(),
                strict=True,
            )
        )
        for _ in range(30)
    ]
    front = pareto_front(rows)
    keys = ("reachable_volume_m3", "dexterous_volume_m3", "mass_kg", "min_cross_section_m2")
    sense = (1, 1, -1, 1)

    def dominates(b, a):
        ge = all(s * b[k] >= s * a[k] for k, s in zip(keys, sense, strict=True))
        return ge and any(b[k] != a[k] for k in keys)

    for i, a in enumerate(rows):
        assert front[i] == (not any(dominates(b, a) for b in rows))


def test_study_refuses_a_direction_count_it_cannot_make(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text("directions = 48\n")
    with pytest.raises(ValueError, match="nearest valid counts: 36 and 56"):
        load_study(path)


@pytest.mark.slow
def test_optimize_resumes_extends_and_writes_the_front(opt_file, tmp_path, capsys):
    opt = load_opt(opt_file)
    out = tmp_path / "run"
    first = run_optimization(opt, out, workers=1, stop_after=1)  # an interrupted run
    assert first["new"] == 1 and first["finished"] == 1
    second = run_optimization(opt, out, workers=1)  # resumes to the file's 3 trials
    assert second["new"] == 2 and second["finished"] == 3
    code = main(["optimize", str(opt_file), "--out", str(out), "--trials", "4", "--quiet"])
    assert code == 0 and "1 trials run now, 4 in the journal" in capsys.readouterr().out
    rows = list(csv.DictReader((out / "trials.csv").open()))
    assert [int(r["trial"]) for r in rows] == [0, 1, 2, 3]
    front = json.loads((out / "front.json").read_text())
    assert front["trials"] == 4 and front["map"]["directions"] == 4
    assert {o["unit"] for o in front["objectives"]} == {"L", "g"}
    on_front = {int(r["trial"]) for r in rows if r["pareto"] == "True"}
    assert on_front == {d["trial"] for d in front["designs"]}
    for d in front["designs"]:
        design = handarm.ArmDesign.from_toml(out / d["toml"])
        assert design.beam_width == pytest.approx(d["params"]["beam_width"])
        assert d["measurements"]["mass_g"] <= 150  # feasible only
    # the front is exactly the non-dominated feasible rows (brute force)
    feas = [r for r in rows if r["feasible"] == "True"]
    for r in feas:
        dominated = any(
            float(o["reachable_volume_L"]) >= float(r["reachable_volume_L"])
            and float(o["mass_g"]) <= float(r["mass_g"])
            and (float(o["reachable_volume_L"]), float(o["mass_g"]))
            != (float(r["reachable_volume_L"]), float(r["mass_g"]))
            for o in feas
        )
        assert (r["pareto"] == "True") == (not dominated)
    for name in ("pareto.png", "hypervolume.png", "parallel.png", "importance.png"):
        assert (out / "pictures" / name).read_bytes()[:4] == b"\x89PNG"
    assert "plotly" in (out / "pictures" / "optimize.html").read_text()[:200_000].lower()
    page = (out / "report.html").read_text()
    assert "trial" in page and '<script src="http' not in page  # the run's offline page
    # another optimization into the same folder is refused, naming the option
    opt_file.write_text(OPT.replace("max_mass_g = 150", "max_mass_g = 140"))
    code = main(["optimize", str(opt_file), "--out", str(out)])  # with its progress bar
    err = capsys.readouterr().err
    assert code == 2 and "--out" in err
    assert len(err.strip().splitlines()) == 1, err  # no bar drawn before the refusal


def test_workspace_sensitivity_uses_the_map_settings_asked_for(tmp_path):
    from handarm.workspace.report import write_workspace_outputs

    write_workspace_outputs(handarm.ArmDesign(), tmp_path, voxel=0.06, directions=4)
    report = json.loads((tmp_path / "workspace.json").read_text())
    sens = report["sensitivity"]
    assert (sens["voxel"], sens["directions"]) == (0.06, 4)
    assert report["collision_model"] == "printed" and report["min_width_m"] > 0
    for row in sens["joints"]:
        assert row["dexterous_mu_star_L"] >= 0 and row["dexterous_mu_star_conf_L"] >= 0


def test_grid_sampler_runs_past_the_end_of_its_grid_under_ask_and_tell(opt_file):
    import optuna

    from handarm.workspace.optimize import _distributions, _sampler

    opt = load_opt(opt_file)
    study = optuna.create_study(
        directions=["maximize", "minimize"], sampler=_sampler(opt, "grid", 0)
    )
    seen = set()
    for _ in range(6 * 5 + 2):  # the whole grid (6 limits x 5 widths), then two more
        t = study.ask(_distributions(opt))
        seen.add((t.params["limit_deg_5"], t.params["beam_width"]))
        study.tell(t, [1.0, 1.0])
    assert len(seen) == 30


def test_repeated_parameter_sets_are_answered_from_the_journal_not_measured(tmp_path):
    """NSGA-II children often copy a parent: such a trial is told the stored measurement."""
    import optuna

    from handarm.workspace.optimize import _distributions, ask_new, counted

    path = tmp_path / "opt.toml"
    path.write_text(
        OPT.replace(
            "beam_width = {low = 0.011, high = 0.013}",
            "limit_deg_2 = {low = 110, high = 160, step = 25}",
        ).replace("trials = 3", "trials = 3\npopulation = 4")
    )
    opt = load_opt(path)
    study = optuna.create_study(
        directions=["maximize", "minimize"],
        sampler=optuna.samplers.NSGAIISampler(population_size=4, seed=3),
    )
    dists, seen, measured = _distributions(opt), {}, []
    for _ in range(12):  # 12 of the 6 x 3 parameter sets
        t = ask_new(opt, study, dists, seen)
        a, b = t.params["limit_deg_5"], t.params["limit_deg_2"]
        m = {"reachable_volume_L": a + b, "mass_g": 100.0 + a - b, "printable": True}
        m["motor_travel_ok"] = True
        t.set_user_attr("measurements", m)
        study.tell(t, [m["reachable_volume_L"], m["mass_g"]])
        measured.append((a, b))
    assert len(set(measured)) == 12  # every measurement is of a new design
    trials = study.get_trials(deepcopy=False)
    repeats = [t for t in trials if "repeat_of" in t.user_attrs]
    assert repeats  # the sampler did ask for designs it had already seen
    for t in repeats:
        first = trials[t.user_attrs["repeat_of"]]
        assert t.params == first.params and t.values == first.values
        assert not counted(t) and counted(first)
    assert sum(counted(t) for t in trials) == 12


@pytest.mark.slow
def test_optimize_resumes_after_the_process_is_killed(opt_file, tmp_path):
    """SIGKILL the command (and its Dask workers) while a trial is being measured; the same
    command then finishes the run, measuring the trial that was in flight first."""
    import os
    import signal
    import subprocess
    import sys
    import time

    import optuna
    from optuna.storages import JournalStorage
    from optuna.storages.journal import JournalFileBackend

    out = tmp_path / "run"
    cmd = [sys.executable, "-m", "handarm.cli", "optimize", str(opt_file), "--out", str(out)]
    cmd += ["--workers", "1", "--quiet"]
    proc = subprocess.Popen(cmd, start_new_session=True)

    def states():
        if not (out / "journal.log").exists():
            return []
        storage = JournalStorage(JournalFileBackend(str(out / "journal.log")))
        study = optuna.load_study(study_name="tiny", storage=storage)
        return [t.state.name for t in study.get_trials(deepcopy=False)]

    deadline = time.monotonic() + 300
    while time.monotonic() < deadline and proc.poll() is None:
        s = states()
        if "COMPLETE" in s and "RUNNING" in s:
            break
        time.sleep(0.2)
    assert proc.poll() is None, "the run ended before it could be killed"
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    assert not (out / "trials.csv").exists()  # killed before any output was written
    assert main(["optimize", str(opt_file), "--out", str(out), "--workers", "1", "--quiet"]) == 0
    rows = list(csv.DictReader((out / "trials.csv").open()))
    assert len(rows) == 3 and {r["state"] for r in rows} == {"COMPLETE"}
    storage = JournalStorage(JournalFileBackend(str(out / "journal.log")))
    trials = optuna.load_study(study_name="tiny", storage=storage).get_trials()
    assert [t.state.name for t in trials if t.state.name != "WAITING"] == ["COMPLETE"] * 3
