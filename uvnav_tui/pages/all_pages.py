"""Imports every numbered page module but Pg 100, so that each registers its body with
:mod:`uvnav_tui.pages.pages` (program.md §4.1, A5): Statistics 6xx, Demo 710 and Data 8xx.

The console imports this module once; tests that build page bodies import it too.
"""

from __future__ import annotations

from uvnav_tui.pages import (  # each import registers its page
    page_611,
    page_615,
    page_620,
    page_631,
    page_633,
    page_641,
    page_642,
    page_643,
    page_650,
    page_710,
    page_810,
    page_821,
    page_830,
    page_840,
    page_850,
    page_851,
    page_852,
    page_853,
)

PAGE_MODULES = (
    page_611, page_615, page_620, page_631, page_633, page_641, page_642, page_643, page_650,
    page_710, page_810, page_821, page_830, page_840, page_850, page_851, page_852, page_853,
)
"""The page modules, in page-number order."""

PAGE_NUMBERS: tuple[int, ...] = tuple(m.PAGE_NUMBER for m in PAGE_MODULES)
"""Every page number registered by importing this module."""
