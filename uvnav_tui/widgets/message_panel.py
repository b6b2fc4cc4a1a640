"""The message log as a scrollable view: the Pg 100 panel on tall terminals, and the body of
the message-log screen (:mod:`uvnav_tui.screens.message_screen`).

Lines are ``HH:MM:SSZ text`` (record time of the cycle), oldest first, literal text. The panel
and the log screen show them grouped (``grouped=True``): ``HH:MM:SSZ WARN  text  ×37 in 10 min``
per group of messages of one kind (:class:`~uvnav_tui.widgets.message_log.MessageGroup`),
alarms in reverse video and warnings in bold, each followed by what to do (``⤷ …``), the run
starts and ends as ``──── Run started … ────``. The view follows the newest line unless the
operator has scrolled up.
"""

from __future__ import annotations

import textwrap
from typing import Self

from rich.text import Text
from textual.containers import Vertical
from textual.events import Resize
from textual.geometry import Region
from textual.widgets import RichLog

from uvnav_tui.widgets.message_log import ALARM, LOG_LIMIT, WARNING, MessageGroup, MessageLog

PANEL_MIN_ROWS = 5
"""The panel shows only when at least this many rows are free under Pg 100."""
PANEL_GROUPS = 100
"""The panel (not scrollable) draws at most the last this many groups."""
ADVICE_INDENT = " " * 10
"""What to do is indented under the group's text (past ``HH:MM:SSZ``)."""


HANGING_INDENT = " " * 16
"""A group's wrapped text continues under its text (past ``HH:MM:SSZ WARN  ``)."""


def group_texts(group: MessageGroup, advice: bool, wall_time: bool = False,
                width: int = 0) -> list[Text]:
    """The lines of a group: its line, styled by level, and (``advice``) what to do;
    ``wall_time``: a run mark with its wall-clock time; ``width`` > 0: wrapped to it with
    hanging indents (literal text: wrapped as words, never read as markup)."""
    style = "reverse" if group.level == ALARM else "bold" if group.level == WARNING else ""
    if group.is_mark:
        style = "bold"
    line = group.line(wall_time)
    lines = (textwrap.wrap(line, width, subsequent_indent=HANGING_INDENT, break_on_hyphens=False)
             if width > len(HANGING_INDENT) + 10 and not group.is_mark else [line])
    out = [Text("\n".join(lines or [line]), style=style)]
    if advice and group.advice:
        first = f"{ADVICE_INDENT}⤷ "
        more = " " * len(first)
        tip = (textwrap.wrap(first + group.advice, width, subsequent_indent=more,
                             break_on_hyphens=False)
               if width > len(first) + 10 else [first + group.advice])
        out.append(Text("\n".join(tip)))
    return out


