"""engine.geodesy.ellipsoidal."""
