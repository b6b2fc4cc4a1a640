"""Least-squares fix (thesis ch. 5), bottom to top: ``statistics`` (critical values, w-test,
reliability, unit variance, χ² bounds; numpy/SciPy only) ← ``adjustment`` (generic Gauss–Newton
core) ← ``robust`` (IRLS M-estimation) ← ``snooping`` (reject-and-recompute driver);
``confidence`` (error ellipses); ``fix`` (the observation slots of GPS, Decca and manual LOPs)."""
