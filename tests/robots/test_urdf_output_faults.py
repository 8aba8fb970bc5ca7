"""``snakesim robot urdf -o`` on a full or read-only disk: a clear error naming the file and the cause, a
non-zero exit, and nothing left that this call wrote (never a URDF naming meshes that are not there).

The full disk is simulated independently of the file system: the one write of every output file
(framework/output_files.py ``_write_all``) raises ENOSPC at the Nth write; the read-only cases are real
(a path through a regular file, a ``meshes`` that is a file, /proc).
"""

from __future__ import annotations

import errno
import os
from pathlib import Path

import pytest
from click.testing import CliRunner

from snakesim.framework import output_files
from snakesim.framework.cli import cli

ARGS = ["robot", "urdf", "--robot", "eels-1.0", "--modules", "2"]


def urdf(*args):
    return CliRunner().invoke(cli, [*ARGS, *map(str, args)])


def full_disk_at(monkeypatch, n: int) -> list[str]:
    """Make the nth output write fail with ENOSPC; returns the names written to, in order."""
    names: list[str] = []
    real = output_files._write_all

    def write(fh, data):
        names.append(os.path.basename(fh.name))
        if len(names) == n:
            raise OSError(errno.ENOSPC, "No space left on device")
        real(fh, data)

    monkeypatch.setattr(output_files, "_write_all", write)
    return names


def everything(root: Path) -> list[str]:
    return sorted(str(p.relative_to(root)) for p in root.rglob("*"))


def test_the_urdf_is_written_last_and_whole(tmp_path, monkeypatch):
    names = full_disk_at(monkeypatch, 0)        # never fails: just the order
    r = urdf("-o", tmp_path / "out" / "my.urdf")
    assert r.exit_code == 0, r.output
    assert names[-1] == ".my.urdf.%d.tmp" % os.getpid() and len(names) == 3     # 2 meshes, then the URDF
    assert not [p for p in everything(tmp_path) if p.endswith(".tmp")]


@pytest.mark.parametrize("n", [1, 2, 3])
def test_a_full_disk_at_any_write_leaves_nothing_and_names_the_file(tmp_path, monkeypatch, n):
    names = full_disk_at(monkeypatch, n)
    r = urdf("-o", tmp_path / "out" / "my.urdf")
    assert r.exit_code != 0
    failed = names[n - 1].split(".")[1:-2]          # .NAME.PID.tmp -> NAME
    assert ".".join(failed) in r.output and "No space left on device" in r.output, r.output
    assert "Traceback" not in r.output
    assert everything(tmp_path) == []               # the folders this call made are gone too


def test_a_full_disk_keeps_what_was_there_before(tmp_path, monkeypatch):
    out = tmp_path / "my.urdf"
    assert urdf("-o", out).exit_code == 0
    before = {p: (tmp_path / p).read_bytes() for p in everything(tmp_path) if (tmp_path / p).is_file()}
    (tmp_path / "meshes" / "other.stl").write_bytes(b"x")
    full_disk_at(monkeypatch, 1)                    # the meshes are there already: the URDF is the 1st write
    r = urdf("--modules", "3", "-o", out)
    assert r.exit_code != 0 and "my.urdf" in r.output
    assert {p: (tmp_path / p).read_bytes() for p in before} == before
    assert (tmp_path / "meshes" / "other.stl").exists()


def test_a_path_through_a_regular_file_is_named(tmp_path):
    (tmp_path / "plain").write_text("x")
    r = urdf("-o", tmp_path / "plain" / "sub" / "my.urdf")
    assert r.exit_code != 0 and "Traceback" not in r.output
    assert str(tmp_path / "plain" / "sub") in r.output and "regular file" in r.output, r.output
    assert everything(tmp_path) == ["plain"]


def test_a_meshes_file_in_the_way_leaves_no_urdf(tmp_path):
    (tmp_path / "meshes").write_text("not a folder")
    r = urdf("-o", tmp_path / "my.urdf")
    assert r.exit_code != 0 and str(tmp_path / "meshes") in r.output, r.output
    assert everything(tmp_path) == ["meshes"]


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="no /proc")
def test_a_folder_that_cannot_be_written_is_named(tmp_path):
    r = urdf("-o", "/proc/snakesim-test/my.urdf")
    assert r.exit_code != 0 and "/proc/snakesim-test" in r.output and "Traceback" not in r.output, r.output
