"""The executor options shared by ``run``, ``demo``, ``reproduce`` and ``sweep``."""

from __future__ import annotations

from typing import Any

import typer

EXECUTOR = typer.Option(None, "--executor", help="serial, local (process pool) or dask")
WORKERS = typer.Option(None, "--workers", "-j", help="processes / local Dask workers (default: cores)")
SCHEDULER = typer.Option(None, "--scheduler", help="Dask scheduler address, e.g. tls://host:8786 (implies dask)")
CHUNK = typer.Option(None, "--chunk-pairs", help="submap pairs per alignment task (default 32)")
TLS = typer.Option(False, "--tls", help="local Dask cluster over TLS (temporary certificates)")
TLS_CA = typer.Option(None, "--tls-ca-file", help="CA certificate (PEM) of the Dask cluster")
TLS_CERT = typer.Option(None, "--tls-cert", help="client certificate (PEM) for the Dask cluster")
TLS_KEY = typer.Option(None, "--tls-key", help="client private key (PEM)")
INSECURE = typer.Option(False, "--insecure", help="allow plain tcp:// to a scheduler that is not on loopback")
DASHBOARD = typer.Option(False, "--dashboard", help="local Dask cluster: serve the dashboard on 127.0.0.1")
UPLOAD = typer.Option(None, "--upload", help="plug-in file (.py/.zip/.egg) to send to every Dask worker")


def executor_config(
    base: dict[str, Any] | None,
    kind: str | None,
    workers: int | None,
    scheduler: str | None,
    chunk: int | None,
    tls: bool,
    ca: str | None,
    cert: str | None,
    key: str | None,
    insecure: bool,
    dashboard: bool,
    upload: list[str] | None,
) -> Any:
    """An ``ExecutorConfig``: ``base`` (a sweep file's, or the CLI default: local pool) with the options set."""
    from roman_sim.core.config import validate_model
    from roman_sim.runner.executors import ExecutorConfig

    data: dict[str, Any] = dict(base) if base is not None else {"kind": "local"}
    given: dict[str, Any] = {
        "kind": kind,
        "workers": workers,
        "scheduler_address": scheduler,
        "chunk_pairs": chunk,
        "tls_ca_file": ca,
        "tls_cert": cert,
        "tls_key": key,
    }
    data.update({k: v for k, v in given.items() if v is not None})
    for flag, value in (("tls", tls), ("insecure", insecure), ("dashboard", dashboard)):
        if value:
            data[flag] = True
    if upload:
        data["upload"] = list(data.get("upload") or []) + list(upload)
    if scheduler is not None and kind is None:
        data["kind"] = "dask"
    return validate_model(ExecutorConfig, data, source="executor")
