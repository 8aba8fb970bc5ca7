"""--viz serve: loopback by default, busy ports said clearly, servers stopped (none left open by the suite)."""

import socket
import time

import pytest

from viz_scenes import SCENE

SHORT = ["--set", "robot.modules=2", "--duration", "0.05", "--quiet"]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _listener(host="127.0.0.1"):
    s = socket.socket()
    s.bind((host, 0))
    s.listen()
    return s


def test_a_busy_port_names_itself_and_the_option():
    from snakesim.components.viz.target import VizTargetError, check_port_free

    with _listener() as busy:
        port = busy.getsockname()[1]
        with pytest.raises(VizTargetError, match=f"port {port} on 127.0.0.1 is already in use; choose another "
                                                 "with --viz-port PORT") as e:
            check_port_free("127.0.0.1", port, "--viz-port")
        assert f"lsof -i :{port}" in str(e.value)


def test_run_with_a_busy_port_is_an_error_not_a_traceback(cli_runner):
    with _listener() as busy:
        port = busy.getsockname()[1]
        res = cli_runner("run", SCENE, *SHORT, "--viz", "serve", "--viz-grpc-port", port,
                         "--viz-port", _free_port())
    assert res.exit_code != 0
    assert f"port {port} on 127.0.0.1 is already in use; choose another with --viz-grpc-port PORT" in res.output
    assert "Traceback" not in res.output


@pytest.mark.parametrize("args, said", [
    (["--viz-host", "0.0.0.0"], "need --viz serve"),
    (["--viz", "save", "x.rrd", "--viz-port", "9191"], "--viz-port only apply to --viz serve"),
])
def test_serve_options_need_serve(tmp_path, monkeypatch, cli_runner, args, said):
    monkeypatch.chdir(tmp_path)
    res = cli_runner("run", SCENE, *SHORT, *args)
    assert res.exit_code != 0 and said in res.output, res.output


def test_serve_binds_loopback_and_stops():
    """A short-lived server: both ports on 127.0.0.1, closed again by stop()."""
    import rerun as rr

    from snakesim.components.viz.target import VizTarget, VizTargetError, check_serve_ports, serve

    target = VizTarget("serve", port=_free_port(), grpc_port=_free_port())
    said = []
    rec = rr.RecordingStream("snakesim-test")
    serving = serve(rec, target, warn=said.append)
    try:
        assert serving.url == f"rerun+http://127.0.0.1:{target.grpc_port}/proxy"
        assert "reachable from other machines" not in said[0] and "Ctrl-C" not in said[0]
        socket.create_connection(("127.0.0.1", target.grpc_port), timeout=2).close()
        if serving.web is not None:
            socket.create_connection(("127.0.0.1", target.port), timeout=2).close()
        # bound to loopback only: the machine's other addresses refuse (when it has one)
        other = _outward_address()
        if other is not None:
            with pytest.raises(OSError):
                socket.create_connection((other, target.grpc_port), timeout=1).close()
    finally:
        serving.stop()
    # both free again: the servers' threads let go of their sockets shortly after stop() returns
    deadline = time.monotonic() + 10
    while True:
        try:
            check_serve_ports(target)
            break
        except VizTargetError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.1)


def _outward_address():
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            s.connect(("192.0.2.1", 9))     # no packet is sent: picks the interface a route would use
            addr = s.getsockname()[0]
    except OSError:
        return None
    return None if addr.startswith("127.") else addr


def test_a_run_without_a_terminal_stops_its_servers(cli_runner):
    """Under the tests (no tty) a served run ends with its servers stopped, and says why."""
    from snakesim.components.viz.target import VizTarget, check_serve_ports

    target = VizTarget("serve", port=_free_port(), grpc_port=_free_port())
    res = cli_runner("run", SCENE, *SHORT, "--viz", "serve", "--viz-port", target.port,
                     "--viz-grpc-port", target.grpc_port)
    assert res.exit_code == 0, res.output
    assert "the servers stop now" in res.stderr
    check_serve_ports(target)
