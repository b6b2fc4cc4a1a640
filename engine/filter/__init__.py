"""Navigation filter (thesis ch. 6), bottom to top: ``params`` ← ``state`` (named indices, the
only code that edits the state vector) ← ``model`` (Φ, Γ, Q) ← ``predict``; ``measurements``
(H, R) ← ``update`` (update step, LOM/LS tests); ``kalman`` re-exports them all; ``smoother``
(RTS) and ``poe`` (pool of errors) use them."""
