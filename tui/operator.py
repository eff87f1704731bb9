"""The TUI operator: answers the engine's instructions and questions from the UI.

The engine calls :meth:`TuiOperator.instruct` / :meth:`prompt` in its worker
thread; they post the question to the UI and block *that* thread until the UI
calls :meth:`answer` (never the UI thread).  Simulated physical actions
(``--simulate``): the block is placed when the instruction is shown
(``EARLY_ACTIONS``); Cycle Start when the operator presses Space at a manual
target (:meth:`TuiOperator.act`: the capture then follows when the light settles).
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable
from typing import Any

from acquisition.messages import Instruct, Log, Prompt

from .messages import LogLine, OperatorQuestion

# Simulated actions the simulated technician performs as soon as the instruction is shown, before the key:
# the block is slid to the station and the screen shows it arriving and coming to rest (the stability
# light, auto-capture), as at a real guideway where the technician moves it, then captures.  Cycle Start
# stays on the key (the machine must not start before the operator says so).
EARLY_ACTIONS = frozenset({"place_block"})


class TuiOperator:
    def __init__(self, post: Callable[[Any], Any]) -> None:
        self.post = post
        self.actions: dict[str, Callable[..., None]] = {}
        self._answers: queue.Queue[tuple[int, str]] = queue.Queue()
        self._ticket = 0
        self._closed = threading.Event()
        # the stability light when the UI answered the last instruction (messages.Stillness; None: no light)
        self.light: str | None = None
        self._acted = 0  # the instruction whose simulated action the UI already performed (act)

    def _ask(self, msg: Instruct | Prompt) -> str:
        if self._closed.is_set():
            return "abort"
        self._ticket += 1
        ticket = self._ticket
        self.post(OperatorQuestion(msg, ticket))
        while True:
            try:
                got, answer = self._answers.get(timeout=0.2)
            except queue.Empty:
                if self._closed.is_set():  # the UI has gone: end the run, its points are kept
                    return "abort"
                continue
            if got == ticket:
                return answer

    def answer(self, ticket: int, answer: str) -> None:
        """The UI's answer to question ``ticket`` (any thread)."""
        self._answers.put((ticket, answer))

    def close(self) -> None:
        """The UI is going away: the pending and every further question is answered ``abort``."""
        self._closed.set()

    def instruct(self, msg: Instruct) -> str:
        action = self.actions.get(msg.action)
        early = msg.action in EARLY_ACTIONS and action is not None and not self._closed.is_set()
        if early:
            action(**msg.params)
        answer = self._ask(msg)
        if answer == msg.choices[0] and action is not None and not early and self._acted != self._ticket:
            action(**msg.params)
        return answer

    def can_act(self, msg: Instruct) -> bool:
        """Is there a simulated action for ``msg`` (``--simulate``)?"""
        return msg.action in self.actions

    def act(self, ticket: int, msg: Instruct) -> bool:
        """Perform the simulated action of instruction ``ticket`` now, before it is answered (the UI thread:
        Space at a manual Cycle Start; the capture follows when the light settles); not again on the answer.
        False when there is none or it was done."""
        action = self.actions.get(msg.action)
        if action is None or self._acted == ticket or ticket != self._ticket:
            return False
        self._acted = ticket
        action(**msg.params)
        return True

    def stillness(self) -> str | None:
        """The stability light as the screen showed it when the capture was answered (messages.Stillness)."""
        return self.light

    def prompt(self, msg: Prompt) -> str:
        return self._ask(msg)

    def log(self, msg: Log) -> None:
        self.post(LogLine(msg.text))
