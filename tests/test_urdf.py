import numpy as np
import yourdfpy

import handarm
from handarm.cad_out import write_urdf


def test_urdf_reproduces_forward_kinematics(tmp_path, design, rng):
    d = design.replace(link_lengths=rng.uniform(0.02, 0.08, 7))
    path = write_urdf(d, tmp_path / "arm.urdf")
    robot = yourdfpy.URDF.load(str(path))
    assert robot.validate()
    names = [f"joint{k}" for k in range(1, 7)]
    assert robot.actuated_joint_names == names
    q = rng.uniform(d.lower, d.upper, (1000, 6))
    t_ref = handarm.forward_matrix(d, q)
    for i in range(len(q)):
        robot.update_cfg(dict(zip(names, q[i], strict=True)))
        t = robot.get_transform("tool", "base_link")
        np.testing.assert_allclose(t, t_ref[i], atol=1e-12, rtol=0)


def test_urdf_limits(tmp_path, design):
    robot = yourdfpy.URDF.load(str(write_urdf(design, tmp_path / "arm.urdf")))
    for k in range(6):
        lim = robot.joint_map[f"joint{k + 1}"].limit
        assert lim.lower == design.joint_limits[k][0]
        assert lim.upper == design.joint_limits[k][1]
        assert lim.effort > 0 and lim.velocity > 0
