"""The executor options, declared once and shared by every command that runs stages.

A command decorated with ``executor_options`` gets the flags ``--executor --workers
--scheduler --chunk-pairs --tls --tls-ca-file --tls-cert --tls-key --insecure --dashboard
--upload`` and receives them as one ``flags: ExecutorFlags = NO_FLAGS`` argument, whose ``config()``
is the ``ExecutorConfig`` to run with.
"""

from __future__ import annotations

import dataclasses
import functools
import inspect
from collections.abc import Callable
from typing import Any, TypeVar

import typer

F = TypeVar("F", bound=Callable[..., Any])


@dataclasses.dataclass(frozen=True)
class ExecutorFlags:
    """The executor options as given on the command line (None / False: not given)."""

    executor: str | None = None
    workers: int | None = None
    scheduler: str | None = None
    chunk_pairs: int | None = None
    tls: bool = False
    tls_ca_file: str | None = None
    tls_cert: str | None = None
    tls_key: str | None = None
    insecure: bool = False
    dashboard: bool = False
    upload: list[str] | None = None

    def config(self, base: dict[str, Any] | None = None) -> Any:
        """An ``ExecutorConfig``: ``base`` (a sweep file's, or the CLI default: local pool) with the options set."""
        from roman_sim.core.config import validate_model
        from roman_sim.runner.executors import ExecutorConfig

        data: dict[str, Any] = dict(base) if base is not None else {"kind": "local"}
        given: dict[str, Any] = {
            "kind": self.executor,
            "workers": self.workers,
            "scheduler_address": self.scheduler,
            "chunk_pairs": self.chunk_pairs,
            "tls_ca_file": self.tls_ca_file,
            "tls_cert": self.tls_cert,
            "tls_key": self.tls_key,
        }
        data.update({k: v for k, v in given.items() if v is not None})
        for flag, value in (("tls", self.tls), ("insecure", self.insecure), ("dashboard", self.dashboard)):
            if value:
                data[flag] = True
        if self.upload:
            data["upload"] = list(data.get("upload") or []) + list(self.upload)
        if self.scheduler is not None and self.executor is None:
            data["kind"] = "dask"
        return validate_model(ExecutorConfig, data, source="executor")


#: What a command's ``flags`` parameter defaults to (the decorator always passes the given ones).
NO_FLAGS = ExecutorFlags()

#: The options' declarations: parameter name -> (type, typer option).
_OPTIONS: dict[str, tuple[Any, Any]] = {
    "executor": (str | None, typer.Option(None, "--executor", help="serial, local (process pool) or dask")),
    "workers": (
        int | None,
        typer.Option(None, "--workers", "-j", help="processes / local Dask workers (default: cores)"),
    ),
    "scheduler": (
        str | None,
        typer.Option(None, "--scheduler", help="Dask scheduler address, e.g. tls://host:8786 (implies dask)"),
    ),
    "chunk_pairs": (
        int | None,
        typer.Option(None, "--chunk-pairs", help="submap pairs per alignment task (default 32)"),
    ),
    "tls": (bool, typer.Option(False, "--tls", help="local Dask cluster over TLS (temporary certificates)")),
    "tls_ca_file": (str | None, typer.Option(None, "--tls-ca-file", help="CA certificate (PEM) of the Dask cluster")),
    "tls_cert": (str | None, typer.Option(None, "--tls-cert", help="client certificate (PEM) for the Dask cluster")),
    "tls_key": (str | None, typer.Option(None, "--tls-key", help="client private key (PEM)")),
    "insecure": (
        bool,
        typer.Option(False, "--insecure", help="allow plain tcp:// to a scheduler that is not on loopback"),
    ),
    "dashboard": (
        bool,
        typer.Option(False, "--dashboard", help="local Dask cluster: serve the dashboard on 127.0.0.1"),
    ),
    "upload": (
        list[str] | None,
        typer.Option(None, "--upload", help="plug-in file (.py/.zip/.egg) to send to every Dask worker"),
    ),
}


def executor_options(fn: F) -> F:
    """Add the executor options to the command ``fn``, which takes them as its ``flags`` argument."""
    sig = inspect.signature(fn)
    if "flags" not in sig.parameters:
        raise TypeError(f"{fn.__name__}: an executor_options command takes a 'flags' parameter")
    own = [p for p in sig.parameters.values() if p.name != "flags"]
    added = [
        inspect.Parameter(name, inspect.Parameter.KEYWORD_ONLY, default=option, annotation=kind)
        for name, (kind, option) in _OPTIONS.items()
    ]

    @functools.wraps(fn)
    def command(*args: Any, **kwargs: Any) -> Any:
        flags = ExecutorFlags(**{name: kwargs.pop(name) for name in _OPTIONS})
        return fn(*args, flags=flags, **kwargs)

    command.__signature__ = sig.replace(parameters=[*own, *added])  # type: ignore[attr-defined]
    annotations = {k: v for k, v in fn.__annotations__.items() if k != "flags"}
    command.__annotations__ = {**annotations, **{name: kind for name, (kind, _) in _OPTIONS.items()}}
    return command  # type: ignore[return-value]
