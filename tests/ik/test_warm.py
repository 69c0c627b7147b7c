"""warm_up: after it, a control loop's solves meet no kernel that has not been compiled.

Run in a fresh interpreter (this process has compiled everything already): every numba
dispatcher in handarm's modules is listed with the signatures it holds after ``warm_up``,
then a loop's worth of targets is solved (tracking steps, noisy near-vertical directions,
targets pushed out of reach by random amounts, with and without a scene) and no dispatcher
may gain a signature. Without ``warm_up`` the same run gains many (checked too, so the
check can fail).
"""

import json
import subprocess
import sys

import numpy as np
import pytest

import handarm
from handarm import ik

_SCRIPT = r"""
import json, sys
import numba
import numpy as np
import handarm
from handarm import ik
from handarm.scene import Scene

def signatures():
    out = {}
    for name, mod in list(sys.modules.items()):
        if not name.startswith("handarm"):
            continue
        for attr, value in list(vars(mod).items()):
            if isinstance(value, numba.core.dispatcher.Dispatcher):
                out[f"{name}.{attr}"] = len(value.signatures)
    return out

d = handarm.ArmDesign.from_dict(json.loads(sys.argv[2]))
scene = Scene.empty().with_sphere([0.09, 0.03, 0.06], 0.015, name="ball")
# the loop's poses are drawn first: a batch validity test of 4,000 poses is the test's own
# set-up, not what a control loop asks
rng = np.random.default_rng(7)
q = rng.uniform(d.lower, d.upper, (4000, 6))
q = q[handarm.is_valid(d, q)][:25]
P, E = handarm.forward(d, q)
info = None
if sys.argv[1] == "warm":
    info = ik.warm_up(d, scene, 0.004)
before = signatures()
levels = set()
for i in range(len(q)):
    current = q[i]
    for step in range(4):  # a short tracking path, 2 mm steps
        p = P[i] + 0.002 * step * rng.standard_normal(3)
        e = E[i] + 1e-6 * rng.standard_normal(3)
        r = ik.solve(d, p, e, current)
        levels.add(int(r.reached_dof))
        if r.follow is not None:
            current = r.follow
    out = P[i] / np.linalg.norm(P[i])
    r = ik.solve(d, P[i] + rng.uniform(0.002, 0.15) * out, E[i], current)
    levels.add(int(r.reached_dof))
    ik.solve(d, P[i], [2e-4, -1e-4, -1.0], current)
    if i < 2:  # over the base and out of reach (level 2's closed-form family)
        ik.solve(d, [0.02 * (i + 1), 0.01, 0.3], E[i], current)
        # over the base axis, far out of reach: no closed form, level 2 slides its seeds
        ik.solve(d, [0.01 * i, -0.005, 0.46], E[i], current)
    if i < 4:
        ik.solve(d, P[i], E[i], current, scene=scene, clearance=0.004, degrade=False)
        ik.solve(d, P[i] + 0.03 * out, E[i], current, scene=scene, clearance=0.004)
after = signatures()
new = sorted(k for k in after if after[k] > before.get(k, 0))
print(json.dumps({"new": new, "levels": sorted(levels), "warm": info}))
"""


def _run(mode: str, design: handarm.ArmDesign) -> dict:
    done = subprocess.run(
        [sys.executable, "-c", _SCRIPT, mode, json.dumps(design.to_dict())],
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


@pytest.mark.slow
def test_after_warm_up_a_loop_compiles_nothing():
    d = handarm.ArmDesign()
    warm = _run("warm", d)
    assert warm["warm"]["levels"] == [2, 3, 4, 5]
    assert {2, 3, 4, 5} <= set(warm["levels"])  # the loop met every level
    assert warm["new"] == []
    cold = _run("cold", d)
    assert len(cold["new"]) >= 5  # without it, the same loop compiles (or loads) kernels


def test_warm_up_meets_every_level_on_other_designs():
    for lengths in ((0.045, 0.055, 0.05, 0.06, 0.045, 0.05, 0.055), (0.05,) * 7):
        d = handarm.ArmDesign(link_lengths=lengths)
        info = ik.warm_up(d)
        assert info["levels"] == [2, 3, 4, 5]
        assert info["targets"] >= 10


def test_warm_up_starts_from_the_configurations_given(monkeypatch):
    """A design whose valid set random draws miss warms up from the pose it is given."""
    from handarm.ik import warm

    d = handarm.ArmDesign()
    q = np.radians([[10, 20, 30, 40, 50, 60]])
    assert handarm.is_valid(d, q).all()
    monkeypatch.setattr(warm, "_DRAWS", 0)  # no random draw finds anything
    with pytest.raises(ValueError, match="^design: no valid configuration .* configurations"):
        ik.warm_up(d)
    info = ik.warm_up(d, configurations=q, batch=False)
    assert info["levels"] == [2, 3, 4, 5]


def test_warm_up_in_a_scene_is_bounded_and_reports_its_levels():
    from handarm.ik import warm
    from handarm.scene import Scene

    d = handarm.ArmDesign()
    table = Scene.empty().with_box([1.0, 1.0, 0.2], [0.0, 0.0, -0.12], name="table")
    free = ik.warm_up(d)
    info = ik.warm_up(d, table, 0.004)
    assert info["scene_levels"] and set(info["scene_levels"]) <= {2, 3, 4, 5}
    # two exact solves and at most _SCENE_SOLVES more
    assert info["targets"] <= free["targets"] + 2 + warm._SCENE_SOLVES
    assert free["scene_levels"] == []


def test_warm_up_refuses_what_is_not_a_design():
    with pytest.raises(TypeError, match="design"):
        ik.warm_up({"lengths": [0.05] * 7})
