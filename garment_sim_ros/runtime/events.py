"""Events of the frame loop and the node: each kind to the logger at most once per period, and every
one (a run of the same kind only once) to a recording (ROS-free: the logger is rclpy's or any with
``info``, ``warning`` and ``error``)."""

from __future__ import annotations

import time
from typing import Callable

LOG_PERIOD_S = 5.0  # the same warning at most this often


class Throttle:
    """Lets a message of a given kind (key) through at most once per ``period_s``."""

    def __init__(self, period_s: float = LOG_PERIOD_S):
        self.period_s = period_s
        self._last: dict[str, float] = {}

    def ready(self, key: str) -> bool:
        now = time.monotonic()
        if now - self._last.get(key, -float("inf")) < self.period_s:
            return False
        self._last[key] = now
        return True


class EventLog:
    """``log(level, kind, message)``: to ``logger`` throttled per kind, and to ``on_event(level, kind,
    message)`` unthrottled but a run of the same kind (a hold logs every frame) only once (the Rerun
    recording's text log)."""

    def __init__(self, logger=None, on_event: Callable[[str, str, str], None] | None = None):
        self.logger = logger
        self.on_event = on_event
        self.throttle = Throttle()
        self._last_kind = ""

    def log(self, level: str, kind: str, message: str) -> None:
        if self.on_event is not None and kind != self._last_kind:
            self.on_event(level, kind, message)
        self._last_kind = kind
        if self.logger is None or not self.throttle.ready(kind):
            return
        # one call per severity: rclpy's logger refuses two severities from one line of code
        if level == "error":
            self.logger.error(message)
        elif level == "warning":
            self.logger.warning(message)
        else:
            self.logger.info(message)
