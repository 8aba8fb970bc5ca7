"""Rejected ROS 2 commands: the exception that names the field and value, and a rate-limited log of them.

Every command source (joint commands, tether commands, simulation requests)
validates a message whole before anything reaches the physics and raises
:class:`Rejected` with a text that names the topic, the field and the value.
:class:`RejectionLog` writes it as a warning on logger ``snakesim.ros2``; the
same reason (the text with its numbers masked: ``points[2].positions[0] (bend_01)
= nan`` and ``points[3]…`` are one reason) at most once per ``every`` wall
seconds: a stack that floods a malformed command gets one line per second, and
the next line for that reason says how many like it were not logged.
"""

from __future__ import annotations

import logging
import re
import time

log = logging.getLogger("snakesim.ros2")

_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


class Rejected(ValueError):
    """A command that is not applied; the message names the field and value."""


def check_stamp(topic: str, header, t: float, max_age: float) -> None:
    """Reject a stamped header (stamp ≠ 0) older than sim time ``t`` by more than ``max_age`` s (stale); an
    unstamped (zero) header is not checked."""
    s = header.stamp
    if s.sec == 0 and s.nanosec == 0:
        return
    st = s.sec + 1e-9 * s.nanosec
    if t - st > max_age:
        raise Rejected(f"{topic}: header.stamp = {st:.9g} s is stale: {t - st:.6g} s older than sim time "
                       f"{t:.9g} s (max_age {max_age:g} s)")


def reason_key(text: str) -> str:
    """The reason a text gives, numbers masked: two rejections for the same reason share it."""
    return _NUMBER.sub("#", text)


class RejectionLog:
    """Warns once per reason per ``every`` wall s (see the module docstring); counts what it did not log."""

    def __init__(self, owner: str, every: float = 1.0):
        self.owner, self.every = owner, every
        self._seen: dict[str, list] = {}            # reason -> [wall s of the last line, not logged since]

    def __call__(self, t: float, err: Exception) -> bool:
        """Log ``err`` (rejected at sim time ``t``) unless its reason was logged less than ``every`` s ago.
        True when a line was written."""
        text = str(err)
        key = reason_key(text)
        now = time.monotonic()
        seen = self._seen.get(key)
        if seen is not None and now - seen[0] < self.every:
            seen[1] += 1
            return False
        more = seen[1] if seen is not None else 0
        if len(self._seen) > 1000:                   # many distinct reasons: forget the old ones
            self._seen = {k: v for k, v in self._seen.items() if now - v[0] < self.every}
        self._seen[key] = [now, 0]
        if more:
            log.warning("%s: rejected at t = %.6g s: %s (and %d more for this reason since the last line)",
                        self.owner, t, text, more)
        else:
            log.warning("%s: rejected at t = %.6g s: %s", self.owner, t, text)
        return True
