"""Geodesy: ``angles`` (wrapping), ``ellipsoid`` (ellipsoids and datums), ``ellipsoidal`` (ECEF,
datum shifts, geodesics, line scale), ``tmgrid`` (transverse Mercator grid).
The lowest layer: imports nothing else of the engine."""
