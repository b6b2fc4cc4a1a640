"""Navigation systems that give observations for the fix (GPS, Decca, manual bearings and
ranges) and the bounded sensors (log, gyro, inclinometer, pressure depth; thesis §3.1, §7.2)."""
