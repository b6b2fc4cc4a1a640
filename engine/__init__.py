"""UVNAV engine: geodesy, least-squares fixing, navigation filter and the processing cycle.

A library first: pure functions and small dataclasses, no global state, no printing, and never
an import of the user interface (enforced by ``tests/test_architecture.py``).
"""

__version__ = "0.1.0"