class MessageLogView(RichLog):
    """Appends the log's new entries on :meth:`sync`; long lines wrap (literal text)."""

    def __init__(self, *, id: str | None = None, classes: str | None = None,
                 grouped: bool = False, max_groups: int | None = None,
                 advice_levels: tuple[str, ...] = ("alarm", "warning", "info"),
                 mark_times: bool = False) -> None:
        super().__init__(id=id, classes=classes, max_lines=LOG_LIMIT, auto_scroll=True,
                         wrap=True, markup=False, highlight=False, min_width=20)
        self.grouped = grouped
        """Groups of messages (the panel, the log screen), else one line per entry."""
        self.max_groups = max_groups
        """At most this many groups drawn (the newest; None: all kept)."""
        self.advice_levels = advice_levels
        """The levels whose groups show what to do."""
        self.mark_times = mark_times
        """Run marks with their wall-clock time (the log screen)."""
        self.levels: frozenset[str] | None = None
        """Only groups of these levels are shown (run marks always); None: all."""
        self._serial = 0
        self._next_group = 0
        self._render_width: int | None = None
        """The width grouped lines are rendered at (they are wrapped here: RichLog measures
        a line against the console's width, 80 columns in a headless run), None: RichLog's."""
        self._next = 0
        self._log: MessageLog | None = None
        self._wrap_width = 0
        """The width the lines written so far were wrapped at (0: hidden, or not yet laid
        out: RichLog then wraps at ``min_width``)."""
        self._batch: list[bool] | None = None
        """While :meth:`sync` writes: the ``layout`` flags of the refreshes asked for."""

    def sync(self, log: MessageLog) -> None:
        """Write the entries added since the last call (each one as its own ``write``, so the
        lines are those of one write per entry; the refreshes they ask for and the scroll to
        the end are done once: at pace fast a sync may bring many entries)."""
        self._log = log
        if self.grouped:
            texts = self._group_texts(log)
            if texts is None:
                return
        else:
            if log.total == self._next:
                return
            start, entries = log.since(self._next)
            texts = [Text(e.line()) for e in entries]
            if start > self._next:
                texts.insert(0, Text(f"({start - self._next} older messages no longer kept)"))
            self._next = start + len(entries)
        if self._size_known:
            self._wrap_width = self.scrollable_content_region.width
        if not self._size_known or len(texts) == 1:
            for text in texts:  # the first writes wait for the size (RichLog defers them)
                self.write(text, width=self._render_width)
            return
        self._batch = []
        try:
            for text in texts:
                self.write(text, scroll_end=False, width=self._render_width)
        finally:
            layout = any(self._batch)
            self._batch = None
        if layout and self.size:
            # The layout asked for is for the new virtual height (RichLog.write sets it); the
            # panel itself keeps its size, so unless a scrollbar appears or goes, updating the
            # scrollbars (what the layout would do for a ScrollView) is all it takes: a layout
            # redraws the whole screen (at pace fast, issue 14).
            shown = (self.show_vertical_scrollbar, self.show_horizontal_scrollbar)
            self._scroll_update(self.virtual_size)
            layout = (self.show_vertical_scrollbar, self.show_horizontal_scrollbar) != shown
        super().refresh(layout=layout)
        # at once, not after the next frame: the panel keeps its size, so the end is known
        # now, and the new lines and the scroll are drawn in one frame instead of two
        self.scroll_end(animate=False, immediate=True, x_axis=False)

    def _group_texts(self, log: MessageLog) -> list[Text] | None:
        """The lines to add for the groups changed since the last sync (None: nothing); when
        a group already drawn grew, the view is cleared and every group drawn again."""
        serial, changed = log.groups_since(self._serial)
        if serial == self._serial:
            return None
        self._serial = serial
        if any(g.number < self._next_group for g in changed):
            self.clear()
            changed = log.recent_groups(self.max_groups or log.groups_kept)
        elif self.max_groups is not None:
            changed = changed[-self.max_groups:]
        if not changed:
            return None
        self._next_group = changed[-1].number + 1
        # one column spare: a scroll bar may appear under lines already written
        width = self.scrollable_content_region.width - 1 if self._size_known else 0
        self._render_width = width if width > 0 else None
        texts: list[Text] = []
        for g in changed:
            if self.levels is not None and not g.is_mark and g.level not in self.levels:
                continue
            texts += group_texts(g, g.level in self.advice_levels, self.mark_times, width)
        return texts

    def on_resize(self, event: Resize) -> None:
        """RichLog wraps a line once, when it is written: after a change of width (the panel
        shown on a terminal grown from 80×24, where it was hidden and its lines wrapped at 20
        columns) every line is written again at the new width. Grouped lines, wrapped here
        with hanging indents, are also written again once the first size is known, after the
        layout (the content width is known only then)."""
        first = not self._size_known
        super().on_resize(event)
        width = self.scrollable_content_region.width
        if self.grouped and self._log is not None and (self._serial or not first):
            self.call_after_refresh(self._rewrap)
        elif first:
            self._wrap_width = width
        elif width and width != self._wrap_width and self._log is not None:
            self.clear()
            self._next = self._serial = self._next_group = 0
            self.sync(self._log)

    def show_levels(self, levels: frozenset[str] | None) -> None:
        """Show only groups of ``levels`` (None: all) from now on: every line written again."""
        if levels == self.levels:
            return
        self.levels = levels
        if self._log is not None:
            self.clear()
            self._next = self._serial = self._next_group = 0
            self.sync(self._log)

    def _rewrap(self) -> None:
        """Write every line again at the width laid out now (grouped view)."""
        width = self.scrollable_content_region.width
        if self._log is None or not width or width == self._wrap_width:
            return
        self.clear()
        self._next = self._serial = self._next_group = 0
        self.sync(self._log)

    def refresh(self, *regions: Region, repaint: bool = True, layout: bool = False,
                recompose: bool = False) -> Self:
        """As the widget's refresh; while :meth:`sync` writes, kept for the end of it."""
        if self._batch is not None and not regions and repaint and not recompose:
            self._batch.append(layout)
            return self
        return super().refresh(*regions, repaint=repaint, layout=layout, recompose=recompose)


class MessagePanel(MessageLogView):
    """The log under Pg 100 (shown by :class:`PanelArea` when the terminal has the rows).

    Not focusable: the page keys (PgUp/PgDn, Return, Space) stay with the page; F2 opens the
    log screen for scrolling."""

    can_focus = False

    def __init__(self, *, id: str | None = None, classes: str | None = None) -> None:
        super().__init__(id=id, classes=classes, grouped=True, max_groups=PANEL_GROUPS,
                         advice_levels=(ALARM, WARNING))

    def on_mount(self) -> None:
        """Titled frame."""
        self.border_title = "Messages (F2: all)"


class PanelArea(Vertical):
    """A page with a :class:`MessagePanel` under it; the panel shows only when at least
    :data:`PANEL_MIN_ROWS` rows are left under the page."""

    def on_resize(self) -> None:
        """Re-fit after the terminal size changed."""
        self.fit()

    def fit(self) -> None:
        """Show or hide the panel for the rows the other children leave."""
        panels = list(self.query_children(MessagePanel))
        if not panels:
            return
        used = sum(w.outer_size.height for w in self.children
                   if not isinstance(w, MessagePanel) and w.display)
        show = self.size.height - used >= PANEL_MIN_ROWS
        for panel in panels:
            panel.display = show
