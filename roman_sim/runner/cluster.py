"""Connecting to a Dask scheduler with a bounded handshake and one clear line per failure.

``connect(address, timeout_s)`` returns a ``distributed.Client`` or raises ``ClusterError``
within about ``timeout_s`` seconds. ``distributed`` itself can hang or crash on endpoints
that are not schedulers: its client waits without a deadline for the handshake of a port
that accepts and never answers, and reads the first eight bytes of any answer as a message
length, so an HTTP server ("HTTP/1.1" is 3.5e18) or random bytes make it allocate exabytes.
Hence a plain-socket probe first: a Dask server sends its handshake (an 8-byte length, then
a small msgpack message) as soon as it accepts a connection, so the probe reads at most a
few kilobytes, decodes them with ``distributed.protocol`` and only then hands the address
to ``Client``. Non-TCP schemes (``tls://``, ``ws://``, ...) are not probed (their transport
speaks first); ``Client``'s own timeout bounds them.
"""

from __future__ import annotations

import logging
import socket
import struct
import time
from typing import TYPE_CHECKING

from roman_sim.core.errors import ClusterError, ConfigError

if TYPE_CHECKING:
    import distributed
    from distributed.security import Security

log = logging.getLogger(__name__)

#: Default bound on reaching a scheduler and completing its handshake (seconds).
DEFAULT_TIMEOUT_S = 5.0
_MAX_HANDSHAKE = 64 * 1024  # a Dask handshake is about 60 bytes
_HTTP_PROBE = b"GET / HTTP/1.0\r\n\r\n"
_EXPECTED = "expected tcp://host:port, e.g. tcp://10.0.0.5:8786"


def parse_scheduler_address(address: str) -> tuple[str, str, int | None]:
    """(scheme, host, port) of a scheduler address (port None for schemes without one); ``ConfigError`` if malformed."""
    from distributed.comm.addressing import parse_address, parse_host_port
    from distributed.comm.registry import backends

    if not isinstance(address, str) or not address.strip():
        raise ConfigError(f"Dask scheduler {address!r}: empty address ({_EXPECTED})")
    try:
        scheme, loc = parse_address(address.strip())
    except (ValueError, TypeError) as err:
        raise ConfigError(f"Dask scheduler {address!r}: not an address ({_EXPECTED}): {err}") from None
    if scheme not in backends:
        hint = " (a dashboard URL? the scheduler itself listens on tcp://host:8786)" if "http" in scheme else ""
        raise ConfigError(
            f"Dask scheduler {address!r}: unknown scheme {scheme!r}{hint} (valid: {', '.join(sorted(backends))})"
        )
    if scheme in ("inproc", "ucx"):
        return scheme, loc, None
    try:
        host, port = parse_host_port(loc)
    except (ValueError, TypeError) as err:
        raise ConfigError(f"Dask scheduler {address!r}: not an address ({_EXPECTED}): {err}") from None
    if not host or not 0 < int(port) < 65536:
        raise ConfigError(f"Dask scheduler {address!r}: host and a port in 1..65535 needed ({_EXPECTED})")
    return scheme, host, int(port)


def connect(address: str, timeout_s: float = DEFAULT_TIMEOUT_S) -> "distributed.Client":
    """A ``distributed.Client`` connected to the scheduler at ``address``.

    Args:
        address: scheduler address, ``tcp://host:port`` (``host:port`` means tcp).
        timeout_s: bound on reaching it and completing the handshake (seconds, > 0).

    Raises:
        ConfigError: ``address`` is not a scheduler address or ``timeout_s`` is not positive.
        ClusterError: nothing listens there, it does not answer in time, it answers with
            something other than the Dask protocol (an HTTP server, random bytes), or it is
            a Dask server but not a scheduler.
    """
    if not isinstance(timeout_s, (int, float)) or not 0 < timeout_s < float("inf"):
        raise ConfigError(f"timeout_s: expected a positive number of seconds, got {timeout_s!r}")
    scheme, host, port = parse_scheduler_address(address)
    if scheme == "tcp" and port is not None:
        probe_scheduler(address, host, port, timeout_s)
    kind = server_type(address.strip(), timeout_s)
    if kind != "Scheduler":
        raise ClusterError(
            f"Dask scheduler {address!r}: that is a Dask {kind}, not a scheduler "
            "(give the scheduler's address, by default port 8786)"
        )
    try:
        client = start_client(address.strip(), timeout_s)
    except Exception as err:  # distributed re-raises the remote side's errors, of any type
        raise ClusterError(
            f"Dask scheduler {address!r}: cannot connect: {type(err).__name__}: {' '.join(str(err).split())[:200]}"
        ) from None
    log.info("connected to the Dask scheduler at %s", address)
    return client


def start_client(address: str, timeout_s: float, security: "Security | None" = None) -> "distributed.Client":
    """A ``distributed.Client`` connected to ``address``; one that fails to connect is closed before the error.

    A ``Client`` whose constructor raises is left half started, its event loop running, for
    the garbage collector to close at some later moment. If that moment falls while the next
    ``Client`` starts its loop, the process deadlocks: starting and closing take the same
    non-reentrant lock of ``distributed`` (``LoopRunner._lock``), and the collector runs
    inside the thread that holds it. Closing the refused client here, at once, leaves the
    collector nothing to close.

    Raises:
        Exception: whatever ``distributed`` raised (callers word the message).
    """
    from distributed import Client

    client = Client.__new__(Client)
    try:
        Client.__init__(client, address, timeout=f"{timeout_s}s", security=security, set_as_default=False)
    except BaseException:
        _close_refused(client, timeout_s)
        raise
    return client


