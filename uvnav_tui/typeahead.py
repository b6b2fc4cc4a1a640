"""Keys typed ahead are handled one at a time, in order, each by the widget that has the focus
once the keys before it have been handled (docs/CONSOLE.md, "Typing ahead").

Textual hands a key to the focused widget as soon as the app reads it: the widget handles it
later, in its own queue.  A key that moves the focus (Tab, bubbling up from the field to the
screen's binding) or opens a dialog (a menu hot-key) took effect only after the keys typed
behind it had already been handed to the old field or to a dialog whose fields did not exist
yet: ``Alt+O r ABC Tab 52 35 30 N …`` typed at speed put everything into the station name.

:class:`TypeAhead` holds every key read while the one before is still being handled, and
hands it on only when that one has *settled*: the key (and everything it bubbled up to) has
been handled, a screen it opened is mounted with its focus set, and the focus has stopped
moving.  The wait is bounded (:data:`SETTLE_S`), so a key is never held for long, whatever
goes wrong.  A single key arriving on a settled console is handled at once, as before.  Pasted
text (a terminal's bracketed paste) takes its turn in the same queue.
"""

from __future__ import annotations

import asyncio
import time
from collections import deque
from typing import TYPE_CHECKING

from textual import events
from textual.css.query import NoMatches
from textual.errors import NoWidget
from textual.message import Message

if TYPE_CHECKING:
    from textual.app import App
    from textual.message_pump import MessagePump

SETTLE_S = 1.0
"""Longest time a key is held for the one before it to settle [s]; at that point it is handed
on anyway (a screen that never mounts must not swallow the keyboard).  Settling takes a few
milliseconds of the UI thread; a refresh of the console at pace fast can add 30–50 ms."""
POLL_S = 0.02
"""How often the wait for a key's round trip checks that its widget still exists [s]."""
MAX_ROUNDS = 8
"""Most rounds of "let every widget of the screen on top handle what is queued": a key that
opens a dialog takes three (the dialog composed and mounted, its focus set, nothing moved)."""


class KeyHandled(Message):
    """Posted to the widget a key was handed to, right behind the key: it bubbles up the same
    way, so when it reaches the app, the key (and whatever it bubbled up to the screen's and
    the app's bindings) has been handled."""

    def __init__(self, done: asyncio.Event) -> None:
        super().__init__()
        self.done = done


class TypeAhead:
    """The key queue of one app (``app``); the app calls :meth:`key` for every key it reads
    and :meth:`handled` for every :class:`KeyHandled` that reaches it."""

    def __init__(self, app: App[object]) -> None:
        self.app = app
        self.held: deque[events.Key | events.Paste] = deque()
        """Keys read while the one before them had not settled, oldest first."""
        self.busy = False
        """True from a key handed on until it has settled."""
        self._task: asyncio.Task[None] | None = None

    async def key(self, event: events.Key | events.Paste) -> None:
        """A key (or pasted text) read from the terminal: handled now if the console is
        settled, else held."""
        if self.busy:
            self.held.append(event)
            return
        await self._deliver(event)

    def handled(self, message: KeyHandled) -> None:
        """A :class:`KeyHandled` reached the app: its key has been handled."""
        message.stop()
        message.done.set()

    async def _deliver(self, event: events.Key | events.Paste) -> None:
        """Hand ``event`` on as Textual does (``App.on_event``, 8.2: a key to the priority
        bindings from the app down, else to the focused widget or the screen; pasted text to
        the focused widget or the screen), then wait for it to settle."""
        self.busy = True
        app = self.app
        target: MessagePump | None = None
        done: asyncio.Event | None = None
        try:
            screen = app.screen
            if isinstance(event, events.Paste):
                (app.focused or screen)._forward_event(event)  # noqa: SLF001
                return
            app.app_focus = True
            if (screen.maximized is not None and event.key == "escape"
                    and app.escape_to_minimize):
                screen.minimize()
            elif not await app._check_bindings(event.key, priority=True):  # noqa: SLF001
                target = app.focused or screen
                target._forward_event(event)  # noqa: SLF001
                done = asyncio.Event()
                target.post_message(KeyHandled(done))
        finally:
            self._task = asyncio.create_task(self._settle(target, done))

    async def _settle(self, target: MessagePump | None, done: asyncio.Event | None) -> None:
        """Wait for the key handed to ``target`` to settle, then hand on the next one."""
        deadline = time.monotonic() + SETTLE_S
        try:
            if target is not None and done is not None:
                await self._round_trip(target, done, deadline)
            await self._quiet(deadline)
        except Exception:  # noqa: BLE001 - a failed wait must never stop the keyboard
            pass
        finally:
            self._next()

    async def _round_trip(self, target: MessagePump, done: asyncio.Event,
                          deadline: float) -> None:
        """Wait for the key's :class:`KeyHandled` to reach the app (or the target to go)."""
        while not done.is_set():
            left = deadline - time.monotonic()
            if left <= 0 or target._closing or target._closed:  # noqa: SLF001
                return
            try:
                await asyncio.wait_for(done.wait(), min(POLL_S, left))
            except TimeoutError:
                pass

    async def _quiet(self, deadline: float) -> None:
        """Let every widget of the screen on top handle what it has queued, until the screen on
        top is mounted and neither it nor the focus changed over a whole round."""
        app = self.app
        for _ in range(MAX_ROUNDS):
            try:
                screen = app.screen
            except (NoWidget, NoMatches, IndexError):
                return
            focused, mounted = app.focused, screen.is_mounted
            await self._flush([app, *screen.walk_children(with_self=True)], deadline)
            if time.monotonic() >= deadline:
                return
            try:
                same = app.screen is screen
            except (NoWidget, NoMatches, IndexError):
                return
            if same and mounted and app.focused is focused:
                return

    @staticmethod
    async def _flush(nodes: list[MessagePump], deadline: float) -> None:
        """Wait until each of ``nodes`` has handled the messages it had queued (a callback
        queued behind them on each, as Textual's pilot does), or the deadline."""
        left = 0
        all_done = asyncio.Event()

        def one_done() -> None:
            nonlocal left
            left -= 1
            if left == 0:
                all_done.set()

        for node in nodes:
            if node.call_later(one_done):
                left += 1
        if left:
            try:
                await asyncio.wait_for(all_done.wait(), max(deadline - time.monotonic(), 0.0))
            except TimeoutError:
                pass

    def _next(self) -> None:
        """Hand on the oldest held key (in the app's own task), or stop being busy."""
        if self.held and self.app.call_later(self._deliver, self.held.popleft()):
            return
        self.held.clear()
        self.busy = False
