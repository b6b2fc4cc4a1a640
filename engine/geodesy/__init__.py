"""Geodesy: reference ellipsoids and datums, geodetic↔ECEF, the Bursa–Wolf datum shift,
geodesics and spheroidal distances (thesis A5, A8.4), and the Transverse Mercator calculating grid
of the engine (k0 = 1, no false origin). The lowest layer: imports nothing else of the engine."""
