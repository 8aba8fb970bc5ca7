"""A rejected command on a command source's run state: counted, its reason kept, logged rate-limited.

Shared by the sources whose run state carries ``rejected``, ``last_reason`` and ``log``
(``CommandsRun``, ``TetherCommandsRun``), so every source counts and logs the same way.
"""

from __future__ import annotations

import numpy as np

from .rejections import RejectionLog


def count_rejection(run, owner: str, t: float, err: Exception, rejected_out: np.ndarray) -> None:
    """Count ``err`` (rejected at sim time ``t``, s) on ``run``, show the count on the ``rejected`` output
    ``rejected_out`` (shape (1,)), keep its text as ``run.last_reason`` and log it on ``owner``'s
    :class:`RejectionLog`, made on the first rejection (a run with none never makes one)."""
    run.rejected += 1
    run.last_reason = str(err)
    rejected_out[0] = run.rejected
    if run.log is None:
        run.log = RejectionLog(owner)
    run.log(t, err)
