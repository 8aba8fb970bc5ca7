"""Where a recording goes: ``spawn`` a viewer, ``save`` an .rrd file, or ``serve`` it.

    parse_target("spawn") / ("serve") / ("save FILE.rrd") / ("save=FILE.rrd") / ("FILE.rrd")

Headless rule: with the ``CI`` environment variable set, or on Linux/BSD with
neither ``DISPLAY`` nor ``WAYLAND_DISPLAY``, nothing opens a window: ``spawn``
saves to its file instead (default ``snakesim.rrd``) and says so on stderr.

``serve`` binds loopback (``host`` 127.0.0.1) unless told otherwise (``--viz-host 0.0.0.0``): a gRPC
server (``grpc_port``, 9876: what ``rerun --connect`` and the web viewer read) and a web viewer over
HTTP (``port``, 9090: static pages only, served by the rerun binary bound to the same host; rerun-sdk's
own ``serve_web_viewer`` always binds every interface). Both ports are checked before anything starts:
a busy one is a :class:`VizTargetError` naming it and what to do.
"""

from __future__ import annotations

import dataclasses
import errno
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

MODES = ("spawn", "save", "serve")
DEFAULT_FILE = "snakesim.rrd"
DEFAULT_HOST, DEFAULT_WEB_PORT, DEFAULT_GRPC_PORT = "127.0.0.1", 9090, 9876
USAGE = "spawn | save FILE.rrd | serve"


class VizTargetError(ValueError):
    """A --viz value that names no viewer target; the message says what is valid."""


@dataclasses.dataclass(frozen=True)
class VizTarget:
    mode: str                   # spawn | save | serve
    path: str = DEFAULT_FILE    # the .rrd file for save (and for spawn's headless fallback)
    host: str = DEFAULT_HOST    # serve: the address both servers bind (loopback unless opened)
    port: int = DEFAULT_WEB_PORT        # serve: the web viewer's HTTP port
    grpc_port: int = DEFAULT_GRPC_PORT  # serve: the gRPC server's port (the recording's data)

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
        serve(rec, target, blueprint, warn)
    else:
        raise VizTargetError(f"unknown viewer mode '{target.mode}'; valid: {USAGE}")
    return rec, target


#: what to look at when a port is taken
WHO_HOLDS = "`ss -ltnp 'sport = :{port}'` or `lsof -i :{port}` shows the process holding it"


def check_port_free(host: str, port: int, option: str) -> None:
    """A VizTargetError naming the port, the option that picks another and how to find who holds it,
    when ``host:port`` cannot be bound (taken, or an address this machine does not have)."""
    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)
    except socket.gaierror as e:
        raise VizTargetError(f"--viz-host {host}: not an address of this machine ({e.strerror})") from None
    family, _, _, _, addr = infos[0]
    with socket.socket(family, socket.SOCK_STREAM) as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)    # a listener, not TIME_WAIT, makes it busy
        try:
            s.bind(addr)
        except OSError as e:
            if e.errno == errno.EADDRINUSE:
                raise VizTargetError(f"--viz serve: port {port} on {host} is already in use; choose another "
                                     f"with {option} PORT, or stop what holds it ({WHO_HOLDS.format(port=port)})"
                                     ) from None
            if e.errno in (errno.EACCES, errno.EPERM):
                raise VizTargetError(f"--viz serve: port {port} needs privileges here; choose one above 1023 "
                                     f"with {option} PORT") from None
            raise VizTargetError(f"--viz serve: cannot listen on {host}:{port} ({e.strerror or e}); "
                                 "--viz-host names an address of this machine (127.0.0.1, 0.0.0.0)") from None


def check_serve_ports(target: VizTarget) -> None:
    """Both of ``serve``'s ports free on its host (VizTargetError otherwise); a no-op for other modes."""
    if target.mode != "serve":
        return
    if target.port == target.grpc_port:
        raise VizTargetError(f"--viz-port and --viz-grpc-port are both {target.port}: give them different ports")
    check_port_free(target.host, target.grpc_port, "--viz-grpc-port")
    check_port_free(target.host, target.port, "--viz-port")


