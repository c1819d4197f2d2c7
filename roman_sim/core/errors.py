"""The error family. The CLI turns any ``RomanSimError`` into one line and exit code 1."""

from __future__ import annotations


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
