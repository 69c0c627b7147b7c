"""``handarm optimize``: constrained multi-objective design search on Optuna and Dask.

Each trial is a design (the base design with the file's variables applied). It is carved
(printability, mass, minimum cross-section, achieved joint limits), its payload is sized
(``firmware_bridge.sizing.max_payload`` on the carved link masses: a convex inner solve),
its motor travel checked, and it is mapped with the achieved limits. The measurements are
stored in Optuna's journal (``OUT/journal.log``) with the trial, so an interrupted run
resumes and a finished one is extended by asking for more trials; objectives, constraint
values, the front and every output are recomputed from those measurements.

Output layout (stable; other tools read it)::

    OUT/journal.log        Optuna JournalStorage (the source of truth)
    OUT/trials.csv         one row per trial: number, state, variables, measurements,
                           feasible, violated, pareto
    OUT/front.json         {"name", "fingerprint", "objectives": [{name, key, unit,
                           direction, reference}], "hypervolume", "map", "designs": [{trial,
                           params, measurements, toml, full?}], "ties": [[a, b, objective]]}
    OUT/front/trial-NNNN.toml   each front design; --build adds OUT/front/trial-NNNN/
    OUT/pictures/          pareto.png, hypervolume.png, parallel.png, importance.png and
                           optimize.html (the same, interactive, hover for trial numbers)
    OUT/report.html        the page of the run (``handarm.report``): fronts, history,
                           parallel coordinates, comparison of two designs
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np

from handarm._io import write_text_atomic
from handarm._outdir import check_out_dir
from handarm.design import ArmDesign
from handarm.workspace._dask import check_scheduler, close_client, open_client
from handarm.workspace.opt_file import CONSTRAINTS, OptFile

__all__ = [
    "measure_design",
    "run_optimization",
    "check_sampler",
    "write_outputs",
    "hypervolume",
    "feasibility",
    "map_uncertainty",
]

_TRIAL_STATES = ("COMPLETE", "FAIL", "PRUNED")
#: A sampler that asks for this many parameter sets in a row that were all measured before
#: has converged: its next repeat is measured again (and counted), so a run always ends.
_MAX_REPEATS = 50


def counted(t) -> bool:
    """Whether trial ``t`` is a finished measurement (not one in flight, queued or a repeat).

    A repeat is a trial whose parameters a sampler asked for again (NSGA-II's children
    often copy a parent): it is answered from the earlier trial's stored measurement, which
    keeps the sampler's bookkeeping right, and it does not count against ``--trials``. A
    trial that a killed run left running is not counted until it is measured (first thing
    when the run is resumed).
    """
    return t.state.name in _TRIAL_STATES and "repeat_of" not in t.user_attrs


def measure_design(
    design_dict: dict,
    map_settings: dict,
    task_poses: list | None = None,
    threads: int | None = None,
    repeats: int = 0,
) -> dict:
    """Every measurement of one design in physical units (a Dask task).

    Parameters
    ----------
    design_dict : dict
        ``ArmDesign.to_dict()``.
    map_settings : dict
        ``voxel`` (m), ``directions``, ``threshold``, ``min_width`` (m of u).
    task_poses : list of 6 floats, optional
        Poses (x, y, z, ex, ey, ez) that must be reachable.
    threads : int, optional
        Numba threads in this worker.
    repeats : int
        Extra maps on jittered grids with rotated directions (``map_uncertainty``).

    Returns
    -------
    dict
        ``printable`` (and ``error`` when not), ``mass_g``, ``min_cross_section_mm2``,
        ``payload_kg``, ``motor_travel_ok``, ``reachable_volume_L``, ``dexterous_volume_L``,
        ``mean_index``, ``task_reached`` (fraction), ``achieved_limits_deg``, the map
        settings and collision model used, and ``*_sd`` uncertainties when ``repeats``.
    """
    if threads is not None:
        import numba

        numba.set_num_threads(max(1, min(threads, numba.config.NUMBA_NUM_THREADS)))
    from handarm.carve import carve
    from handarm.carve.properties import link_properties
    from handarm.firmware_bridge.sizing import carved_link_masses, max_payload
    from handarm.ik import count_solutions
    from handarm.transmission import motor_ranges
    from handarm.workspace.maps import reachability_map
    from handarm.workspace.scores import map_scores

    design = ArmDesign.from_dict(design_dict)
    out = {"collision_model": design.collision_model, "map": dict(map_settings)}
    try:
        carved = carve(design, 2.0)
    except ValueError as exc:
        return {**out, "printable": False, "error": f"carving failed: {exc}"}
    props = [link_properties(link, design.density) for link in carved.links]
    broken = [p["link"] for p in props if not p["watertight"] or p["bodies"] != 1]
    out["printable"] = not broken
    if broken:
        out["error"] = f"links not one watertight body: {', '.join(broken)}"
    out["mass_g"] = 1e3 * sum(p["mass_kg"] for p in props)
    out["min_cross_section_mm2"] = 1e6 * min(p["min_cross_section_m2"] for p in props)
    mapped = carved.as_built  # what the printed links allow, within what was asked
    out["achieved_limits_deg"] = [[math.degrees(v) for v in lim] for lim in mapped.joint_limits]
    try:
        motor_ranges(mapped)
        out["motor_travel_ok"] = True
    except ValueError:
        out["motor_travel_ok"] = False
    payload, _info = max_payload(mapped, links=carved_link_masses(carved))
    out["payload_kg"] = payload
    s = map_settings
    wmap = reachability_map(mapped, s["voxel"], s["directions"], min_width=s["min_width"])
    sc = map_scores(wmap, s["threshold"])
    out["reachable_volume_L"] = 1e3 * sc["reachable_volume_m3"]
    out["dexterous_volume_L"] = 1e3 * sc["dexterous_volume_m3"]
    out["mean_index"] = sc["mean_index"]
    if task_poses is not None and len(task_poses):
        poses = np.asarray(task_poses, float)
        counts = count_solutions(mapped, poses[:, :3], poses[:, 3:], min_width=s["min_width"])
        out["task_reached"] = float(np.mean(counts > 0))
    if repeats:
        out |= map_uncertainty(mapped, s, repeats)
    return out


def map_uncertainty(design: ArmDesign, settings: dict, repeats: int, seed: int = 0) -> dict:
    """Spread of the volumes over ``repeats`` maps on jittered grids with rotated directions.

    Each repeat shifts the voxel grid by a random fraction of a voxel along each axis and
    turns the direction set by a random rotation; the standard deviation over the repeats
    and the unshifted map is the uncertainty of the map's volumes (L).
    """
    from scipy.spatial.transform import Rotation

    from handarm.workspace.maps import reachability_map
    from handarm.workspace.scores import map_scores

    rng = np.random.default_rng(seed)
    v = settings["voxel"]
    vols = []
    for r in range(repeats + 1):
        offset = (0.0, 0.0, 0.0) if r == 0 else tuple(rng.uniform(-0.5, 0.5, 3) * v)
        rot = None if r == 0 else Rotation.random(random_state=rng).as_matrix()
        wmap = reachability_map(
            design,
            v,
            settings["directions"],
            min_width=settings["min_width"],
            offset=offset,
            rotation=rot,
        )
        sc = map_scores(wmap, settings["threshold"])
        vols.append((sc["reachable_volume_m3"] * 1e3, sc["dexterous_volume_m3"] * 1e3))
    vols = np.array(vols)
    return {
        "reachable_volume_L_sd": float(vols[:, 0].std(ddof=1)),
        "dexterous_volume_L_sd": float(vols[:, 1].std(ddof=1)),
        "reachable_volume_L_mean": float(vols[:, 0].mean()),
        "dexterous_volume_L_mean": float(vols[:, 1].mean()),
        "uncertainty_repeats": repeats,
    }


def feasibility(opt: OptFile, m: dict) -> tuple[dict, list[str]]:
    """Constraint values by name (<= 0 is satisfied, Optuna's convention) and those violated.

    Always ``printable`` and ``motor_travel``; then the file's constraints and, with task
    poses, ``task_poses`` (the fraction of poses not reached).
    """
    values = {"printable": 0.0 if m.get("printable") else 1.0}
    if m.get("printable"):
        values["motor_travel"] = 0.0 if m["motor_travel_ok"] else 1.0
        for name, bound in opt.constraints.items():
            key, sense = CONSTRAINTS[name]
            values[name] = float(m[key] - bound if sense == "max" else bound - m[key])
        if "task_reached" in m:
            values["task_poses"] = 1.0 - m["task_reached"]
    return values, [k for k, v in values.items() if v > 0]


def _values(opt: OptFile, m: dict) -> list[float]:
    return [float(m[o.key]) for o in opt.objectives]


def hypervolume(opt: OptFile, points) -> float:
    """Hypervolume of objective vectors (physical units) against the objectives' references.

    Points worse than the reference in any objective add nothing.
    """
    from optuna._hypervolume import compute_hypervolume

    sign = np.array([-1.0 if o.direction == "maximize" else 1.0 for o in opt.objectives])
    ref = sign * np.array([o.reference for o in opt.objectives])
    pts = np.atleast_2d(np.asarray(points, float)) * sign
    if pts.size == 0:
        return 0.0
    pts = pts[np.all(pts < ref, axis=1)]
    if not len(pts):
        return 0.0
    return float(compute_hypervolume(pts, ref))


def _sampler(opt: OptFile, name: str, seed: int):
    """The named sampler; ``seed`` differs per session so a resumed run does not repeat."""
    import optuna

    if name == "nsga2":
        return _nsga2(opt, seed)
    if name == "tpe":
        # multivariate: the variables' joint density (limits of two joints trade together);
        # constant liar: trials in flight count as bad so two workers are not asked the
        # same point
        return optuna.samplers.TPESampler(
            seed=seed, multivariate=True, constant_liar=True, n_startup_trials=20
        )
    if name == "gp":
        return optuna.samplers.GPSampler(seed=seed)
    space = {}
    for v in opt.variables:
        if v.choices is not None:
            space[v.name] = list(v.choices)
        elif v.step is not None:
            space[v.name] = list(np.arange(v.low, v.high + v.step / 2, v.step))
        else:
            space[v.name] = list(np.linspace(v.low, v.high, opt.grid_points))
        if v.integer:
            space[v.name] = sorted({int(round(x)) for x in space[v.name]})
    return _AskTellGrid(space, seed=seed)


def _nsga2(opt: OptFile, seed: int):
    """Optuna's NSGA-II with real-coded variation and a hypervolume-cut elite.

    Optuna's defaults suit mixed spaces: uniform crossover only swaps the parents' values and
    a "mutated" variable is drawn anew, uniformly over its range, so no child is ever *near*
    a good design, and a front whose best points sit on a cliff (a carving limit, a step of
    one voxel in a volume) is found only by luck. Here, for numeric variables:

    - BLX-0.5 crossover (Eshelman and Schaffer's blend): each variable uniform over the
      parents' interval widened by half its length, so children fill the gaps between two
      front designs and reach a little beyond them; Optuna brings a child outside the box
      back into it (Optuna 5: a continuous variable past its upper bound is clipped just
      under it and one below its lower bound is drawn again; a stepped or integer variable
      is clipped to the nearer bound), so every design is within the bounds;
    - polynomial mutation, distribution index 20, probability 1 / number of variables
      (Deb's NSGA-II settings): a small step, bounded so that it stays in the box and can
      reach its edges.

    Categorical variables keep Optuna's uniform crossover and random resampling. The last
    non-dominated front that does not fit in the population is cut by hypervolume (greedy
    subset selection against the objectives' references, ``_HypervolumeElite``) instead of
    crowding distance.
    """
    import optuna
    from optuna.samplers.nsgaii import BLXAlphaCrossover, PolynomialMutation

    with warnings.catch_warnings():
        # these building blocks are marked experimental in Optuna 5; their behaviour is
        # pinned by the tests
        warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
        return optuna.samplers.NSGAIISampler(
            population_size=opt.population,
            crossover=BLXAlphaCrossover(alpha=0.5),
            mutation=PolynomialMutation(eta=20.0),
            elite_population_selection_strategy=_HypervolumeElite(opt),
            seed=seed,
        )


class _HypervolumeElite:
    """NSGA-II's elite: whole non-dominated fronts, the last one cut by hypervolume.

    Optuna cuts the last front by crowding distance, which divides each objective's gaps
    by that objective's range in the population: an objective that hardly moves (payload
    varies by 0.05 % near the paper's arm) weighs as much as one that moves by a third,
    and the elite spreads over differences nobody can measure. Greedy hypervolume subset
    selection (``optuna._hypervolume._solve_hssp``, what Optuna's TPE uses to break the
    same tie) keeps the designs that add most to the front's hypervolume against the
    objectives' references: the quantity the run reports. Designs that are infeasible or
    not better than a reference add no hypervolume and are cut by crowding distance, as
    in Optuna.
    """

    def __init__(self, opt: OptFile):
        self._size = opt.population
        self._sign = np.array([-1.0 if o.direction == "maximize" else 1.0 for o in opt.objectives])
        self._ref = self._sign * np.array([o.reference for o in opt.objectives])

    def __call__(self, study, population: list) -> list:
        from optuna._hypervolume import _solve_hssp
        from optuna.samplers.nsgaii._elite_population_selection_strategy import (
            _crowding_distance_sort,
            _rank_population,
        )
        from optuna.study._constrained_optimization import _is_constrained_optimization

        constrained = _is_constrained_optimization(population)
        elite = []
        for front in _rank_population(population, study.directions, is_constrained=constrained):
            if len(elite) + len(front) <= self._size:
                elite.extend(front)
                if len(elite) == self._size:
                    break
                continue
            n = self._size - len(elite)
            loss = np.array([t.values for t in front]) * self._sign
            ok = np.all(loss < self._ref, axis=1)
            if constrained:
                ok &= np.array([all(v <= 0 for v in t.constraints.values()) for t in front])
            idx = np.flatnonzero(ok)
            if len(idx) > n:
                idx = _solve_hssp(loss[idx], idx, n, self._ref)
            chosen = {int(i) for i in idx}
            rest = [t for i, t in enumerate(front) if i not in chosen]
            _crowding_distance_sort(rest)
            elite += [front[i] for i in sorted(chosen)] + rest[: n - len(chosen)]
            break
        return elite


def check_sampler(opt: OptFile, sampler: str | None = None) -> None:
    """Refuse, before any trial, a sampler (``sampler`` or the file's) whose library is absent.

    Optuna's GP sampler imports PyTorch only after its random start-up trials, so without
    this check a run would fail ten trials in.
    """
    import importlib.util

    name, where = (sampler, "sampler") if sampler else (opt.sampler, f"{opt.path}: sampler")
    if name == "gp" and importlib.util.find_spec("torch") is None:
        raise ValueError(
            f"{where}: 'gp' (Gaussian-process search) needs PyTorch, which is not installed: "
            "pip install 'handarm[gp]', or use nsga2 or tpe"
        )


def _grid_class():
    import optuna

    class AskTellGrid(optuna.samplers.GridSampler):
        """The grid sampler without its ``study.stop()`` at the end of the grid.

        That call only works inside ``study.optimize``; here the number of trials asked
        already bounds the run (a grid revisits points once it is exhausted).
        """

        def after_trial(self, study, trial, state, values) -> None:
            return None

    return AskTellGrid


def _AskTellGrid(space, seed):  # noqa: N802 - reads as the class it builds
    return _grid_class()(space, seed=seed)


def _distributions(opt: OptFile) -> dict:
    from optuna.distributions import (
        CategoricalDistribution,
        FloatDistribution,
        IntDistribution,
    )

    out = {}
    for v in opt.variables:
        if v.choices is not None:
            out[v.name] = CategoricalDistribution(v.choices)
        elif v.integer:
            out[v.name] = IntDistribution(int(v.low), int(v.high), step=int(v.step or 1))
        else:
            out[v.name] = FloatDistribution(v.low, v.high, step=v.step)
    return out


def open_study(opt: OptFile, out: Path, sampler: str | None = None):
    """The Optuna study in ``out/journal.log`` (created or resumed).

    Raises
    ------
    ValueError
        If ``out`` holds a run of a different optimization (other variables, objectives,
        constraints or map settings): results would not be comparable.
    """
    import optuna
    from optuna.storages import JournalStorage
    from optuna.storages.journal import JournalFileBackend

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    out.mkdir(parents=True, exist_ok=True)
    storage = JournalStorage(JournalFileBackend(str(out / "journal.log")))
    study = optuna.create_study(
        study_name=opt.name,
        storage=storage,
        directions=[o.direction for o in opt.objectives],
        load_if_exists=True,
    )
    stored = study.user_attrs.get("fingerprint")
    if stored is None:
        study.set_user_attr("fingerprint", opt.fingerprint())
    elif stored != opt.fingerprint():
        raise ValueError(
            f"out: {out} holds a run of a different optimization file (variables, objectives, "
            "constraints or map settings changed); use another --out"
        )
    # a resumed session gets its own seed, still reproducible: file seed + trials so far
    name = sampler or opt.sampler
    if not study.trials and name in ("nsga2", "tpe"):
        for params in first_generation(opt, _STARTUP[name](opt)):
            study.enqueue_trial(params)
    study.sampler = _sampler(opt, name, opt.seed + len(study.trials))
    return study


# how many trials a searching sampler draws before it models anything: NSGA-II's first
# generation, TPE's start-up trials
_STARTUP = {"nsga2": lambda opt: opt.population, "tpe": lambda opt: 20}


def first_generation(opt: OptFile, n: int) -> list[dict]:
    """``n`` space-filling parameter sets to start a search from, reproducible from the seed.

    The box's corners first (all of them when there are at most ``n / 2``: the extreme
    designs are where the front of a limits-versus-strength trade ends, and a random first
    generation rarely holds them), then a scrambled Latin hypercube for the rest, each
    coordinate snapped to its variable's step, integer or choice. Optuna draws the first
    generation at random, which left NSGA-II below a grid of the same budget in half the
    benchmark's seeds. The set is queued in the journal; ``_ask`` files it as NSGA-II's
    generation 0, so that it is what the second generation is bred from.
    """
    from scipy.stats import qmc

    dim = len(opt.variables)
    corners = []
    if 2**dim <= n // 2:
        corners = [[(i >> k) & 1 for k in range(dim)] for i in range(2**dim)]
    rest = qmc.LatinHypercube(d=dim, seed=opt.seed).random(n - len(corners))
    unit = np.vstack([np.array(corners, float).reshape(-1, dim), rest])
    return [
        {v.name: _snap(v, float(x)) for v, x in zip(opt.variables, row, strict=True)}
        for row in unit
    ]


def _snap(v, x: float):
    """The value of variable ``v`` at ``x`` in [0, 1] of its range (or of its choices)."""
    if v.choices is not None:
        return v.choices[min(int(x * len(v.choices)), len(v.choices) - 1)]
    value = v.low + x * (v.high - v.low)
    if v.step is not None:
        value = v.low + round((value - v.low) / v.step) * v.step
        value = min(value, v.high)
    return int(round(value)) if v.integer else float(value)


def run_optimization(
    opt: OptFile,
    out: str | os.PathLike[str],
    *,
    trials: int | None = None,
    sampler: str | None = None,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: Callable[[int, int, int, float], None] | None = None,
    stop_after: int | None = None,
) -> dict:
    """Run (or resume, or extend) the optimization until ``trials`` trials have finished.

    Parameters
    ----------
    opt : OptFile
    out : path
        Output folder (the journal lives here; see the module doc for the layout).
    trials : int, optional
        Total finished trials wanted (default: the file's ``trials``).
    sampler : str, optional
        ``nsga2``, ``tpe``, ``gp`` or ``grid`` (default: the file's).
    scheduler : str, optional
        A Dask scheduler address; default: a local cluster of ``workers`` processes.
    workers : int, optional
        Local worker processes and trials in flight (default 2).
    progress : callable, optional
        ``progress(finished, total, front_size, hypervolume)`` after each trial.
    stop_after : int, optional
        Stop after this many new trials (what an interruption looks like; for tests).

    Returns
    -------
    dict
        ``new`` (trials run now), ``finished`` (in the journal), ``repeats`` (parameter
        sets the sampler asked for again, answered from the journal: see ``counted``),
        ``front``, ``hypervolume``.
    """
    if trials is not None and (isinstance(trials, bool) or trials < 1):
        raise ValueError(f"trials: expected an integer >= 1, got {trials!r}")
    if workers is not None and workers < 1:
        raise ValueError(f"workers: expected an integer >= 1, got {workers!r}")
    check_sampler(opt, sampler)
    check_scheduler(scheduler)
    out = check_out_dir(out)
    total = trials or opt.trials
    study = open_study(opt, out, sampler)
    finished = sum(counted(t) for t in study.get_trials(deepcopy=False))
    todo = max(0, total - finished)
    if stop_after is not None:
        todo = min(todo, stop_after)
    if progress:
        progress(finished, total, *_front_stats(opt, study))
    new = 0
    if todo:
        new = _run_trials(opt, study, out, todo, scheduler, workers, progress, finished, total)
    result = write_outputs(opt, study, out)
    from handarm.report import write_report  # plotly: loaded only for the report

    write_report(out)
    repeats = sum("repeat_of" in t.user_attrs for t in study.get_trials(deepcopy=False))
    return {"new": new, "finished": finished + new, "repeats": repeats, **result}


def _run_trials(opt, study, out, todo, scheduler, workers, progress, finished, total) -> int:
    import optuna
    from dask.distributed import as_completed

    dists = _distributions(opt)
    poses = None if opt.task_poses is None else opt.task_poses.tolist()
    client, cluster, threads, inflight_max = open_client(scheduler, workers, out=out)
    asked = done = 0
    running = {}

    # measured (or in flight) parameter sets -> trial number
    trials = study.get_trials(deepcopy=False)
    seen = {_param_key(t.params): t.number for t in trials if counted(t)}
    # trials a killed run left running: measured again first, under their own numbers
    left = [t for t in trials if t.state.name == "RUNNING"]
    seen.update({_param_key(t.params): t.number for t in left})

    def ask_one(ac):
        nonlocal asked, done, finished
        while asked < todo:
            if left:
                trial = optuna.trial.Trial(study, left.pop(0)._trial_id)
            else:
                trial = ask_new(opt, study, dists, seen)
            asked += 1
            try:
                design = opt.design(trial.params)
            except ValueError as exc:
                trial.set_user_attr("error", str(exc))
                study.tell(trial, state=optuna.trial.TrialState.FAIL)
                done += 1
                finished += 1
                continue
            fut = client.submit(
                measure_design,
                design.to_dict(),
                opt.map,
                poses,
                threads,
                key=f"handarm-opt-{opt.fingerprint()}-{trial.number}",
                pure=False,
            )
            running[fut.key] = trial
            ac.add(fut)
            return

    try:
        ac = as_completed([])
        for _ in range(inflight_max):
            ask_one(ac)
        for fut in ac:
            trial = running.pop(fut.key)
            try:
                m = fut.result()
            except Exception as exc:  # a worker crashed on this design: record, go on
                trial.set_user_attr("error", f"{type(exc).__name__}: {exc}")
                study.tell(trial, state=optuna.trial.TrialState.FAIL)
            else:
                _tell_measured(opt, study, trial, m)
            done += 1
            finished += 1
            if progress:
                progress(finished, total, *_front_stats(opt, study))
            ask_one(ac)
    finally:
        close_client(client, cluster, out)
    return done


def _param_key(params: dict) -> tuple:
    return tuple(sorted((k, repr(v)) for k, v in params.items()))


def ask_new(opt: OptFile, study, dists: dict, seen: dict):
    """The next trial to measure: a parameter set not in ``seen`` (params key -> trial).

    Repeats the sampler asks for are answered from ``seen`` (``_answer_repeat``) and asked
    again, up to ``_MAX_REPEATS`` in a row; the trial returned is entered in ``seen``.
    """
    for _ in range(_MAX_REPEATS):
        trial = _ask(study, dists)
        key = _param_key(trial.params)
        if key not in seen:
            break
        _answer_repeat(opt, study, trial, seen[key])
    else:
        trial = _ask(study, dists)  # converged: measured again, and counted
    seen[_param_key(trial.params)] = trial.number
    return trial


def _ask(study, dists: dict):
    """``study.ask``, with a queued trial filed in a genetic sampler's current generation.

    Optuna's NSGA-II files a trial in a generation when it samples the trial's parameters.
    It never samples a queued trial (``first_generation``), so those belonged to no
    generation: NSGA-II's first generation was the next ``population`` trials, drawn at
    random, and the corners and the Latin hypercube never became parents. Asking the
    sampler for the trial's generation files it (``BaseGASampler.get_trial_generation``
    computes and stores it); a sampled trial already has one.
    """
    trial = study.ask(dists)
    generation = getattr(study.sampler, "get_trial_generation", None)
    if generation is not None:
        generation(study, study.get_trials(deepcopy=False)[trial.number])
    return trial


def _answer_repeat(opt: OptFile, study, trial, original: int) -> None:
    """Tell ``trial`` what trial ``original`` measured (or, still in flight, that it failed)."""
    import optuna

    trial.set_user_attr("repeat_of", original)
    first = study.get_trials(deepcopy=False)[original]
    if first.state.name != "COMPLETE":
        # failed, or still being measured: the sampler learns nothing new from the copy
        study.tell(trial, state=optuna.trial.TrialState.FAIL)
        return
    _tell_measured(opt, study, trial, first.user_attrs.get("measurements", {}))


def _tell_measured(opt: OptFile, study, trial, m: dict) -> None:
    """Store measurement ``m`` with ``trial``, its constraint values, and tell the study."""
    import optuna

    trial.set_user_attr("measurements", m)
    for name, value in feasibility(opt, m)[0].items():
        trial.set_constraint(name, value)
    if m.get("printable") and "mass_g" in m and "reachable_volume_L" in m:
        study.tell(trial, _values(opt, m))
    else:
        trial.set_user_attr("error", m.get("error", "not measured"))
        study.tell(trial, state=optuna.trial.TrialState.FAIL)


def _rows(opt: OptFile, study) -> list[dict]:
    rows = []
    for t in study.get_trials(deepcopy=False):
        if not counted(t):  # running, queued and not yet asked, or a repeat
            continue
        m = t.user_attrs.get("measurements", {})
        ok = t.state.name == "COMPLETE"
        violated = ["printable"] if not ok else feasibility(opt, m)[1]
        rows.append(
            {
                "trial": t.number,
                "state": t.state.name,
                "params": dict(t.params),
                "measurements": m,
                "feasible": ok and not violated,
                "violated": violated,
                "error": t.user_attrs.get("error", ""),
            }
        )
    return rows


def _pareto(opt: OptFile, rows: list[dict]) -> list[bool]:
    sign = np.array([-1.0 if o.direction == "maximize" else 1.0 for o in opt.objectives])
    keep = [r["feasible"] for r in rows]
    pts = np.zeros((len(rows), len(sign)))
    for i, r in enumerate(rows):
        if keep[i]:
            pts[i] = sign * np.array(_values(opt, r["measurements"]))
    out = []
    for i in range(len(rows)):
        if not keep[i]:
            out.append(False)
            continue
        dom = any(
            keep[j] and np.all(pts[j] <= pts[i]) and np.any(pts[j] < pts[i])
            for j in range(len(rows))
        )
        out.append(not dom)
    return out


def _front_stats(opt: OptFile, study) -> tuple[int, float]:
    rows = _rows(opt, study)
    front = [r for r, p in zip(rows, _pareto(opt, rows), strict=True) if p]
    hv = hypervolume(opt, [_values(opt, r["measurements"]) for r in front]) if front else 0.0
    return len(front), hv


_MEASURED = (
    "reachable_volume_L",
    "dexterous_volume_L",
    "mean_index",
    "mass_g",
    "min_cross_section_mm2",
    "payload_kg",
    "motor_travel_ok",
    "task_reached",
)


def _ties(opt: OptFile, designs: list[dict]) -> list[list]:
    """Pairs of front designs whose volume objectives differ by less than their uncertainty."""
    ties = []
    for o in opt.objectives:
        if not o.key.endswith("volume_L"):
            continue
        for i, a in enumerate(designs):
            for b in designs[i + 1 :]:
                fa, fb = a.get("full"), b.get("full")
                if not fa or not fb or f"{o.key}_sd" not in fa:
                    continue
                spread = math.hypot(fa[f"{o.key}_sd"], fb[f"{o.key}_sd"])
                if abs(fa[o.key] - fb[o.key]) <= spread:
                    ties.append([a["trial"], b["trial"], o.name])
    return ties


def write_outputs(opt: OptFile, study, out: Path, *, refine: bool = True) -> dict:
    """trials.csv, front.json, the front designs' TOML and the pictures (see module doc)."""
    rows = _rows(opt, study)
    pareto = _pareto(opt, rows)
    params = [v.name for v in opt.variables]
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(["trial", "state", *params, *_MEASURED, "feasible", "violated", "pareto", "error"])
    for r, p in zip(rows, pareto, strict=True):
        m = r["measurements"]
        w.writerow(
            [
                r["trial"],
                r["state"],
                *[r["params"].get(k, "") for k in params],
                *[m.get(k, "") for k in _MEASURED],
                r["feasible"],
                ";".join(r["violated"]),
                p,
                r["error"],
            ]
        )
    write_text_atomic(out / "trials.csv", buf.getvalue())
    front = [r for r, p in zip(rows, pareto, strict=True) if p]
    old = {}
    if (out / "front.json").exists():
        old = {d["trial"]: d for d in json.loads((out / "front.json").read_text())["designs"]}
    designs = []
    for r in front:
        name = f"trial-{r['trial']:04d}"
        design = opt.design(r["params"]).replace(name=f"{opt.name}-{name}")
        design.to_toml(out / "front" / f"{name}.toml")
        entry = {
            "trial": r["trial"],
            "params": r["params"],
            "measurements": {k: r["measurements"].get(k) for k in _MEASURED},
            "toml": f"front/{name}.toml",
        }
        full = old.get(r["trial"], {}).get("full")
        if full is None and refine and (opt.map["full_voxel"] or opt.map["repeats"]):
            full = _refine(opt, design)
        if full is not None:
            entry["full"] = full
        designs.append(entry)
    hv = hypervolume(opt, [_values(opt, r["measurements"]) for r in front]) if front else 0.0
    data = {
        "name": opt.name,
        "fingerprint": opt.fingerprint(),
        "objectives": [
            {
                "name": o.name,
                "key": o.key,
                "unit": o.unit,
                "direction": o.direction,
                "reference": o.reference,
            }
            for o in opt.objectives
        ],
        "constraints": opt.constraints,
        "map": opt.map,
        "collision_model": opt.base.collision_model,
        "trials": len(rows),
        "feasible": sum(r["feasible"] for r in rows),
        "hypervolume": hv,
        "designs": designs,
        "ties": _ties(opt, designs),
    }
    write_text_atomic(out / "front.json", json.dumps(data, indent=2) + "\n")
    from handarm.workspace.opt_plots import optimization_pictures

    optimization_pictures(opt, study, rows, pareto, out / "pictures")
    return {"front": designs, "hypervolume": hv, "rows": rows}


def _refine(opt: OptFile, design: ArmDesign) -> dict:
    """A front design re-measured on the full-resolution map, with its uncertainty."""
    settings = dict(opt.map)
    settings["voxel"] = opt.map["full_voxel"] or opt.map["voxel"]
    settings["directions"] = opt.map["full_directions"] or opt.map["directions"]
    m = measure_design(design.to_dict(), settings, repeats=max(2, opt.map["repeats"]))
    keep = ("reachable_volume_L", "dexterous_volume_L", "mean_index", "reachable_volume_L_sd")
    keep += ("dexterous_volume_L_sd", "uncertainty_repeats")
    return {"voxel": settings["voxel"], "directions": settings["directions"]} | {
        k: m[k] for k in keep if k in m
    }


def build_front(opt: OptFile, out: Path, progress: bool = False) -> list[Path]:
    """Fully build (``handarm build``) every front design into ``out/front/trial-NNNN/``."""
    from handarm.pipeline import build

    data = json.loads((out / "front.json").read_text())
    paths = []
    for d in data["designs"]:
        design = ArmDesign.from_toml(out / d["toml"])
        folder = out / d["toml"].removesuffix(".toml")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            build(design, folder, progress=progress)
        paths.append(folder)
    return paths
