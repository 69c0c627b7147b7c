"""Analytical 5-DoF inverse kinematics (paper section III): every solution range, exact.

``solve`` answers one target with every solution range; ``solve_batch`` answers N targets in
parallel; ``configuration_at`` gives the joint angles at any point of a range.
"""

from handarm.ik.solver import (
    MAX_SOLUTIONS,
    BatchResult,
    IKResult,
    branch_of,
    configuration_at,
    configurations_along,
    count_solutions,
    format_result,
    nearest_solution,
    solve,
    solve_batch,
    solve_batch_iter,
)

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
]
