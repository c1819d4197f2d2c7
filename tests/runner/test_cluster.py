"""Dask connections: a bounded handshake and one line for every endpoint that is not a scheduler.

The endpoints are real local servers started by the test: a socket that accepts and never
answers, an HTTP server, one that sends random bytes, one that sends a plausible length and
then garbage, a closed port; and a real loopback ``LocalCluster`` (its scheduler connects,
its worker is refused). The timeout marker guards against hangs; no duration is asserted.
"""

from __future__ import annotations

import http.server
import socket
import struct
import threading
from collections.abc import Callable, Iterator

import numpy as np
import pytest
import yaml

from roman_sim.core.errors import ClusterError, ConfigError
from roman_sim.runner.cluster import connect, parse_scheduler_address

pytestmark = pytest.mark.timeout(120)
T = 1.0  # handshake bound used in these tests (s)


def _serve(handler: Callable[[socket.socket], None]) -> Iterator[int]:
    """A loopback TCP server running ``handler`` on every accepted connection; yields its port."""
    srv = socket.create_server(("127.0.0.1", 0))
    keep: list[socket.socket] = []
    stop = threading.Event()

    def loop() -> None:
        while not stop.is_set():
            try:
                conn, _ = srv.accept()
            except OSError:
                return
            keep.append(conn)
            handler(conn)

    threading.Thread(target=loop, daemon=True).start()
    yield srv.getsockname()[1]
    stop.set()
    srv.close()
    for c in keep:
        c.close()


@pytest.fixture
def silent_port() -> Iterator[int]:
    yield from _serve(lambda conn: None)  # accepts and never answers


@pytest.fixture
def junk_port() -> Iterator[int]:
    data = np.random.default_rng(0).bytes(256)
    yield from _serve(lambda conn: conn.sendall(data))


@pytest.fixture
def plausible_junk_port() -> Iterator[int]:
    body = np.random.default_rng(1).bytes(40)
    yield from _serve(lambda conn: conn.sendall(struct.pack("Q", len(body)) + body))


@pytest.fixture
def http_port() -> Iterator[int]:
    class Quiet(http.server.BaseHTTPRequestHandler):
        def do_GET(self) -> None:
            self.send_response(200)
            self.end_headers()
            self.wfile.write(b"<html>dashboard</html>")

        def log_message(self, *args: object) -> None:
            pass

    class Server(http.server.ThreadingHTTPServer):
        def handle_error(self, request: object, client_address: object) -> None:
            pass

    srv = Server(("127.0.0.1", 0), Quiet)
    threading.Thread(target=srv.serve_forever, daemon=True).start()
    yield srv.server_address[1]
    srv.shutdown()
    srv.server_close()


@pytest.fixture
def closed_port() -> int:
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


@pytest.fixture(scope="module")
def local_cluster() -> Iterator[object]:
    from distributed import LocalCluster

    cluster = LocalCluster(
        n_workers=1, threads_per_worker=1, processes=False, protocol="tcp", host="127.0.0.1", dashboard_address=":0"
    )  # a free port: 8787 may be taken
    yield cluster
    cluster.close()


def _fails(address: str, **kw: object) -> str:
    with pytest.raises(ClusterError) as e:
        connect(address, **kw)
    assert "\n" not in str(e.value)
    return str(e.value)


def test_a_port_that_never_answers(silent_port: int) -> None:
    msg = _fails(f"tcp://127.0.0.1:{silent_port}", timeout_s=T)
    assert msg == (
        f"Dask scheduler 'tcp://127.0.0.1:{silent_port}': 127.0.0.1:{silent_port} accepted the "
        "connection but sent no Dask handshake within 1 s (not a Dask scheduler?)"
    )


def test_an_http_server(http_port: int) -> None:
    msg = _fails(f"127.0.0.1:{http_port}", timeout_s=T)
    assert f"127.0.0.1:{http_port} is an HTTP server, not a Dask scheduler" in msg


def test_random_bytes_give_no_huge_allocation(junk_port: int) -> None:
    head = np.random.default_rng(0).bytes(8)
    msg = _fails(f"tcp://127.0.0.1:{junk_port}", timeout_s=T)
    announced = struct.unpack("Q", head)[0]
    assert f"does not speak the Dask protocol: its first bytes ({head.hex()}) announce a {announced}-byte" in msg


def test_a_plausible_length_then_garbage(plausible_junk_port: int) -> None:
    msg = _fails(f"tcp://127.0.0.1:{plausible_junk_port}", timeout_s=T)
    assert "answered with bytes that are not a Dask handshake" in msg


def test_a_closed_port(closed_port: int) -> None:
    msg = _fails(f"tcp://127.0.0.1:{closed_port}", timeout_s=T)
    assert msg.endswith(f"nothing listens on 127.0.0.1:{closed_port} (connection refused)")


@pytest.mark.parametrize(
    ("address", "expect"),
    [
        ("not-a-url", "not an address (expected tcp://host:port, e.g. tcp://10.0.0.5:8786): missing port number"),
        ("http://127.0.0.1:8787", "unknown scheme 'http' (a dashboard URL?"),
        ("tcp://127.0.0.1", "missing port number"),
        ("tcp://127.0.0.1:0", "host and a port in 1..65535 needed"),
        ("tcp://127.0.0.1:70000", "host and a port in 1..65535 needed"),
        ("", "empty address"),
    ],
)
def test_malformed_addresses(address: str, expect: str) -> None:
    with pytest.raises(ConfigError) as e:
        parse_scheduler_address(address)
    assert expect in str(e.value)
    with pytest.raises(ConfigError):
        connect(address, timeout_s=T)


def test_bad_timeout() -> None:
    with pytest.raises(ConfigError, match="timeout_s: expected a positive number of seconds, got 0"):
        connect("tcp://127.0.0.1:8786", timeout_s=0)


def test_a_real_scheduler_connects_and_a_worker_is_refused(local_cluster) -> None:
    client = connect(local_cluster.scheduler_address, timeout_s=5.0)
    try:
        assert client.submit(lambda x: x * 7, 6).result() == 42
    finally:
        client.close()
    worker = next(iter(local_cluster.workers.values())).address
    msg = _fails(worker, timeout_s=5.0)
    assert msg.endswith("that is a Dask Worker, not a scheduler (give the scheduler's address, by default port 8786)")


def test_sweep_cli_reports_a_bad_scheduler_in_one_line(tmp_path, silent_port: int, cli_fails) -> None:
    path = tmp_path / "sweep.yaml"
    path.write_text(
        yaml.safe_dump(
            {"name": "s", "scenario": "smoke", "seeds": [0], "executor": {"kind": "dask", "connect_timeout_s": T}}
        )
    )
    line = cli_fails("sweep", path, "--scheduler", "not-a-url", "--out", tmp_path / "o")
    assert "scheduler_address: Dask scheduler 'not-a-url': not an address" in line
    line = cli_fails("sweep", path, "--scheduler", f"tcp://127.0.0.1:{silent_port}", "--out", tmp_path / "o")
    assert "sent no Dask handshake within 1 s" in line
