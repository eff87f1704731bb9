"""Modal dialogs: a plan's question with its choices as keys, a device fault, yes/no confirmation, help."""

from __future__ import annotations

import ast
import time
from collections.abc import Callable
from typing import TYPE_CHECKING

from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import Vertical
from textual.markup import escape
from textual.screen import ModalScreen, Screen
from textual.widgets import Static

if TYPE_CHECKING:
    from acquisition.messages import Prompt

TITLES = {
    "fault": "Device fault", "invalid": "Invalid reading", "jump": "Jump between stations",
    "warmup": "Warm-up not stable", "resume": "Resume the run", "pause": "Run paused",
    "inposition": "No in-position signal", "mismatch": "Unexpected target", "stability": "Axis not stable",
}


# Keys a question must not use for a choice: the run screen under the pause dialog means redo by r and
# skip by s, so "resume" there is p (the key that paused) rather than its first letter.
PREFERRED_KEYS = {"pause": {"resume": "p"}}
RESERVED_KEYS = {"pause": ("r", "s")}


def choice_keys(choices: tuple[str, ...], preferred: dict[str, str] | None = None,
                reserved: tuple[str, ...] = ()) -> list[str]:
    """One key per choice: ``preferred[choice]`` if given, else its first letter not taken by an earlier
    choice nor ``reserved``, else the next free digit."""
    preferred = preferred or {}
    taken: list[str] = []
    for c in choices:
        blocked = [*taken, *reserved, *(v for k, v in preferred.items() if k != c)]
        key = preferred.get(c) or next((ch for ch in c.lower() if ch.isalpha() and ch not in blocked),
                                       str(len(taken) + 1))
        taken.append(key)
    return taken


class QuestionScreen(ModalScreen[str]):
    """A plan's :class:`~acquisition.messages.Prompt`; dismisses with the choice."""

    def __init__(self, prompt: Prompt) -> None:
        super().__init__()
        self.prompt = prompt
        self.keys = choice_keys(prompt.choices, PREFERRED_KEYS.get(prompt.key), RESERVED_KEYS.get(prompt.key, ()))

    def compose(self) -> ComposeResult:
        p = self.prompt
        title = TITLES.get(p.key, "Question")
        with Vertical(id="dialog", classes="fault" if p.fault and p.key == "fault" else ""):
            yield Static(title, id="dialog-title")
            # ("Device fault: ..." under the title "Device fault")
            yield Static(escape(p.text.removeprefix(f"{title}: ")), id="dialog-text")
            default = p.default or p.choices[0]
            keys = "   ".join(f"[b]{k}[/b] {escape(c)}" + (" (Enter)" if c == default else "")
                             for k, c in zip(self.keys, p.choices, strict=True))
            yield Static(keys, id="dialog-keys")

    def on_key(self, event) -> None:  # noqa: ANN001 - textual.events.Key
        # (Textual calls on_key of every class in the MRO: subclasses override answer_key instead)
        self.answer_key(event)

    def answer_key(self, event) -> None:  # noqa: ANN001 - textual.events.Key
        key = event.key
        if key == "enter":
            event.stop()
            self.dismiss(self.prompt.default or self.prompt.choices[0])
        elif key in self.keys:
            event.stop()
            self.dismiss(self.prompt.choices[self.keys.index(key)])


def duration_text(seconds: float) -> str:
    """``45 s``, ``3 min 05 s``, ``1 h 02 min``."""
    s = max(0, int(seconds))
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60:02d} s"
    return f"{s // 3600} h {s % 3600 // 60:02d} min"


