"""Where a recording goes: ``spawn`` a viewer, ``save`` an .rrd file, or ``serve`` it.

    parse_target("spawn") / ("serve") / ("save FILE.rrd") / ("save=FILE.rrd") / ("FILE.rrd")

Headless rule: with the ``CI`` environment variable set, or on Linux/BSD with
neither ``DISPLAY`` nor ``WAYLAND_DISPLAY``, nothing opens a window: ``spawn``
saves to its file instead (default ``snakesim.rrd``) and says so on stderr.
"""

from __future__ import annotations

import dataclasses
import os
import sys
from pathlib import Path

MODES = ("spawn", "save", "serve")
DEFAULT_FILE = "snakesim.rrd"
USAGE = "spawn | save FILE.rrd | serve"


class VizTargetError(ValueError):
    """A --viz value that names no viewer target; the message says what is valid."""


@dataclasses.dataclass(frozen=True)
class VizTarget:
    mode: str                   # spawn | save | serve
    path: str = DEFAULT_FILE    # the .rrd file for save (and for spawn's headless fallback)

    def __str__(self) -> str:
        return f"save {self.path}" if self.mode == "save" else self.mode


def parse_target(text: str) -> VizTarget:
    s = str(text).strip()
    if s in ("spawn", "serve"):
        return VizTarget(s)
    if s == "save":
        raise VizTargetError("'save' needs a file name: --viz save FILE.rrd")
    for sep in (" ", "=", ":"):
        if s.startswith("save" + sep):
            return VizTarget("save", _rrd(s[5:].strip()))
    if s.lower().endswith(".rrd"):
        return VizTarget("save", s)
    raise VizTargetError(f"'{s}' is not a viewer target; valid: {USAGE} (or just FILE.rrd)")


def _rrd(path: str) -> str:
    if not path:
        raise VizTargetError("'save' needs a file name: --viz save FILE.rrd")
    if not path.lower().endswith(".rrd"):
        raise VizTargetError(f"'{path}': a rerun recording file must end in .rrd")
    return path


def headless_reason(environ=None, platform: str | None = None) -> str | None:
    """Why no window may open here (None when one may)."""
    env = os.environ if environ is None else environ
    plat = sys.platform if platform is None else platform
    if env.get("CI"):
        return "the CI environment variable is set"
    if plat.startswith(("linux", "freebsd", "openbsd")) and not (env.get("DISPLAY") or env.get("WAYLAND_DISPLAY")):
        return "no display ($DISPLAY is unset)"
    return None


def effective_target(target: VizTarget, environ=None, platform: str | None = None,
                     warn=lambda msg: sys.stderr.write(msg + "\n")) -> VizTarget:
    """``target``, or for ``spawn`` on a headless machine the save fallback (with a message)."""
    if target.mode != "spawn":
        return target
    why = headless_reason(environ, platform)
    if why is None:
        return target
    warn(f"snakesim viz: {why}, so no viewer window opens; saving the recording to {target.path} instead "
         f"(view it with `rerun {target.path}`)")
    return VizTarget("save", target.path)


def open_recording(target: VizTarget, application_id: str = "snakesim", recording_id: str | None = None,
                   blueprint=None, warn=lambda msg: sys.stderr.write(msg + "\n")):
    """(a fresh rerun RecordingStream sending to ``target``, the target used after the
    headless rule). Only the ``sim`` timeline is kept (no wall-clock log_time)."""
    import rerun as rr

    target = effective_target(target, warn=warn)
    rec = rr.RecordingStream(application_id, recording_id=recording_id)
    rec.set_log_time_enabled(False)
    rec.set_log_tick_enabled(False)
    if target.mode == "save":
        Path(target.path).parent.mkdir(parents=True, exist_ok=True)
        rec.save(target.path, default_blueprint=blueprint)
    elif target.mode == "spawn":
        rec.spawn(default_blueprint=blueprint)
    elif target.mode == "serve":
        url = rec.serve_grpc(default_blueprint=blueprint)
        rr.serve_web_viewer(connect_to=url, open_browser=False)
        warn(f"snakesim viz: serving the recording at {url} (web viewer on http://localhost:9090); "
             "open it with `rerun --connect` or a browser")
    else:
        raise VizTargetError(f"unknown viewer mode '{target.mode}'; valid: {USAGE}")
    return rec, target
