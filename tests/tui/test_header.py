"""The run and results screens' header survives a title update that arrives as its screen goes away (a run
ending as its results open, the app exiting then): Textual's own header crashed the app with NoMatches."""

from __future__ import annotations

import asyncio

import pytest
from textual.app import App, ComposeResult
from textual.widgets import Header
from textual.widgets._header import HeaderTitle

from tui.widgets.header import RunHeader


def title_after_its_children_went(header_class: type[Header]) -> None:
    class One(App[None]):
        def compose(self) -> ComposeResult:
            yield header_class()

    async def main() -> None:
        app = One()
        async with app.run_test() as pilot:
            await app.query_one(HeaderTitle).remove()  # what a screen going away does to it
            app.title = "changed"  # the watcher runs for the header whose title is gone
            await pilot.pause()

    asyncio.run(main())


def test_run_header_takes_a_title_change_without_its_title() -> None:
    title_after_its_children_went(RunHeader)


def test_textuals_header_did_not() -> None:  # the reason for RunHeader: if this stops failing, it can go
    with pytest.raises(Exception, match="HeaderTitle"):
        title_after_its_children_went(Header)
