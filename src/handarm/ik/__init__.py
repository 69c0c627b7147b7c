"""Analytical 5-DoF inverse kinematics (paper section III): every solution range, exact.

``solve`` answers one target with every solution range (or the closest reachable pose);
``solve_batch`` answers N targets in parallel; ``count_solutions`` counts without storing;
``configuration_at`` gives the joint angles at any point of a range; ``warm_up`` compiles
every kernel a control loop calls before the loop starts.

Layers point one way: the numba kernels (``_solve`` and below), the exact core
(``exact``), graceful degradation on top of it (``degrade``), the public ``solve``
(``api``) on top of both.
"""

from handarm.ik.api import solve
from handarm.ik.exact import (
    branch_of,
    configuration_at,
    configurations_along,
    count_solutions,
    solve_batch,
    solve_batch_iter,
    solve_exact,
)
from handarm.ik.obstacles import solve_in_scene
from handarm.ik.results import (
    MAX_SOLUTIONS,
    BatchResult,
    IKResult,
    format_result,
    nearest_solution,
)
from handarm.ik.warm import warm_up

__all__ = [
    "MAX_SOLUTIONS",
    "BatchResult",
    "IKResult",
    "branch_of",
    "configuration_at",
    "configurations_along",
    "count_solutions",
    "format_result",
    "nearest_solution",
    "solve",
    "solve_batch",
    "solve_batch_iter",
    "solve_exact",
    "solve_in_scene",
    "warm_up",
]
