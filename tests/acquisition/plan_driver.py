"""Running a workflow plan without the engine: every message the plan yields goes to a responder
(the test's bench), whose answer is sent back, until the plan ends."""

from __future__ import annotations

from collections.abc import Callable, Generator
from typing import Any, TypeVar

R = TypeVar("R", bound=Callable[[Any], Any])


def drive(plan: Generator[Any, Any, Any], responder: R) -> R:
    """Run ``plan`` to its end against ``responder``; returns the responder (holding what it saw)."""
    reply = None
    while True:
        try:
            msg = plan.send(reply)
        except StopIteration:
            return responder
        reply = responder(msg)
