"""Reachability maps, workspace scores and joint-limit trade studies on top of the batch IK."""
