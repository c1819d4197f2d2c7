"""Who may talk to the project's Dask clusters: TLS, loopback-only local clusters, plug-ins on workers.

A Dask worker runs whatever its scheduler sends, and a scheduler runs whatever any client
submits, so an unauthenticated scheduler on a shared network is code execution for anyone
who can reach it. Hence:

* Certificates come from ``ExecutorConfig`` (``tls_ca_file``, ``tls_cert``, ``tls_key``, the
  CLI's ``--tls-ca-file/--tls-cert/--tls-key``) or, when none is given, from Dask's own
  configuration (``distributed.comm.tls.ca-file``, ``...tls.client.cert``/``key``, a Dask
  config file or ``DASK_DISTRIBUTED__COMM__TLS__...`` variables), mapped onto
  ``distributed.security.Security``.
* A ``tcp://`` scheduler that is not on loopback is refused unless ``insecure`` is set (a
  warning scrolls away while the cluster stays open to the subnet; a refusal makes the
  choice explicit). Loopback ``tcp://`` is allowed: only this machine's users reach it.
* The local cluster listens on 127.0.0.1 only; with ``tls`` it uses temporary certificates.
* Plug-ins (``module:Class``) must be importable on every worker: an installed package, or
  a file given in ``upload`` (``Client.upload_file``). ``check_worker_imports`` names the
  worker and the module that fails.
"""

from __future__ import annotations

import ipaddress
import logging
import socket
from pathlib import Path
from typing import TYPE_CHECKING

from roman_sim.core.errors import ConfigError, RomanSimError
from roman_sim.runner.executor_base import ExecutorConfig

if TYPE_CHECKING:
    from distributed import Client, LocalCluster
    from distributed.security import Security


log = logging.getLogger(__name__)

LOOPBACK = "127.0.0.1"


class PluginImportError(RomanSimError):
    """A Dask worker cannot import a plug-in module."""


def _file(path: str | None, field: str) -> str | None:
    if path is None:
        return None
    if not Path(path).is_file():
        raise ConfigError(f"executor.{field}: no such file {path!r}")
    return str(Path(path).resolve())


def _from_dask_config() -> dict[str, str | None]:
    import dask

    get = dask.config.get
    return {
        "ca": get("distributed.comm.tls.ca-file", None),
        "cert": get("distributed.comm.tls.client.cert", None),
        "key": get("distributed.comm.tls.client.key", None),
    }


def security_for(cfg: ExecutorConfig) -> Security | None:
    """The ``Security`` for ``cfg`` (None: plain tcp to loopback or an explicitly insecure address)."""
    from distributed.security import Security

    explicit = {
        "ca": _file(cfg.tls_ca_file, "tls_ca_file"),
        "cert": _file(cfg.tls_cert, "tls_cert"),
        "key": _file(cfg.tls_key, "tls_key"),
    }
    files = explicit if any(explicit.values()) else _from_dask_config()
    if cfg.scheduler_address is None:
        if any(explicit.values()):
            raise ConfigError(
                "executor.tls_*: certificates are for a remote scheduler (set scheduler_address); "
                "a local cluster with tls uses temporary certificates"
            )
        return Security.temporary() if cfg.tls else None
    remote_tls = cfg.scheduler_address.strip().startswith("tls://")
    if not remote_tls:
        if cfg.tls:
            raise ConfigError(
                f"executor.scheduler_address {cfg.scheduler_address!r}: tls is set, give a tls:// address"
            )
        return None
    if not files["ca"] or not files["cert"]:
        raise ConfigError(
            f"executor.scheduler_address {cfg.scheduler_address!r}: a tls:// scheduler needs a CA "
            "and a client certificate (--tls-ca-file, --tls-cert [--tls-key], or Dask's config "
            "distributed.comm.tls.ca-file / distributed.comm.tls.client.cert)"
        )
    return Security(
        tls_ca_file=files["ca"], tls_client_cert=files["cert"], tls_client_key=files["key"], require_encryption=True
    )


