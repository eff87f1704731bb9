"""Driving a plan (a generator of messages) in a test without devices or an engine."""

from __future__ import annotations

from collections.abc import Callable, Generator, Iterable
from typing import Any, TypeVar

from acquisition import messages as m
from drivers.readings import AveragedDisplacement

R = TypeVar("R", bound=Callable[[Any], Any])


def drive(plan: Generator[Any, Any, Any], responder: R) -> R:
    """Send each message of ``plan`` to ``responder`` and its answer back, to the plan's end."""
    reply = None
    while True:
        try:
            msg = plan.send(reply)
        except StopIteration:
            return responder
        reply = responder(msg)


class Scripted:
    """A responder: the interferometer readings of ``readings`` in order, a good 2-sample sensor
    reading, every wait as asked, the first choice to every question, start time 0; keeps every
    message in ``msgs``."""

    def __init__(self, readings: Iterable[Any]) -> None:
        self.readings = iter(readings)
        self.msgs: list[Any] = []

    def __call__(self, msg: Any) -> Any:
        self.msgs.append(msg)
        if isinstance(msg, m.TriggerInterferometer):
            return next(self.readings)
        if isinstance(msg, m.ReadSensor):
            return AveragedDisplacement(0.0, 0.0, 2, 0, 0.0, ())
        if isinstance(msg, m.Wait):
            return msg.seconds
        if isinstance(msg, m.Instruct | m.Prompt):
            return msg.choices[0]
        return 0.0 if isinstance(msg, m.OpenRun) else None
