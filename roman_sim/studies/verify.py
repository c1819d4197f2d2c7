"""A finished run's figures recomputed, then checked by an independent scorer (``report --verify``).

Three checks, the last independent of the others:

- every file's bytes against the SHA-256 ``manifest.json`` recorded for it (a file edited
  after the run is named);
- the run's files recomputed from its raw files (``roman_sim.report.recompute``:
  ``metrics.json`` from ``pairs.csv``, ``ate.json`` from the TUM files);
- the figures of the run's compact summary (recall, hits, relevant pairs and intervals per
  method, pair set and heading bin, the operating points, recall at precision 1, runtime
  medians, ATE per variant, packet sizes where the packets were kept) against
  ``roman_sim.studies.independent_scorer``, which re-scores the raw files with code of its own (nothing
  from ``roman_sim.evaluation``).

``verify_run`` returns the list of differences (empty: everything matches).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from roman_sim.core.errors import RomanSimError
from roman_sim.core.records import to_json_object
from roman_sim.report.recompute import REL_TOL, Verification, check_run_files, stored_summary


def _drop_points(node: Any) -> None:
    """Remove every ``points`` entry of a JSON-like tree, in place."""
    if isinstance(node, dict):
        node.pop("points", None)
        for v in node.values():
            _drop_points(v)
    elif isinstance(node, list):
        for v in node:
            _drop_points(v)


def _has_points(node: Any) -> bool:
    """Whether a JSON-like tree holds a non-empty ``points`` entry."""
    if isinstance(node, dict):
        return bool(node.get("points")) or any(_has_points(v) for v in node.values())
    if isinstance(node, list):
        return any(_has_points(v) for v in node)
    return False


def independent_check(run_dir: Path) -> list[str]:
    """Where the independent scorer's figures differ from the run's stored compact summary.

    A run whose ``metrics.json`` predates the operating points (or the revisit figures) gives a
    summary without them; it is then compared without them (``verify_run`` says so for the
    points).
    """
    from roman_sim.studies.independent_scorer import agreement, score_run

    stored = to_json_object(stored_summary(run_dir))  # compared as JSON figures: the scorer knows no records
    scored = score_run(run_dir)
    if not _has_points(stored):
        _drop_points(scored)
    if isinstance(scored, dict) and "revisits" not in stored:
        scored.pop("revisits", None)
    return agreement(stored, scored)


def verify_run(
    run_dir: str | Path, rel_tol: float = REL_TOL, pairs_file: str = "pairs.csv", tum_suffix: str = ""
) -> Verification:
    """Recompute ``metrics.json`` (and ``ate.json`` when present), run the independent scorer, list every difference."""
    from roman_sim.pipeline.manifest import changed_files, read_manifest

    d = Path(run_dir)
    out = check_run_files(d, rel_tol, pairs_file, tum_suffix)
    man = read_manifest(d)
    out.differences += changed_files(d, man)
    if any(rec.sha256 for rec in man.stages.values()):  # older manifests recorded no hashes
        out.checked.append("every file's SHA-256 against manifest.json")
    try:
        out.differences += [f"independent scorer: {x}" for x in independent_check(d)]
    except RomanSimError as err:
        out.differences.append(f"independent scorer: cannot score ({err})")
    else:
        out.checked.append("the summary's figures against the independent scorer")
    return out
