"""Measured cosine statistics of the simulated encoder: per relation, and against the view difference.

Every draw takes fresh objects, families and groups, so the statistics are over the
encoder's whole distribution (in one world, the few family and group pairs each sit at one
draw of their parts).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from roman_sim.frontend.appearance import SceneLooks, reference_looks
from roman_sim.frontend.semantics import SemanticConfig, SimulatedEncoder

#: Case name -> (relation, view difference deg).
from roman_sim.mapping.protocols import EncodeContext

CASES: dict[str, tuple[str, float]] = {
    "same_view": ("same_instance", 0.0),
    "side_view": ("same_instance", 90.0),
    "opposite_view": ("same_instance", 180.0),
    "same_family": ("same_family", 0.0),
    "same_group": ("same_group", 0.0),
    "other": ("other", 0.0),
}


def _view(phi_rad: float) -> NDArray[np.float64]:
    return np.array([np.cos(phi_rad), np.sin(phi_rad), 0.0])


def sample_cosines(cfg: SemanticConfig, case: str, n: int = 200, seed: int = 0) -> NDArray[np.float64]:
    """(n,) cosines of ``n`` independent pairs of observations related as ``case`` (a ``CASES`` key)."""
    relation, dview = CASES[case]
    groups = {f"g{k}": [f"a{k}", f"b{k}"] for k in range(n)} if relation == "same_group" else {}
    second = "a" if relation in ("same_instance", "same_family") else "b"
    fams = {i: f"{'a' if i % 2 == 0 else second}{i // 2}" for i in range(2 * n)}
    # every instance drawn with its own appearance values: the configured relations' kernel-0 pairs
    looks = SceneLooks({i: reference_looks(f, i) for i, f in fams.items()}, {})
    enc = SimulatedEncoder(cfg.model_copy(update={"groups": groups}), seed, looks=looks)
    rng = np.random.default_rng(seed)
    out = np.empty(n)
    mask = np.ones((1, 1), dtype=bool)
    for k in range(n):
        phi = rng.uniform(-np.pi, np.pi)
        fam_a = f"a{k}"
        fam_b = fam_a if relation in ("same_instance", "same_family") else f"b{k}"
        b_id = 2 * k if relation == "same_instance" else 2 * k + 1
        a = enc.encode(None, mask, EncodeContext(2 * k, fam_a, _view(phi)))
        b = enc.encode(None, mask, EncodeContext(b_id, fam_b, _view(phi + np.radians(dview))))
        out[k] = float(a @ b)
    return out


def cosine_statistics(
    cfg: SemanticConfig | None = None, n: int = 200, seed: int = 0, threshold: float = 0.85
) -> dict[str, dict[str, float]]:
    """Mean, std, 5/95 % quantiles and fraction above ``threshold`` for every case."""
    cfg = cfg or SemanticConfig()
    stats = {}
    for case in CASES:
        c = sample_cosines(cfg, case, n, seed)
        stats[case] = {
            "mean": float(c.mean()),
            "std": float(c.std()),
            "p05": float(np.quantile(c, 0.05)),
            "p95": float(np.quantile(c, 0.95)),
            "frac_above": float(np.mean(c > threshold)),
        }
    return stats


def view_curve(
    cfg: SemanticConfig | None = None, n: int = 50, seed: int = 0, steps: int = 13
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(view difference deg, mean same-instance cosine) from 0 to 180 deg."""
    cfg = cfg or SemanticConfig()
    enc = SimulatedEncoder(cfg, seed)
    degs = np.linspace(0.0, 180.0, steps)
    mask = np.ones((1, 1), dtype=bool)
    means = []
    for d in degs:
        cs = [
            enc.encode(None, mask, EncodeContext(k, "conifer", _view(0.0)))
            @ enc.encode(None, mask, EncodeContext(k, "conifer", _view(np.radians(d))))
            for k in range(n)
        ]
        means.append(float(np.mean(cs)))
    return degs, np.array(means)
