"""Where runs execute: a local process pool (default) or Dask distributed, behind one executor interface.

Both hand the campaign a ``concurrent.futures``-style executor (``submit`` ->
``concurrent.futures.Future``): the standard library's ProcessPoolExecutor, or
dask's ``Client.get_executor()``. The campaign loop is the same for both;
distribution, retries on lost Dask workers and data transfer are theirs.
"""

from __future__ import annotations

import multiprocessing
import os
import re
from concurrent.futures import ProcessPoolExecutor

from .results import CampaignError

CONNECT_TIMEOUT_S = 10.0


class Backend:
    """An executor plus how many runs it executes at once (``slots``) and a one-line description."""

    def __init__(self, executor, slots: int, description: str, closer=None, restart=None):
        self.executor, self.slots, self.description = executor, max(1, int(slots)), description
        self._closer, self._restart = closer, restart

    def restart(self) -> None:
        """A fresh executor after the old one broke (a local worker process died)."""
        if self._restart is None:
            raise CampaignError(f"{self.description}: the executor broke and cannot be restarted")
        self.executor = self._restart()

    def close(self, interrupted: bool = False) -> None:
        """Shut down; ``interrupted`` (Ctrl-C): do not wait for the runs in flight, end local workers now."""
        if interrupted:
            # ProcessPoolExecutor has no public way to stop running work before 3.14's terminate_workers();
            # the runs in flight are not recorded, so a resume runs them again
            for proc in list((getattr(self.executor, "_processes", None) or {}).values()):
                proc.terminate()
        try:
            self.executor.shutdown(wait=not interrupted, cancel_futures=True)
        except TypeError:       # dask's ClientExecutor has no cancel_futures
            self.executor.shutdown(wait=not interrupted)
        if self._closer:
            self._closer()

    def __enter__(self):
        return self

    def __exit__(self, exc_type, *exc):
        self.close(interrupted=exc_type is KeyboardInterrupt)


def local_pool(workers: int | None = None) -> Backend:
    """A process pool of ``workers`` processes (default: every core).

    Workers are spawned, not forked: the parent has loaded numba and maybe
    threads (a forked copy of a threaded process can deadlock), and a spawned
    worker behaves the same on every OS.
    """
    n = workers or os.cpu_count() or 1
    if n < 1:
        raise CampaignError(f"--workers must be >= 1, got {n}")
    ctx = multiprocessing.get_context("spawn")

    def make():
        return ProcessPoolExecutor(max_workers=n, mp_context=ctx, initializer=_worker_init)

    return Backend(make(), n, f"local process pool, {n} worker{'s' * (n != 1)}", restart=make)


def _worker_init() -> None:
    """Workers leave Ctrl-C to the campaign: a run is then either recorded whole or not at all
    (a worker killed by the terminal's SIGINT would otherwise be recorded as a failed run).
    And a worker whose campaign was killed outright (SIGKILL, a lost session) exits within a
    second instead of lingering: nothing would read its result."""
    import signal
    import threading
    import time

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    parent = os.getppid()

    def watch():
        while os.getppid() == parent:
            time.sleep(1.0)
        os._exit(1)

    threading.Thread(target=watch, name="campaign-parent-watch", daemon=True).start()


_ADDRESS = re.compile(r"^(tcp|tls|inproc|ucx|ws|wss)://[^\s/]+(:\d+)?$")


def dask_scheduler(address: str, connect_timeout: float = CONNECT_TIMEOUT_S) -> Backend:
    """Connect to a running Dask scheduler (``tcp://host:port``) within ``connect_timeout`` s."""
    if not _ADDRESS.match(address):
        raise CampaignError(f"--scheduler {address!r} is not a scheduler address; valid: tcp://HOST:PORT "
                            "(also tls://, ws://, ucx://)")
    try:
        from distributed import Client
    except ImportError as e:     # pragma: no cover - dask is a dependency
        raise CampaignError(f"--scheduler needs dask[distributed]: {e}") from None
    try:
        client = Client(address, timeout=f"{connect_timeout}s", set_as_default=False)
    except (OSError, TimeoutError) as e:
        raise CampaignError(f"cannot reach the Dask scheduler at {address} within {connect_timeout:g} s "
                            f"({type(e).__name__}: {e}); is `dask scheduler` running there, and the port open?") \
            from None
    return _dask_backend(client, f"Dask scheduler {address}", client.close)


def dask_local(workers: int) -> Backend:
    """Start a Dask LocalCluster of ``workers`` single-threaded processes on loopback, no dashboard."""
    if workers < 1:
        raise CampaignError(f"--dask-local must be >= 1 workers, got {workers}")
    from distributed import Client, LocalCluster

    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                           dashboard_address=None)
    client = Client(cluster, set_as_default=False)

    def close():
        client.close()
        cluster.close()

    return _dask_backend(client, f"Dask LocalCluster, {workers} worker{'s' * (workers != 1)}", close)


def _dask_backend(client, description: str, closer) -> Backend:
    info = client.scheduler_info()
    slots = sum(w.get("nthreads", 1) for w in info.get("workers", {}).values()) or 1
    # pure=False: two runs with equal arguments (a grid point run twice) are still two runs
    return Backend(client.get_executor(pure=False), slots, f"{description} ({slots} threads)", closer=closer)
