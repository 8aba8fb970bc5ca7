"""Issue 17: recordings are streamed, not preallocated. The recorder fills fixed-size chunks; with an
output folder each full chunk is appended to signals.csv as it fills, so the file is byte-identical to
one written at the end, and a run killed midway keeps its rows up to the last full chunk."""

from __future__ import annotations

import io
import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from snakesim.framework import recorder as recorder_mod

SNAKESIM = Path(sys.executable).with_name("snakesim")

SCENE = """
sim: {duration: 0.5, dt: 0.001, integrator: rk4}
components:
  src: {type: constant, params: {value: [1.0, 2.0, 3.0], n: 3}}
  pend: {type: pendulum, params: {theta0: 0.3}}
record: [pend.theta, src.y]
"""


def _preallocated_csv(columns, rows) -> bytes:
    """What the recorder wrote before chunks: the header, then one savetxt of every row."""
    buf = io.StringIO()
    buf.write(",".join(columns) + "\n")
    np.savetxt(buf, rows, fmt="%.17g", delimiter=",")
    return buf.getvalue().encode()


@pytest.mark.parametrize("chunk", [7, 64, 501])
def test_a_recording_of_many_chunks_is_identical_to_one_preallocated(scene, tmp_path, monkeypatch, chunk):
    one = scene(SCENE).run(out_dir=tmp_path / "one")          # 501 rows: one chunk
    assert one.log.n == 501 and len(one.log.chunks) == 1
    monkeypatch.setattr(recorder_mod, "CHUNK_ROWS", chunk)
    many = scene(SCENE).run(out_dir=tmp_path / "many")
    assert many.log.chunk_rows == chunk and many.log.n == 501
    np.testing.assert_array_equal(many.log.rows, one.log.rows)
    np.testing.assert_array_equal(many["src.y"], one["src.y"])
    np.testing.assert_array_equal(many.log["pend.theta"], one.log["pend.theta"])
    expected = _preallocated_csv(one.log.columns, one.log.rows)
    assert (tmp_path / "one" / "signals.csv").read_bytes() == expected
    assert (tmp_path / "many" / "signals.csv").read_bytes() == expected
    # write_csv elsewhere (not the streamed file) gives the same bytes
    many.log.write_csv(tmp_path / "again.csv")
    assert (tmp_path / "again.csv").read_bytes() == expected


def test_rows_are_concatenated_lazily_and_cached_until_the_next_record(scene):
    s = scene(SCENE)
    from snakesim.framework.recorder import Recorder

    log = Recorder(s.plan.record_refs, s.plan, None, chunk_rows=4)
    for k in range(10):
        assert log.record(k * 0.1) is None
    r1 = log.rows
    assert r1.shape == (10, 5) and log.rows is r1                 # cached
    np.testing.assert_array_equal(r1[:, 0], np.arange(10) * 0.1)
    assert all(c.base is r1 for c in log.chunks)                  # the chunks are views of it: memory held once
    log.record(1.0)
    r2 = log.rows
    assert r2 is not r1 and r2.shape == (11, 5) and r2[-1, 0] == 1.0
    np.testing.assert_array_equal(r2[:10], r1)


def test_the_default_chunk_size_streams_a_long_recording_exactly(scene, tmp_path):
    """Over 8192 rows with the default chunk: rows and bytes as preallocated."""
    s = scene(SCENE, sim_overrides={"duration": 20.0, "dt": 0.001, "integrator": "semi_implicit_euler"})
    r = s.run(out_dir=tmp_path / "o")
    assert r.log.n == 20001 and len(r.log.chunks) == 20001 // recorder_mod.CHUNK_ROWS
    assert (tmp_path / "o" / "signals.csv").read_bytes() == _preallocated_csv(r.log.columns, r.log.rows)


def test_a_run_killed_midway_keeps_its_signals_up_to_the_last_flush(tmp_path):
    out = tmp_path / "run"
    p = subprocess.Popen([str(SNAKESIM), "run", "pendulum", "--duration", "1000", "--out", str(out)],
                         stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
    try:
        line = p.stderr.readline()
        if line.startswith("compiling kernels"):      # a cold numba cache (a first run) says so first
            line = p.stderr.readline()
        assert line.startswith("running"), line
        csv = out / "signals.csv"
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:      # a couple of seconds in, and at least two chunks written
            time.sleep(0.5)
            if csv.is_file() and csv.stat().st_size > 0 and \
                    len(csv.read_bytes().splitlines()) > 2 * recorder_mod.CHUNK_ROWS:
                break
        time.sleep(0.5)
        p.send_signal(signal.SIGKILL)
        p.wait(timeout=60)
    finally:
        if p.poll() is None:
            p.kill()
    assert p.returncode == -signal.SIGKILL
    summary = json.loads((out / "summary.json").read_text())      # it never ended, and says so
    assert summary["outcome"] == "incomplete" and summary["completed"] is False
    assert (out / "config.yaml").read_text().startswith("# snakesim resolved configuration")
    text = csv.read_text()
    assert text.endswith("\n")                                    # whole rows only: no torn row
    header, *lines = text.splitlines()
    assert header.startswith("t,")
    n = len(lines)
    assert n >= 2 * recorder_mod.CHUNK_ROWS
    data = np.loadtxt(csv, delimiter=",", skiprows=1, ndmin=2)
    assert data.shape == (n, len(header.split(","))) and np.isfinite(data).all()
    dt = data[1, 0] - data[0, 0]
    np.testing.assert_allclose(data[:, 0], np.arange(n) * dt, rtol=0, atol=1e-9 * n)


def test_a_two_dimensional_port_names_its_columns_without_commas(tmp_path):
    """An unnamed (2, 3) port: columns comp.port[i][j], so the CSV header splits into as many columns as
    every row has values (a comma inside a name split it into more)."""
    from snakesim.framework import Builder, Component, Output

    class Grid(Component):
        type_name = "grid_2d_test"
        time_invariant = True
        cells = Output(shape=(2, 3), unit="1")

        def output(self, t, x, u, y):
            y.cells[:] = np.arange(6.0).reshape(2, 3)

    b = Builder(dt=0.1, duration=0.3)
    g = b.add(Grid("g"))
    b.record(g.out.cells)
    b.build().run(out_dir=None).log.write_csv(tmp_path / "s.csv")
    header, first = (tmp_path / "s.csv").read_text().splitlines()[:2]
    assert header.split(",") == ["t", *(f"g.cells[{i}][{j}]" for i in range(2) for j in range(3))]
    assert len(first.split(",")) == len(header.split(","))