def is_loopback(host: str) -> bool:
    """Whether every address ``host`` resolves to is a loopback address (False when it does not resolve)."""
    try:
        infos = socket.getaddrinfo(host.strip("[]"), None)
    except (OSError, UnicodeError):
        return False
    return bool(infos) and all(ipaddress.ip_address(str(i[4][0]).split("%")[0]).is_loopback for i in infos)


def check_address(address: str, cfg: ExecutorConfig, security: Security | None) -> str:
    """``address`` normalised; ConfigError for a malformed one or an unauthenticated non-loopback one."""
    from distributed.comm.addressing import parse_address, parse_host_port

    addr = address.strip()
    if "://" not in addr:
        addr = f"tcp://{addr}"
    try:
        scheme, loc = parse_address(addr)
        host, port = parse_host_port(loc)
    except (ValueError, TypeError) as err:
        raise ConfigError(f"executor.scheduler_address {address!r}: expected tls://host:port ({err})") from None
    if scheme not in ("tcp", "tls") or not host or not 0 < int(port) < 65536:
        raise ConfigError(f"executor.scheduler_address {address!r}: expected tls://host:port or tcp://host:port")
    if scheme == "tcp" and not is_loopback(host):
        if not cfg.insecure:
            raise ConfigError(
                f"executor.scheduler_address {address!r}: plain tcp:// to a host that is not on "
                "loopback is unauthenticated (anyone who reaches the scheduler runs code on its "
                "workers); use tls:// with certificates, or pass --insecure to accept that"
            )
        log.warning("Dask scheduler %s: unauthenticated tcp:// connection (--insecure)", address)
    return addr


def local_cluster(cfg: ExecutorConfig, security: Security | None) -> LocalCluster:
    """A ``LocalCluster`` on 127.0.0.1: one single-threaded process per worker, dashboard off unless asked.

    The scheduler always serves HTTP (health and metrics); it is bound to 127.0.0.1 on a free
    port, and the dashboard's pages are only added with ``dashboard``. Workers bind to
    127.0.0.1 as well.
    """
    from distributed import LocalCluster

    return LocalCluster(
        n_workers=cfg.n_workers(),
        threads_per_worker=1,
        processes=True,
        host=LOOPBACK,
        protocol="tls://" if security is not None else "tcp://",
        security=security,
        dashboard_address=f"{LOOPBACK}:0",
        scheduler_kwargs={"dashboard": cfg.dashboard},
        worker_dashboard_address=None,
        silence_logs=logging.WARNING,
    )


def upload(client: Client, path: str) -> None:
    """Send a plug-in file (.py, .zip, .egg) to every worker; ConfigError when it is missing or fails."""
    p = Path(path)
    if not p.is_file() or p.suffix not in (".py", ".zip", ".egg"):
        raise ConfigError(f"executor.upload {path!r}: not a .py, .zip or .egg file")
    try:
        client.upload_file(str(p.resolve()), load=True)
    except Exception as err:  # the worker's import error, of any type
        raise PluginImportError(
            f"executor.upload {path!r}: a worker could not load it: {type(err).__name__}: "
            f"{' '.join(str(err).split())[:200]}"
        ) from None


def _try_imports(modules: list[str]) -> dict[str, str]:
    """On a worker: module -> error text for every module that does not import."""
    import importlib

    failed = {}
    for m in modules:
        try:
            importlib.import_module(m)
        except Exception as err:  # ImportError or an error raised while importing
            failed[m] = f"{type(err).__name__}: {err}"
    return failed


def check_worker_imports(client: Client, modules: list[str]) -> None:
    """PluginImportError naming the first worker and module that cannot be imported."""
    if not modules:
        return
    per_worker = client.run(_try_imports, sorted(set(modules)))
    for worker, failed in sorted(per_worker.items()):
        for module, why in sorted(failed.items()):
            raise PluginImportError(
                f"Dask worker {worker} cannot import plug-in module {module!r} ({why}); install it on the "
                f"workers or ship it with --upload {module.replace('.', '/')}.py"
            )
