"""Modal dialogs: a plan's question with its choices as keys, yes/no confirmation, help."""

from __future__ import annotations

import ast
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


def choice_keys(choices: tuple[str, ...]) -> list[str]:
    """One key per choice: its first letter not taken by an earlier choice, else the next free letter."""
    taken: list[str] = []
    for c in choices:
        key = next((ch for ch in c.lower() if ch.isalpha() and ch not in taken), str(len(taken) + 1))
        taken.append(key)
    return taken


class QuestionScreen(ModalScreen[str]):
    """A plan's :class:`~acquisition.messages.Prompt`; dismisses with the choice."""

    def __init__(self, prompt: Prompt) -> None:
        super().__init__()
        self.prompt = prompt
        self.keys = choice_keys(prompt.choices)

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
        key = event.key
        if key == "enter":
            event.stop()
            self.dismiss(self.prompt.default or self.prompt.choices[0])
        elif key in self.keys:
            event.stop()
            self.dismiss(self.prompt.choices[self.keys.index(key)])


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


class HelpScreen(ModalScreen[None]):
    """The keys of the screen it was opened from (and the application's); any key closes it."""

    def __init__(self, screen: Screen, app_bindings: list[Binding]) -> None:
        super().__init__()
        self.source = screen
        self.app_bindings = app_bindings

    def compose(self) -> ComposeResult:
        rows = []
        seen = set()
        for b in [*getattr(self.source, "BINDINGS", []), *self.app_bindings]:
            if not isinstance(b, Binding) or not b.description or b.description in seen or not self.live(b):
                continue
            seen.add(b.description)
            rows.append(f"  [b]{b.key_display or b.key:<12}[/b] {b.description}")
        name = getattr(self.source, "SCREEN_NAME", type(self.source).__name__)
        with Vertical(id="dialog"):
            yield Static(f"Keys: {name}", id="dialog-title")
            yield Static("\n".join(rows), id="dialog-text")
            yield Static("any key closes this help", id="dialog-keys")

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
