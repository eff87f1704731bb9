"""The screens' header: Textual's, made safe against a title update that arrives while its screen goes away."""

from __future__ import annotations

import contextlib

from textual.css.query import NoMatches
from textual.dom import NoScreen
from textual.events import Mount
from textual.widgets import Header
from textual.widgets._header import HeaderTitle


class RunHeader(Header):
    """``textual.widgets.Header`` whose title watcher tolerates a header whose children are already gone.

    Textual's own watcher (8.2.8) runs once after the header is mounted; when the app exits or switches screens
    in that instant (a run that ends as its results open) it finds no ``HeaderTitle`` and the app crashes with
    ``NoMatches``.  The title is simply not updated then: nobody sees that header any more.
    """

    def _on_mount(self, event: Mount) -> None:
        event.prevent_default()  # instead of Header._on_mount, not as well

        async def set_title() -> None:
            with contextlib.suppress(NoMatches, NoScreen):
                self.query_one(HeaderTitle).update(self.format_title())

        self.watch(self.app, "title", set_title)
        self.watch(self.app, "sub_title", set_title)
        self.watch(self.screen, "title", set_title)
        self.watch(self.screen, "sub_title", set_title)
