"""Process resource figures: peak resident memory per stage (Linux ``/proc``; None elsewhere)."""

from __future__ import annotations

from pathlib import Path


def peak_rss_mb() -> float | None:
    """Peak resident set size of this process (MB) since start or the last ``reset_peak_rss``."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024.0
    except (OSError, ValueError):
        return None
    return None


def reset_peak_rss() -> None:
    """Reset the peak to the current size (Linux >= 4.0: ``/proc/self/clear_refs`` = 5)."""
    try:
        Path("/proc/self/clear_refs").write_text("5")
    except OSError:
        pass
