"""Messages from the run's worker thread to the UI (``post_message`` is thread-safe).

Live readings replace one another in the queue (``can_replace``, as Toolong's
``SizeChanged``): a sensor streaming at kHz rates reaches the screen as at most
one pending reading, never a backlog.  Documents, questions and log lines are
never dropped.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from textual.message import Message

if TYPE_CHECKING:  # the app's first frame does not wait for the acquisition stack
    from acquisition.engine import RunOutcome
    from acquisition.messages import Instruct, Prompt
    from acquisition.monitor import LiveReading


@dataclass
class LiveReadingArrived(Message, bubble=False):
    """The newest live reading of the devices."""

    reading: LiveReading

    def can_replace(self, message: Message) -> bool:
        return isinstance(message, LiveReadingArrived)


@dataclass
class RunDocument(Message, bubble=False):
    """One engine document (``start``, ``event``, ``annotate``, ``retract``, ``state``, ``progress``, ``stop``)."""

    name: str
    doc: dict[str, Any]


@dataclass
class HeightArrived(Message, bubble=False):
    """The live surface height of a straightness point (acquisition.live.LiveProfile)."""

    pass_: int
    station: int
    height_um: float


@dataclass
class DeviationArrived(Message, bubble=False):
    """The live deviation of a positioning point (acquisition.live.LiveDeviation): µm after
    environmental compensation (linear axes) or arcsec (rotary), ``label`` says which."""

    row: dict[str, Any]
    deviation: float
    label: str


@dataclass
class OperatorQuestion(Message, bubble=False):
    """The plan asks the operator; the answer goes back with ``ticket`` (tui.operator.TuiOperator.answer)."""

    question: Instruct | Prompt
    ticket: int


@dataclass
class LogLine(Message, bubble=False):
    text: str


@dataclass
class RunEnded(Message, bubble=False):
    """The run's worker has finished: ``outcome`` (None when it failed before starting, ``error`` says why)."""

    run_dir: Path
    outcome: RunOutcome | None
    error: str = ""
