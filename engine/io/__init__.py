"""Files and text in and out: the ``.RUN`` run file and NMEA 0183 logs as run input, the data
files ``TO_WGS84.DAT`` and ``DECCA.CHN``, the ``.OUT`` log and its output-file rules, TOML
sources, operator text fields and the thesis' screen number formats. Depends only on
:mod:`engine.geodesy` (ellipsoid values) and :mod:`engine.errors`."""
