"""Analytical 5-DoF inverse kinematics (paper section III): every solution range, exact."""
