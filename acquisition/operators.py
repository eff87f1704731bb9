"""Operators answer a plan's instructions and prompts.

The engine receives an operator; the plan never knows which one it has:
automatic (the simulated technician), plain terminal, or the TUI.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import Protocol, TextIO

from .messages import Instruct, Log, Prompt
from .stillness import LOOK


class Operator(Protocol):
    def instruct(self, msg: Instruct) -> str: ...

    def prompt(self, msg: Prompt) -> str: ...

    def log(self, msg: Log) -> None: ...

    # optional: ``stillness() -> str | None``, the answer to messages.Stillness (none: nobody judges)


class AutoOperator:
    """Simulated technician: performs physical actions through ``actions`` and
    answers every question with ``answers[msg.key]`` if given, else its default
    (or first) choice.

    A question about a fault (``Prompt.fault``) is answered ``"retry"`` at most
    ``fault_retries`` times in a run, then ``"abort"``: an unattended run gives up
    on a fault that does not clear instead of retrying for ever.  A warm-up that
    does not settle before its timeout is overridden (recorded in the run).
    """

    def __init__(self, actions: dict[str, Callable[..., None]] | None = None,
                 log_to: TextIO | None = None, *, answers: dict[str, str] | None = None,
                 fault_retries: int = 1) -> None:
        self.actions = actions or {}
        self.log_to = log_to
        self.answers = {"warmup": "override", **(answers or {})}
        self.fault_retries = fault_retries
        self.transcript: list[str] = []

    def instruct(self, msg: Instruct) -> str:
        self.transcript.append(msg.text)
        action = self.actions.get(msg.action)
        if action is not None:
            action(**msg.params)
        return self.answers.get(msg.key) or msg.choices[0]

    def prompt(self, msg: Prompt) -> str:
        self.transcript.append(msg.text)
        if msg.fault:  # the first choice is the one that tries again (retry, wait, acknowledge)
            if self.fault_retries <= 0:
                return "abort"
            self.fault_retries -= 1
            return msg.choices[0]
        answer = self.answers.get(msg.key)
        if answer in msg.choices:
            return answer
        return msg.default if msg.default is not None else msg.choices[0]

    def log(self, msg: Log) -> None:
        self.transcript.append(msg.text)
        if self.log_to is not None:
            print(msg.text, file=self.log_to, flush=True)


class TerminalOperator:
    """Plain terminal: prints instructions and questions with their choices; Enter
    accepts the default (for an instruction: the first choice, e.g. ``capture``); a
    unique prefix selects a choice (``r`` = retry/redo when unambiguous)."""

    def __init__(self, stdin: TextIO = sys.stdin, stdout: TextIO = sys.stdout,
                 actions: dict[str, Callable[..., None]] | None = None) -> None:
        self.stdin = stdin
        self.stdout = stdout
        # Simulated physical actions (``--simulate``): done when the operator confirms an instruction.
        self.actions = actions or {}

    def _ask(self, text: str, choices: tuple[str, ...], default: str | None) -> str:
        default = default or choices[0]
        while True:
            print(f"{text} [{'/'.join(choices)}] (Enter = {default}): ", end="", file=self.stdout, flush=True)
            line = self.stdin.readline()
            if not line:  # EOF: treat as abort if offered
                return "abort" if "abort" in choices else default
            answer = line.strip().lower()
            if not answer:
                return default
            matches = [c for c in choices if c.startswith(answer)]
            if len(matches) == 1:
                return matches[0]
            print(f"  please answer one of: {', '.join(choices)}", file=self.stdout)

    def instruct(self, msg: Instruct) -> str:
        answer = self._ask(msg.text, msg.choices, None)
        action = self.actions.get(msg.action)
        if answer == msg.choices[0] and action is not None:
            action(**msg.params)
        return answer

    def prompt(self, msg: Prompt) -> str:
        return self._ask(msg.text, msg.choices, msg.default)

    def log(self, msg: Log) -> None:
        print(msg.text, file=self.stdout, flush=True)

    def stillness(self) -> str:
        """No live view here: the plan looks with the interferometer before a capture (messages.Stillness)
        and asks when the block does not come to rest."""
        return LOOK
