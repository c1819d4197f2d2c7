"""Closure-file benchmark: time and memory of reading and scoring a 200 MB closure file.

A smoke run (``roman-sim run smoke`` into a temporary folder, or ``--run DIR``) gives its
ROMAN closures (``run_closures``); its lines are drawn at random, with replacement, into a
CSV file and a g2o file (with its timestamps file) of ``--mb`` MB each (200; 20 with
``--quick``). Each figure comes from a fresh process: the imports alone (the baseline), reading
each file (``read_closures``), and the whole ``roman-sim score`` of the CSV file and of the
run's own closures (the small file). Reports wall and CPU seconds and the peak resident memory
(``ru_maxrss``) of each process. The closures of one pair repeat, so nearly all are unscored:
the scoring keeps one per pair and lists the others. ``--compare COMMIT`` also measures that
commit of this repository (``git archive``: e.g. the one before the streamed readers) reading
and scoring the same CSV file (``former``). Writes ``benchmarks/out/closures.json``.
Run: ``python benchmarks/bench_closures.py [--quick] [--run DIR] [--compare COMMIT]``.
"""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from roman_sim.core.atomic import write_json
from roman_sim.interop.closures import write_csv_closures, write_g2o_closures
from roman_sim.scoring.external import run_closures

OUT = Path(__file__).resolve().parent / "out" / "closures.json"
ROOT = Path(__file__).resolve().parents[1]
#: The measured process: ``{body}`` between a clock and the resource figures it prints as JSON.
CHILD = """
import json, resource, time
t0, c0 = time.perf_counter(), time.process_time()
{body}
print(json.dumps({{"wall_s": time.perf_counter() - t0, "cpu_s": time.process_time() - c0,
                  "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}}))
"""
IMPORTS = "import roman_sim.cli, roman_sim.scoring.external, roman_sim.interop.closures"


def _env(root: Path = ROOT) -> dict[str, str]:
    return {**os.environ, "PYTHONPATH": str(root), "MUJOCO_GL": "egl", "PYOPENGL_PLATFORM": "egl"}


def _measure(body: str, cwd: Path, root: Path = ROOT) -> dict:
    """Wall, CPU and peak memory of a fresh process running ``body`` with the project at ``root``."""
    res = subprocess.run(
        [sys.executable, "-c", CHILD.format(body=body)], cwd=cwd, env=_env(root), capture_output=True, text=True
    )
    if res.returncode != 0:
        raise SystemExit(f"failed: {body}\n{res.stderr}")
    fig = json.loads(res.stdout.strip().splitlines()[-1])
    return {k: round(v, 2) for k, v in fig.items()}


def _grow(entries: list[str], mb: float, path: Path, head: str = "") -> int:
    """Write ``head`` and entries drawn at random (seed 0) until ``mb`` MB; the number drawn."""
    rng = np.random.default_rng(0)
    size, n = 0, 0
    with path.open("w", encoding="utf-8") as fh:
        fh.write(head)
        while size < mb * 1e6:
            chunk = "".join(entries[i] for i in rng.integers(0, len(entries), 4096))
            fh.write(chunk)
            size, n = size + len(chunk), n + 4096
    return n


def _files(run: Path, mb: float, tmp: Path) -> dict[str, Path | int]:
    """The run's closures as CSV and g2o files of ``mb`` MB each, and the run's own CSV."""
    closures = run_closures(run, "roman")
    write_csv_closures(tmp / "own.csv", closures)
    write_g2o_closures(tmp / "own.g2o", tmp / "big.time.txt", closures, ["a", "b"])
    csv_lines = (tmp / "own.csv").read_text(encoding="utf-8").splitlines(keepends=True)
    g2o_text = (tmp / "own.g2o").read_text(encoding="utf-8").splitlines(keepends=True)
    g2o = [g2o_text[i] + g2o_text[i + 1] for i in range(0, len(g2o_text), 2)]  # "# LC: n" and its edge
    n_csv = _grow(csv_lines[1:], mb, tmp / "big.csv", head=csv_lines[0])
    n_g2o = _grow(g2o, mb, tmp / "big.g2o")
    return {"own": tmp / "own.csv", "csv": tmp / "big.csv", "g2o": tmp / "big.g2o", "n_csv": n_csv, "n_g2o": n_g2o}


def _checkout(commit: str, dest: Path) -> str:
    """This repository's ``commit`` extracted into ``dest``; its full hash."""
    full = subprocess.run(["git", "-C", str(ROOT), "rev-parse", commit], check=True, capture_output=True, text=True)
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", commit], check=True, capture_output=True)
    dest.mkdir()
    subprocess.run(["tar", "-x", "-C", str(dest)], input=archive.stdout, check=True)
    return full.stdout.strip()


def main(quick: bool = False, run: Path | None = None, compare: str | None = None) -> dict:
    """Run the benchmark and write its figures."""
    mb = 20 if quick else 200
    with tempfile.TemporaryDirectory(prefix="bench_closures.") as tmp_name:
        tmp = Path(tmp_name)
        if run is None:
            run = tmp / "smoke"
            subprocess.run(
                [sys.executable, "-m", "roman_sim.cli", "run", "smoke", "--out", str(run)],
                env=_env(),
                check=True,
                capture_output=True,
            )
        f = _files(run, mb, tmp)
        read = "from roman_sim.interop.closures import read_closures\n"
        score = "from roman_sim.cli import app\napp({args!r}, standalone_mode=False)"
        out: dict = {
            "mb": mb,
            "closures": {"csv": f["n_csv"], "g2o": f["n_g2o"]},
            "bytes": {k: Path(str(f[k])).stat().st_size for k in ("csv", "g2o")},
            "imports": _measure(IMPORTS, tmp),
            "read_csv": _measure(f"{IMPORTS}\n{read}read_closures({str(f['csv'])!r})", tmp),
            "read_g2o": _measure(
                f"{IMPORTS}\n{read}read_closures({str(f['g2o'])!r}, {str(tmp / 'big.time.txt')!r}, ['a', 'b'])", tmp
            ),
            "score_own": _measure(score.format(args=["score", str(run), "-c", str(f["own"]), "-o", "s1"]), tmp),
            "score_csv": _measure(score.format(args=["score", str(run), "-c", str(f["csv"]), "-o", "s2"]), tmp),
        }
        if compare is not None:
            former = tmp / "former"
            out["former"] = {
                "commit": _checkout(compare, former),
                "read_csv": _measure(f"{IMPORTS}\n{read}read_closures({str(f['csv'])!r})", tmp, former),
                "score_csv": _measure(
                    score.format(args=["score", str(run), "-c", str(f["csv"]), "-o", "s3"]), tmp, former
                ),
            }
    out["machine"] = {
        "python": platform.python_version(),
        "cpu_count": os.cpu_count(),
        "note": "2 cores shared with other jobs while measured: CPU seconds and memory are the stable figures",
    }
    write_json(OUT, out)
    return out


if __name__ == "__main__":

    def _arg(flag: str) -> str | None:
        return sys.argv[sys.argv.index(flag) + 1] if flag in sys.argv else None

    at = _arg("--run")
    fig = main(quick="--quick" in sys.argv, run=Path(at) if at else None, compare=_arg("--compare"))
    sys.stdout.write(json.dumps(fig, indent=2) + "\n")
