"""``.RUN`` lines shared by the hot-path tests (tests/io/test_runfile_fast.py, the Python twin;
tests/native/test_runparse.py, the compiled kernel)."""

from __future__ import annotations

from hypothesis import strategies as st

DIVE = "920917 105009 - - - - - 250.9 6.1 .0 .22 39651.487 19.76\n"
"""A record without GPS (a dive): since 2026-12-04 it takes the hot path too."""
DIVE_LINES = [
    DIVE, DIVE.replace(" - - - - -", " - - .5 .25 .125"),
    DIVE.replace(" - - -", " - 004 29 55.439 W -", 1), DIVE.replace(" 19.76", ""),
    DIVE.replace(" 19.76", " 19.76 1"), DIVE.replace(" .22 39651.487 19.76", ""),
    DIVE.replace(" - - -", " -- - -", 1), DIVE.replace(" - -", " -", 1),
    "920917 105009 - - - - - - - -\n", "920917 105009 - - - - - - - - - - -\n",
    "920917 105009 - - - - - - - - - - - -\n", "920917 105009 -\n",
    DIVE.replace("105009", "105060"), DIVE.replace(" ", "\t"),
    DIVE.replace("250.9", "360"), DIVE.replace("\n", " hdop=1.2\n"),
    DIVE.replace(" - - -", " 52 49 56.313 S - -", 1),  # latitude only
]

_DIVE_TOKS = DIVE.split()
_DIVE_EDITS = ["-", "0", ".5", "-.5", "59.999", "60", "1.", "", "N", "S", "E", "W", "x", "1e3",
               "nan", "0.9999", "90", "180.000", "52 49 1.5 N", "004 29 55.439 E", "- -", "1 2"]


@st.composite
def perturbed_dive_lines(draw: st.DrawFn) -> str:
    """:data:`DIVE` with one to four of its tokens replaced (an empty one dropped; some
    replacements are several tokens, e.g. a whole coordinate)."""
    edits = draw(st.lists(st.tuples(st.integers(0, len(_DIVE_TOKS) - 1),
                                    st.sampled_from(_DIVE_EDITS)), min_size=1, max_size=4))
    toks = list(_DIVE_TOKS)
    for k, tok in edits:
        toks[k] = tok
    return " ".join(t for t in toks if t) + "\n"
