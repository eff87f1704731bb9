"""Messages a plan yields; the engine executes each and sends back a reply.

Every message is a small frozen dataclass.  Replies: ``OpenRun`` -> run start
time (s since the epoch); ``Instruct``/``Prompt`` -> the operator's answer;
``ReadSensor`` -> :class:`~drivers.readings.AveragedDisplacement`;
``TriggerInterferometer`` -> :class:`~drivers.readings.InterferometerReading`;
``Wait`` -> the seconds actually waited; ``Requested`` -> bool; the others -> ``None``.

The engine handles two answers itself and never passes them to the plan:
``"pause"`` (the run pauses, the operator is asked to resume or abort, then the
same question is asked again) and ``"abort"`` (the run ends early, data kept).
"""


from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any


@dataclass(frozen=True)
class OpenRun:
    """Start a run; ``metadata`` becomes the run's start document."""

    kind: str
    metadata: dict[str, Any] = field(default_factory=dict)
    resume_uid: str = ""  # continue the run with this uid (``guideway acquire --resume``)


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
    key: str = ""


@dataclass(frozen=True)
class Prompt:
    """Ask the operator a question with a fixed set of answers.

    ``key`` names the kind of question (``"jump"``, ``"invalid"``, ``"fault"``,
    ``"warmup"``, ``"pause"``, ``"resume"``) so automatic operators and the TUI can
    treat it without parsing the text.  ``fault``: the unrecovered fault behind the
    question; answering ``"abort"`` then ends the run as *fail* with that reason.
    """

    text: str
    choices: tuple[str, ...]
    default: str | None = None
    key: str = ""
    fault: str = ""


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
class Wait:
    """Let ``seconds`` pass (warm-up observation interval, dwell)."""

    seconds: float


@dataclass(frozen=True)
class Annotate:
    """Set top-level run metadata ``key`` (run.json) to ``value``; on disk when this returns."""

    key: str
    value: Any


@dataclass(frozen=True)
class Retract:
    """Withdraw the last recorded point (the operator redoes it); ``match`` must equal its fields."""

    match: dict[str, Any]
    stream: str = "primary"


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
class Progress:
    """A progress report for the operator's display (e.g. the warm-up drift); no effect on the run.

    Subscribers get it as a ``progress`` document ``{"uid", "key", "data"}``.
    """

    key: str
    data: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class Requested:
    """Has the operator asked for ``key`` (e.g. ``"override"`` of a warm-up) since the last check?

    Reply: True once per request (:meth:`~acquisition.engine.RunEngine.request`), else False.
    """

    key: str


@dataclass(frozen=True)
class Stillness:
    """How the operator sees the block or axis at the step about to be captured (asked after its
    ``capture``).  Reply: ``"stable"``, ``"settling"`` or ``"moving"`` as its live view showed it when it
    answered (the TUI's stability light, :mod:`acquisition.stillness`); ``"look"`` when it has no live
    view and the plan should look with the interferometer (the plain terminal); None when nobody judges
    (the simulated technician, whose block is placed exactly and at once): no check.
    """


@dataclass(frozen=True)
class CloseRun:
    """End the run normally."""

    reason: str = ""


Message = (
    OpenRun | Instruct | Prompt | ZeroInterferometer | TriggerInterferometer
    | ReadSensor | Wait | Annotate | Retract | Record | Log | Progress | Requested | Stillness | CloseRun
)

# Messages that talk to a device: a driver error while executing one pauses the run.
DEVICE_MESSAGES: tuple[type, ...] = (ZeroInterferometer, TriggerInterferometer, ReadSensor)