def _url_host(host: str) -> str:
    """The address a browser on this machine uses for a server bound to ``host``."""
    return "127.0.0.1" if host in ("0.0.0.0", "") else ("[::1]" if host == "::" else host)


def rerun_binary() -> str | None:
    """The rerun viewer binary shipped with rerun-sdk (rerun_cli), or $RERUN_CLI_PATH; None if absent."""
    if os.environ.get("RERUN_CLI_PATH"):
        return os.environ["RERUN_CLI_PATH"]
    try:
        import rerun_cli
    except ImportError:
        return None
    exe = Path(rerun_cli.__file__).parent / ("rerun.exe" if sys.platform.startswith("win") else "rerun")
    return str(exe) if exe.is_file() else None


def _die_with_parent():                     # Linux: the web viewer ends with this process, even killed
    try:
        import ctypes
        import signal
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGTERM)   # PR_SET_PDEATHSIG
    except Exception:  # noqa: BLE001  (not Linux: ended by stop_serving or at exit)
        pass


def _listening(host: str, port: int, timeout: float) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            with socket.create_connection((_url_host(host).strip("[]"), port), timeout=0.2):
                return True
        except OSError:
            time.sleep(0.05)
    return False


class Serving:
    """A ``serve`` target's servers: the recording's gRPC server (``url``; it lives as long as the
    recording is connected) and the web viewer process (None when none could start). ``stop()`` ends
    both (idempotent)."""

    def __init__(self, rec, url: str, web=None, web_url: str | None = None):
        self.rec, self.url, self.web, self.web_url = rec, url, web, web_url

    def stop(self) -> None:
        if self.web is not None:
            self.web.terminate()
            try:
                self.web.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.web.kill()
                self.web.wait()
            self.web = None
        if self.rec is not None:
            self.rec.flush()
            self.rec.disconnect()                    # shuts the gRPC server down
            self.rec = None


def serve(rec, target: VizTarget, blueprint=None, warn=lambda msg: sys.stderr.write(msg + "\n")) -> Serving:
    """Start ``target``'s gRPC server on ``rec`` and a web viewer reading it, both bound to ``target.host``
    (ports checked first: VizTargetError). Returns the :class:`Serving` (also ``rec._snakesim_serving``)."""
    import rerun as rr

    check_serve_ports(target)
    try:
        rec.set_sinks(rr.GrpcServerSink(target.host, target.grpc_port), default_blueprint=blueprint)
    except Exception as e:  # noqa: BLE001  (raised by the bindings; the port was free a moment ago)
        raise VizTargetError(f"--viz serve: cannot start the gRPC server on {target.host}:{target.grpc_port} "
                             f"({e}); choose another with --viz-grpc-port PORT") from None
    url = f"rerun+http://{_url_host(target.host)}:{target.grpc_port}/proxy"
    web = web_url = None
    exe = rerun_binary()
    if exe is not None:
        web = subprocess.Popen([exe, "--serve-web", "--bind", target.host, "--web-viewer-port", str(target.port),
                                url], stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL, preexec_fn=_die_with_parent if os.name == "posix" else None)
        if _listening(target.host, target.port, 10.0):
            web_url = f"http://{_url_host(target.host)}:{target.port}/?url={url}"
        else:
            web.terminate()
            web.wait()
            web = None
    serving = Serving(rec, url, web, web_url)
    rec._snakesim_serving = serving
    opened = "" if target.host in ("127.0.0.1", "localhost", "::1") else \
        f" (listening on {target.host}: reachable from other machines)"
    where = f"web viewer at {web_url}, " if web_url else "no web viewer (the rerun binary did not start); "
    warn(f"snakesim viz: serving the recording{opened}: {where}native viewer: `rerun --connect {url}`")
    return serving
