"""`snakesim graph`: the dataflow picture's layout is sound and the files are real.

The layout is tested as numbers (no pixel comparisons): columns follow the
signal flow, boxes never overlap, sub-assembly frames enclose their members
and not their neighbours, wide and tall graphs wrap. The drawn files are
checked for what a reader needs: every component name is in the SVG text.
"""

from __future__ import annotations

import itertools

from click.testing import CliRunner

from snakesim.framework.cli import cli
from snakesim.framework.dataflow_picture import layout
from snakesim.framework.session import load_session


def _overlap(a, b) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def _rects(lay):
    return {n: (b.x, b.y, b.x + b.w, b.y + b.h) for n, b in lay.boxes.items()}


def _sound(lay):
    rects = _rects(lay)
    for (n1, r1), (n2, r2) in itertools.combinations(rects.items(), 2):
        assert not _overlap(r1, r2), f"boxes {n1} and {n2} overlap"
    for f in lay.frames:
        prefix = "/".join(f.path) + "/"
        for n, r in rects.items():
            inside = f.x0 <= r[0] and r[2] <= f.x1 and f.y0 <= r[1] and r[3] <= f.y1
            if n.startswith(prefix) and lay.boxes[n].strip == f.strip:
                assert inside, f"{n} is outside its frame {prefix}"
            elif not n.startswith(prefix):
                assert not _overlap(r, (f.x0, f.y0, f.x1, f.y1)), f"{n} overlaps the frame of {prefix}"
    for r in rects.values():
        assert -1e-9 <= r[0] and r[2] <= lay.width + 1e-9 and -1e-9 <= r[1] and r[3] <= lay.height + 1e-9


def test_pendulum_reads_left_to_right():
    lay = layout(load_session("pendulum"))
    pend, damper = lay.boxes["pend"], lay.boxes["damper"]
    assert (pend.layer, damper.layer) == (0, 1)          # the state first, the block it feeds next
    assert pend.x < damper.x and pend.kind == "continuous" and damper.kind == "algebraic"
    back = next(lk for lk in lay.links if lk.src == "damper")
    assert back.ports == [("tau", "tau")] and not back.orders   # the loop is cut at the state's input
    assert "rec: theta, omega" in pend.info and "stop: theta" in pend.info
    _sound(lay)


def test_fifty_components_in_sub_assemblies_wrap_into_panels():
    lay = layout(load_session("mass-spring-chain", overrides=["n=25"]))
    assert len(lay.boxes) == 49 and lay.mode == "panels" and lay.n_strips >= 3
    assert 0.5 < lay.width / lay.height < 4, "a picture a person can read on a screen"
    assert {f.path for f in lay.frames} == {(f"cell{i}",) for i in range(1, 25)}
    _sound(lay)


def test_a_long_chain_wraps_into_strips(tmp_path):
    n = 50
    lines = ["sim: {duration: 0.01, dt: 0.001}", "components:", "  src: {type: constant}"]
    lines += [f"  g{i}: {{type: gain}}" for i in range(n)]
    lines += ["connections:", "  - src.y -> g0.u"] + [f"  - g{i - 1}.y -> g{i}.u" for i in range(1, n)]
    lines += [f"record: [g{n - 1}.y]"]
    (tmp_path / "chain.yaml").write_text("\n".join(lines) + "\n")
    lay = layout(load_session(tmp_path / "chain.yaml"))
    assert lay.n_layers == n + 1 and lay.mode == "strips" and lay.n_strips >= 4
    assert 0.5 < lay.width / lay.height < 4
    _sound(lay)


def test_pruned_components_are_drawn_grey(tmp_path):
    (tmp_path / "scene.yaml").write_text(
        "components:\n"
        "  pend: {type: pendulum}\n"
        "  unused: {type: gain}\n"
        "  source: {type: sine}\n"
        "connections:\n"
        "  - source.y -> unused.u\n")
    lay = layout(load_session(tmp_path / "scene.yaml"))
    assert lay.boxes["unused"].kind == "pruned" and lay.boxes["source"].kind == "pruned"
    assert [(lk.src, lk.dst) for lk in lay.links] == [("source", "unused")]   # pruned wiring still shown
    _sound(lay)


def test_cli_writes_svg_and_png(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for name in ("a.svg", "b.svg", "c.png"):
        result = CliRunner().invoke(cli, ["graph", "mass-spring-chain", "-o", name])
        assert result.exit_code == 0, result.output
    svg = (tmp_path / "a.svg").read_text()
    assert svg == (tmp_path / "b.svg").read_text(), "the same scene must give the same file"
    for text in ("mass0", "cell3", "spring_damper", "x → x_a"):
        assert text in svg
    assert (tmp_path / "c.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    result = CliRunner().invoke(cli, ["graph", "pendulum", "-o", "d.pdf"])
    assert result.exit_code != 0 and ".svg or .png" in result.output


def test_boxes_say_which_component_provides_the_robot_and_who_uses_it():
    """The robot is a resource, not an arrow: the provider's box says so, and each user's box names it."""
    lay = layout(load_session("contact-screw-drive", overrides=["robot.modules=2"]))
    assert "provides robot" in lay.boxes["robot"].info
    users = [n for n, b in lay.boxes.items() if "uses robot" in b.info]
    assert set(users) == {"contact", "drive"}
