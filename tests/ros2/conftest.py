import itertools
import os
import sys

import pytest

sys.path.insert(0, os.path.dirname(__file__))


def _dds_or_skip():
    try:
        import cyclonedds.domain  # noqa: F401
        import rosbags.typesys  # noqa: F401
    except Exception as e:            # pragma: no cover - the dependency is declared
        pytest.skip(f"cyclonedds/rosbags not importable: {e}")


@pytest.fixture(scope="session")
def dds_domain():
    """A domain id no other test (or concurrent run) of this session uses, and a check that DDS starts here."""
    _dds_or_skip()
    from snakesim.components.ros2.transport import Ros2Participant

    base = 100 + os.getpid() % 100
    try:
        Ros2Participant(base).close()
    except Exception as e:
        pytest.skip(f"Cyclone DDS cannot start on loopback in this sandbox: {e}")
    # every domain id 1-219 once, from this session's base, before any is reused: a session
    # of more tests than ids wraps round rather than running dry (a test's participants are closed by then).
    # Under pytest-xdist each worker takes its own residue class, so two workers never share a domain.
    worker = int(os.environ.get("PYTEST_XDIST_WORKER", "gw0")[2:])
    workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
    # (220-232 are left to tests elsewhere that start a node of their own: tests/docs/test_ros2_readme.py)
    ids = [d for d in [*range(base, 220), *range(1, base)] if d % workers == worker % workers]
    counter = itertools.cycle(ids)
    return lambda: next(counter)
