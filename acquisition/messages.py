"""Messages a plan yields; the engine executes each and sends back a reply.

Every message is a small frozen dataclass.  Replies: ``OpenRun`` -> run start
time (s since the epoch); ``Instruct``/``Prompt`` -> the operator's answer;
``ReadSensor`` -> :class:`~drivers.readings.AveragedDisplacement`;
``TriggerInterferometer`` -> :class:`~drivers.readings.InterferometerReading`;
the others -> ``None``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any


@dataclass(frozen=True)
class OpenRun:
    """Start a run; ``metadata`` becomes the run's start document."""

    kind: str
    metadata: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class Instruct:
    """Ask the operator to do something physical (e.g. place the block).

    ``action`` names it for automatic operators (``"place_block"``);
    ``params`` carries its arguments; ``choices`` the allowed answers.
    """

    action: str
    text: str
    params: dict[str, Any] = field(default_factory=dict)
    choices: tuple[str, ...] = ("done", "abort")


@dataclass(frozen=True)
class Prompt:
    """Ask the operator a question with a fixed set of answers."""

    text: str
    choices: tuple[str, ...]
    default: str | None = None


@dataclass(frozen=True)
class ZeroInterferometer:
    """Set the interferometer datum at the current pose."""


@dataclass(frozen=True)
class TriggerInterferometer:
    """Trigger one interferometer capture and return it."""


@dataclass(frozen=True)
class ReadSensor:
    """Averaged displacement-sensor reading of ``samples`` polled values."""

    samples: int = 1


@dataclass(frozen=True)
class Record:
    """Hand one data record (a point) to the subscribers; it is on disk when this returns."""

    data: dict[str, Any]
    stream: str = "primary"


@dataclass(frozen=True)
class Log:
    """A line for the operator's log."""

    text: str


@dataclass(frozen=True)
class CloseRun:
    """End the run normally."""

    reason: str = ""


Message = (
    OpenRun | Instruct | Prompt | ZeroInterferometer | TriggerInterferometer
    | ReadSensor | Record | Log | CloseRun
)
