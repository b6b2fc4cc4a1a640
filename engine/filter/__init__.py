"""The navigation filter (thesis ch. 6): the 11-state extended Kalman filter with its
models, measurement updates and innovation tests, the RTS smoother, and the Pool of Errors."""
