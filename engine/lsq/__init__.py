"""The least-squares fix (thesis ch. 5): the adjustment core, Baarda quality control
(overall model test, w-test data snooping, reliability, unit variance), the robust option,
confidence regions, and the fix of one cycle from the systems' observations."""