def _close_refused(client: "distributed.Client", timeout_s: float) -> None:
    """Close a client whose start failed; errors of closing are logged, not raised."""
    try:
        client.close(timeout=timeout_s)
    except Exception as err:  # a client that failed early may lack what closing touches
        log.debug("closing a refused Dask client: %s: %s", type(err).__name__, err)


def server_type(address: str, timeout_s: float) -> str:
    """The ``type`` a Dask server at ``address`` reports (``Scheduler``, ``Worker``, ``Nanny``), within ``timeout_s``.

    Runs ``identity`` over ``distributed.core.rpc`` on an event loop of its own (in a worker
    thread, so it also works when the caller runs an event loop); ``ClusterError`` when it
    fails or takes longer.
    """
    import asyncio
    from concurrent.futures import ThreadPoolExecutor
    from concurrent.futures import TimeoutError as FutureTimeout

    from distributed.core import rpc

    async def identity() -> object:
        async with rpc(address, timeout=timeout_s) as remote:
            return await asyncio.wait_for(remote.identity(), timeout_s)

    pool = ThreadPoolExecutor(max_workers=1)
    try:
        info = pool.submit(asyncio.run, identity()).result(timeout=2 * timeout_s)
    except (FutureTimeout, TimeoutError):
        raise ClusterError(f"Dask scheduler {address!r}: no reply to 'identity' within {timeout_s:g} s") from None
    except Exception as err:  # the remote side's error, or a transport error, of any type
        raise ClusterError(
            f"Dask scheduler {address!r}: 'identity' failed: {type(err).__name__}: {' '.join(str(err).split())[:200]}"
        ) from None
    finally:
        pool.shutdown(wait=False, cancel_futures=True)
    kind = info.get("type") if isinstance(info, dict) else None
    return str(kind) if kind else "server of unknown type"


def probe_scheduler(address: str, host: str, port: int, timeout_s: float) -> None:
    """Check within ``timeout_s`` that ``host:port`` opens with a Dask handshake; ``ClusterError`` if not."""
    deadline = time.monotonic() + timeout_s
    try:
        sock = socket.create_connection((host, port), timeout=timeout_s)
    except socket.gaierror as err:
        raise ClusterError(f"Dask scheduler {address!r}: unknown host {host!r} ({err.strerror})") from None
    except ConnectionRefusedError:
        raise ClusterError(
            f"Dask scheduler {address!r}: nothing listens on {host}:{port} (connection refused)"
        ) from None
    except TimeoutError:
        raise ClusterError(f"Dask scheduler {address!r}: no answer from {host}:{port} within {timeout_s:g} s") from None
    except OSError as err:
        raise ClusterError(f"Dask scheduler {address!r}: cannot reach {host}:{port} ({err.strerror or err})") from None
    with sock:
        head, closed = _recv(sock, 8, min(deadline, time.monotonic() + timeout_s / 2))
        if not head and not closed:
            _send_quietly(sock, _HTTP_PROBE)  # a Dask server speaks first; an HTTP server answers a request
            head, closed = _recv(sock, 8, deadline)
        _check_head(address, host, port, head, closed, timeout_s)
        (n,) = struct.unpack("Q", head)
        body, _ = _recv(sock, n, deadline)
        if len(body) < n:
            raise ClusterError(
                f"Dask scheduler {address!r}: {host}:{port} stopped after {len(body)} of the "
                f"{n} handshake bytes it announced (not a Dask scheduler?)"
            )
    _check_body(address, host, port, body)


def _check_head(address: str, host: str, port: int, head: bytes, closed: bool, timeout_s: float) -> None:
    where = f"Dask scheduler {address!r}: {host}:{port}"
    if head.startswith(b"HTTP/"):
        raise ClusterError(
            f"{where} is an HTTP server, not a Dask scheduler (the dashboard? the scheduler "
            "listens on tcp://host:8786 by default)"
        )
    if not head and closed:
        raise ClusterError(f"{where} closed the connection without a Dask handshake (not a Dask scheduler?)")
    if not head:
        raise ClusterError(
            f"{where} accepted the connection but sent no Dask handshake within {timeout_s:g} s (not a Dask scheduler?)"
        )
    if len(head) < 8:
        raise ClusterError(f"{where} sent {len(head)} bytes ({head[:8].hex()}) and then nothing: not a Dask handshake")
    (n,) = struct.unpack("Q", head)
    if not 8 <= n <= _MAX_HANDSHAKE:
        raise ClusterError(
            f"{where} does not speak the Dask protocol: its first bytes ({head.hex()}) announce a {n}-byte message"
        )


def _check_body(address: str, host: str, port: int, body: bytes) -> None:
    from distributed.protocol import loads
    from distributed.protocol.utils import unpack_frames

    try:
        frames, missing = unpack_frames(body, partial=True)
        msg = None if missing else loads(frames, deserialize=False)
    except Exception:  # garbage that merely looked like a length: reported below
        msg = None
    if not isinstance(msg, dict) or "pickle-protocol" not in msg:
        raise ClusterError(
            f"Dask scheduler {address!r}: {host}:{port} answered with bytes that are not a Dask "
            "handshake (not a Dask scheduler?)"
        )


def _recv(sock: socket.socket, n: int, deadline: float) -> tuple[bytes, bool]:
    """(up to ``n`` bytes received before ``deadline``, whether the peer closed the connection)."""
    buf = bytearray()
    while len(buf) < n:
        left = deadline - time.monotonic()
        if left <= 0:
            break
        sock.settimeout(left)
        try:
            chunk = sock.recv(min(n - len(buf), 65536))
        except TimeoutError:
            break
        except OSError:
            return bytes(buf), True
        if not chunk:
            return bytes(buf), True
        buf.extend(chunk)
    return bytes(buf), False


def _send_quietly(sock: socket.socket, data: bytes) -> None:
    try:
        sock.sendall(data)
    except OSError:
        pass
