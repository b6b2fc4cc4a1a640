"""Navigation systems, each behind one seam (``base.NavSystem``, listed in ``registry.SYSTEMS``):
GPS, Decca, manual bearings/distances; and the bounded sensors' conversions. See docs/SYSTEMS.md."""
