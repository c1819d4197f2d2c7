"""The error family. The CLI turns any ``RomanSimError`` into one line and exit code 1.

An error raised in a worker process (a local pool's or a Dask worker) reaches the caller
pickled, without the exceptions behind it (a plug-in's own, with the file and line of its
bug). The worker keeps their text on the error (``keep_worker_traceback``: an attribute,
which pickling keeps), and ``format_chain`` shows it where the chain ends.
"""

from __future__ import annotations

import traceback

#: What ``format_chain`` puts between an exception and the one that reported it.
REPORTED_AS = "\nwhich was reported as:\n\n"
#: The attribute that carries, across processes, the tracebacks behind an error raised in a worker.
WORKER_TRACEBACK = "worker_traceback"


class RomanSimError(Exception):
    """Base class of every error the package raises on purpose (bad input, bad state)."""


class ConfigError(RomanSimError):
    """A configuration value, file or name is invalid; the message names the field."""


class WorldError(RomanSimError):
    """A world cannot be generated, built, exported or loaded."""


class SimError(RomanSimError):
    """Robots, cameras, paths, rendering or odometry cannot do what was asked."""


class RecordingError(RomanSimError):
    """A recording is missing, corrupt or of an unknown version."""


class MappingError(RomanSimError):
    """Segmentation, tracking or submap construction failed on its input."""


class StorageError(RomanSimError):
    """A saved map, submap or result file is missing, corrupt or of a wrong version."""


class AlignmentError(RomanSimError):
    """An aligner is unknown or misconfigured (bad pairs give a failed result, not this)."""


class EvaluationError(RomanSimError):
    """Evaluation inputs are missing or inconsistent."""


class ClusterError(RomanSimError):
    """A Dask scheduler cannot be reached in time, or the address is not a Dask scheduler."""


class RunFolderBusy(RomanSimError):
    """Another live run holds the lock of the results folder (the message names its pid)."""


class PluginError(ConfigError):
    """A user plug-in (``package.module:Class``) failed: import, construction, protocol, dry call or a call in a run.

    A ``ConfigError``: the configuration names a plug-in that does not work.

    Attributes:
        plugin: the plug-in's ``package.module:Class`` path.
        kind: ``aligner``, ``segmenter`` or ``encoder``.
    """

    def __init__(self, message: str, plugin: str = "", kind: str = "") -> None:
        super().__init__(message)
        self.plugin, self.kind = plugin, kind


def format_chain(err: BaseException) -> str:
    """The tracebacks of ``err`` and of every exception behind it, the first cause first.

    A cause is followed through ``raise ... from err`` and through the context a
    ``raise ... from None`` hid, so a plug-in's own exception and line are shown; an error
    raised in a worker process shows the tracebacks the worker kept (``keep_worker_traceback``)
    in place of what lies behind it.
    """
    chain: list[BaseException] = []
    e: BaseException | None = err
    while e is not None and all(e is not c for c in chain):
        chain.append(e)
        if isinstance(getattr(e, WORKER_TRACEBACK, None), str):
            break
        e = e.__cause__ or e.__context__
    parts = ["".join(traceback.format_exception(x, chain=False)) for x in reversed(chain)]
    behind = getattr(chain[-1], WORKER_TRACEBACK, None)
    if isinstance(behind, str):
        parts.insert(0, behind)
    return REPORTED_AS.join(parts)


def keep_worker_traceback(err: BaseException, behind: BaseException | None = None) -> BaseException:
    """``err`` carrying the tracebacks of ``behind`` (default: ``err`` itself) and of what lies behind it
    as text, so they survive the trip from a worker process to the caller; returns ``err``.

    Text already kept (an error passed on through two workers) is not replaced."""
    if not isinstance(getattr(err, WORKER_TRACEBACK, None), str):
        setattr(err, WORKER_TRACEBACK, format_chain(err if behind is None else behind))
    return err
