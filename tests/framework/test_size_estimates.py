"""Sizes checked before anything is allocated: a camera resolution that cannot fit is refused with the
estimate (bytes a pixel x buffers) and a size that fits; a run's recording is estimated at build (rows at
sim.record_rate x columns) and ``snakesim run`` prints the estimate of a long run and warns, naming
sim.record_rate, about a recording that will reach the memory limit; only what cannot run is refused.
No test allocates anything large."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

from snakesim.framework import Component, Output, Params, SnakesimError
from snakesim.framework.cli import cli, install_plugin_cli
from snakesim.framework.recorder import recording_estimate, recording_warning

HUGE = 100_000


class HugeVector(Component[Params]):
    """A 100 000-element output (a 'huge vector port')."""

    type_name = "test_huge_vector"
    v = Output(shape=(HUGE,), unit="1", feedthrough=())

    def output(self, t, x, u, y):
        y.v[0] = t


def invoke(*args, env=None):
    install_plugin_cli()
    return CliRunner().invoke(cli, [str(a) for a in args], env=env)


def test_a_stereo_size_that_cannot_fit_is_refused_with_the_estimate_and_what_fits():
    r = invoke("run", "--stereo", "100000x100000", "--duration", "0.01", "--quiet")
    assert r.exit_code != 0 and "ArrayMemoryError" not in r.output and "Traceback" not in r.output, r.output
    out = " ".join(r.output.split())
    assert "--stereo: 100000x100000 pixels would take ~3.52 TB" in out, out       # 1e10 px x (322 + 2 x 15) B
    assert "B a pixel" in out and "memory limit" in out and "pixels fit, e.g." in out


def test_the_camera_check_follows_the_memory_limit(monkeypatch):
    from snakesim.components.perception.camera import camera_memory_bytes, check_camera_size

    check_camera_size(640, 480, views=2)
    monkeypatch.setenv("SNAKESIM_MEMORY_LIMIT", str(camera_memory_bytes(640, 480, 2)))
    check_camera_size(640, 480, views=2)
    with pytest.raises(ValueError, match=r"641x480 pixels would take .* e\.g\. 640x479"):
        check_camera_size(641, 480, views=2)


def test_a_camera_in_a_scene_file_is_checked_before_its_rays_are_made(monkeypatch, tmp_path):
    from snakesim.components.perception.camera import Camera

    class P:   # the parameters setup reads before the check
        near, max_range, width, height, color = 0.01, 10.0, 200_000, 200_000, True

    cam = Camera.__new__(Camera)          # setup alone, on a bare instance: nothing else is built
    monkeypatch.setattr(Camera, "p", property(lambda self: P()), raising=False)
    monkeypatch.setattr(Camera, "rate", 5.0, raising=False)
    monkeypatch.setattr(Camera, "name", "cam", raising=False)
    with pytest.raises(ValueError, match=r"^cam: 200000x200000 pixels would take"):
        cam.setup()


def test_a_huge_vector_recording_is_estimated_at_build_naming_record_rate(write_yaml, monkeypatch):
    from snakesim.framework.registry import build_registry
    from snakesim.framework.session import load_session

    reg = build_registry(load_entry_points=False)
    reg.add_component(HugeVector)
    s = load_session(write_yaml("""
        sim: {duration: 1000.0, dt: 0.01, integrator: rk4}
        components:
          big: {type: test_huge_vector}
        record: [big.v]
    """), registry=reg)
    est = recording_estimate(s.plan, 1000.0)
    assert est["rows"] == 100_001 and est["columns"] == HUGE and est["bytes"] == 8.0 * 100_001 * (HUGE + 1)
    monkeypatch.setenv("SNAKESIM_MEMORY_LIMIT", "1e9")
    est = recording_estimate(s.plan, 1000.0)
    msg = recording_warning(est, 1000.0)
    assert msg.startswith("the recording would take ~80 GB (1e+05 rows at sim.record_rate = 100 Hz x 100000 "
                          "signal columns), over the memory limit 1 GB"), msg
    rate = est["fit_rate"]
    assert f"set sim.record_rate to at most {rate:g} Hz" in msg and 8.0 * (HUGE + 1) * rate * 1000.0 <= 1e9
    assert recording_warning(recording_estimate(s.plan, 1.0), 1.0) is None


def test_a_billion_second_run_prints_its_estimate_before_it_starts(monkeypatch):
    from snakesim.framework.session import Session

    def not_run(self, *a, **k):
        raise SnakesimError("stopped by the test before the run")

    monkeypatch.setattr(Session, "run", not_run)
    r = invoke("run", "pendulum", "--duration", "1e9")
    out = " ".join(r.output.split())
    assert "estimate: 1e+12 base steps" in out and "rows x 3 signal columns at sim.record_rate = 1000 Hz" in out, out
    assert "warning: the recording would take ~32 TB" in out and "set sim.record_rate to at most" in out
    assert "stopped by the test before the run" in out
    # with --quiet the warning is still said; a short run says nothing
    r = invoke("run", "pendulum", "--duration", "1e9", "--quiet")
    assert "estimate:" not in r.output and "warning: the recording would take" in r.output
    r = invoke("run", "pendulum", "--duration", "1")
    assert "estimate:" not in r.output and "warning" not in r.output


def test_what_cannot_run_is_refused_before_it_starts():
    r = invoke("run", "pendulum", "--duration", "1e10", "--quiet")
    assert r.exit_code != 0 and "at most 1e+12 steps" in r.output, r.output
