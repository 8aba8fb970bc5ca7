"""--viz values: the three targets, the errors for bad ones, and the headless rule."""

import pytest

from snakesim.components.viz.target import (DEFAULT_FILE, VizTarget, VizTargetError, effective_target,
                                            headless_reason, parse_target)


@pytest.mark.parametrize("text, expected", [
    ("spawn", VizTarget("spawn")),
    ("serve", VizTarget("serve")),
    ("save run.rrd", VizTarget("save", "run.rrd")),
    ("save=out/run.rrd", VizTarget("save", "out/run.rrd")),
    ("save:run.rrd", VizTarget("save", "run.rrd")),
    ("run.RRD", VizTarget("save", "run.RRD")),
])
def test_valid_targets(text, expected):
    assert parse_target(text) == expected
    assert parse_target(str(expected)) == expected          # the sink's params round-trip


@pytest.mark.parametrize("text, message", [
    ("bogus", "'bogus' is not a viewer target; valid: spawn | save FILE.rrd | serve"),
    ("save", "'save' needs a file name: --viz save FILE.rrd"),
    ("save=", "'save' needs a file name"),
    ("save run.txt", "'run.txt': a rerun recording file must end in .rrd"),
])
def test_bad_targets_say_what_is_valid(text, message):
    with pytest.raises(VizTargetError, match=message.replace("|", r"\|").replace(".", r"\.")):
        parse_target(text)


def test_headless_reasons():
    assert headless_reason({"CI": "true", "DISPLAY": ":0"}, "linux") == "the CI environment variable is set"
    assert headless_reason({}, "linux") == "no display ($DISPLAY is unset)"
    assert headless_reason({"DISPLAY": ":0"}, "linux") is None
    assert headless_reason({"WAYLAND_DISPLAY": "wayland-0"}, "linux") is None
    assert headless_reason({}, "darwin") is None            # macOS has a display without $DISPLAY


def test_spawn_falls_back_to_save_when_headless():
    said = []
    t = effective_target(VizTarget("spawn"), {"CI": "1"}, "linux", warn=said.append)
    assert t == VizTarget("save", DEFAULT_FILE)
    assert "CI environment variable" in said[0] and f"rerun {DEFAULT_FILE}" in said[0]
    # with a display, and for the other modes, nothing changes and nothing is said
    assert effective_target(VizTarget("spawn"), {"DISPLAY": ":0"}, "linux", warn=said.append) == VizTarget("spawn")
    assert effective_target(VizTarget("serve"), {}, "linux", warn=said.append) == VizTarget("serve")
    assert len(said) == 1
