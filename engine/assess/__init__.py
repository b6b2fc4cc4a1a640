"""Accuracy of a replayed run against the simulator's truth (``uvnav assess``)."""