class FaultScreen(QuestionScreen):
    """A device fault: what happened and what to check in plain words, the attempt count and how long
    the device has been failing (updated every second), retry / abort; ``d`` shows the driver's own line.

    ``attempt``: the fault questions in a row for this step (1 = the first failure); ``since``: the
    ``clock()`` time of the first."""

    def __init__(self, prompt: Prompt, attempt: int = 1, since: float | None = None,
                 clock: Callable[[], float] = time.monotonic) -> None:
        super().__init__(prompt)
        self.attempt = attempt
        self.clock = clock
        self.since = clock() if since is None else since
        from acquisition.fault_words import explain  # (not before the first frame: benchmarks/bench_tui_first_frame.py)

        self.words = explain(prompt.fault or prompt.text)
        self.show_detail = False

    def compose(self) -> ComposeResult:
        choices = "   ".join(f"[b]{k}[/b] {escape(c)}" + (" (Enter)" if c == (self.prompt.default or
                                                                       self.prompt.choices[0]) else "")
                             for k, c in zip(self.keys, self.prompt.choices, strict=True))
        with Vertical(id="dialog", classes="fault"):
            yield Static(self.title_text(), id="dialog-title")
            yield Static(f"[b]{escape(self.words.what)}[/b]\n{escape(self.words.check)}", id="dialog-text")
            detail = Static(f"[dim]technical detail:[/dim] {escape(self.words.detail)}", id="fault-detail")
            detail.display = False
            yield detail
            yield Static(f"{choices}   [b]d[/b] technical details", id="dialog-keys")

    def on_mount(self) -> None:
        self.refresh_text()
        self.set_interval(1.0, self.refresh_text)

    def title_text(self) -> str:
        return f"Device fault · attempt {self.attempt} · failing for {duration_text(self.clock() - self.since)}"

    def refresh_text(self) -> None:
        self.query_one("#dialog-title", Static).update(self.title_text())
        self.query_one("#fault-detail", Static).display = self.show_detail

    def answer_key(self, event) -> None:  # noqa: ANN001 - textual.events.Key
        if event.key == "d" and "d" not in self.keys:
            event.stop()
            self.show_detail = not self.show_detail
            self.refresh_text()
            return
        super().answer_key(event)


def question_screen(prompt: Prompt, attempt: int = 1, since: float | None = None) -> QuestionScreen:
    """The dialog of one question: a device fault gets :class:`FaultScreen`."""
    if prompt.key == "fault":
        return FaultScreen(prompt, attempt, since)
    return QuestionScreen(prompt)


class ConfirmScreen(ModalScreen[bool]):
    """A yes/no question: y / n (Escape = no)."""

    BINDINGS = [Binding("y", "answer(True)", "yes"), Binding("n", "answer(False)", "no"),
                Binding("escape", "answer(False)", "no", show=False)]

    def __init__(self, title: str, text: str) -> None:
        super().__init__()
        self.title_text, self.text = title, text

    def compose(self) -> ComposeResult:
        with Vertical(id="dialog"):
            yield Static(escape(self.title_text), id="dialog-title")
            yield Static(escape(self.text), id="dialog-text")
            yield Static("[b]y[/b] yes   [b]n[/b] no", id="dialog-keys")

    def action_answer(self, yes: bool) -> None:
        self.dismiss(yes)


HELP_ACTIONS = ("help", "help_here")  # the actions that open this help (the application's, the set-up form's)


class HelpScreen(ModalScreen[None]):
    """The keys of the screen it was opened from (and the application's); any key closes it."""

    def __init__(self, screen: Screen, app_bindings: list[Binding]) -> None:
        super().__init__()
        self.source = screen
        self.app_bindings = app_bindings

    def compose(self) -> ComposeResult:
        rows = []
        seen = set()
        # over a dialog only the application's priority keys reach past it (F1), not q
        app_bindings = [b for b in self.app_bindings if b.priority or not isinstance(self.source, ModalScreen)]
        for b in [*getattr(self.source, "BINDINGS", []), *app_bindings]:
            if not isinstance(b, Binding) or not b.description or b.description in seen or not self.live(b):
                continue
            seen.add(b.description)
            # the help's own key as both keys that open it (the footer has room for "?" only)
            key = b.key_display or b.key
            if b.action.removeprefix("app.") in HELP_ACTIONS:  # over a dialog only F1 reaches the application
                key = "F1" if isinstance(self.source, ModalScreen) else "?/F1"
            rows.append(f"  [b]{escape(key):<12}[/b] {b.description}")
        name = getattr(self.source, "SCREEN_NAME", type(self.source).__name__)
        with Vertical(id="dialog"):
            yield Static(f"Keys: {name}", id="dialog-title")
            yield Static("\n".join(rows), id="dialog-text")
            yield Static("?/F1: this help on every screen · any key closes it", id="dialog-keys")

    def live(self, binding: Binding) -> bool:
        """Whether the key does something on the source screen now (its ``check_action``): help lists only those."""
        if binding.action.startswith("app."):
            return True
        name, _, args = binding.action.partition("(")
        try:
            params = tuple(ast.literal_eval(f"({args[:-1]},)")) if args else ()
        except (ValueError, SyntaxError):
            params = ()
        return bool(self.source.check_action(name, params))

    def on_key(self, event) -> None:  # noqa: ANN001
        event.stop()
        self.dismiss(None)
