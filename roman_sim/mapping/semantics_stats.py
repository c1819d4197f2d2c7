"""Measured cosine statistics of the simulated encoder, and a plot documenting them."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from roman_sim.mapping.semantics import EncodeContext, SemanticConfig, SimulatedEncoder

#: Case name -> (same instance, view difference deg, family of the second observation).
CASES: dict[str, tuple[bool, float, str]] = {
    "same_view": (True, 0.0, "conifer"),
    "side_view": (True, 90.0, "conifer"),
    "opposite_view": (True, 180.0, "conifer"),
    "same_family": (False, 0.0, "conifer"),
    "same_group": (False, 0.0, "deciduous"),
    "other_group": (False, 0.0, "rock"),
}


def _view(phi_rad: float) -> NDArray[np.float64]:
    return np.array([np.cos(phi_rad), np.sin(phi_rad), 0.0])


def sample_cosines(cfg: SemanticConfig, case: str, n: int = 200, seed: int = 0) -> NDArray[np.float64]:
    """(n,) cosines between two observations of a ``conifer`` and the ``case`` partner."""
    same, dview, fam_b = CASES[case]
    enc = SimulatedEncoder(cfg, seed)
    rng = np.random.default_rng(seed)
    out = np.empty(n)
    mask = np.ones((1, 1), dtype=bool)
    for k in range(n):
        phi = rng.uniform(-np.pi, np.pi)
        a = enc.encode(None, mask, EncodeContext(2 * k, "conifer", _view(phi)))
        b_id = 2 * k if same else 2 * k + 1
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


def plot_cosine_statistics(path: str | Path, cfg: SemanticConfig | None = None, n: int = 200, seed: int = 0) -> Path:
    """Histogram of every case plus the view curve, saved as a PNG at ``path``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from roman_sim.core.atomic import write_bytes

    cfg = cfg or SemanticConfig()
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4))
    bins = np.linspace(0.0, 1.0, 101)
    for case in CASES:
        ax1.hist(sample_cosines(cfg, case, n, seed), bins=bins, alpha=0.6, label=case)
    ax1.axvline(0.85, color="k", ls="--", lw=1, label="CLIP cos_min 0.85")
    ax1.set(xlabel="cosine", ylabel="pairs", title="Simulated CLIP-like descriptor cosines")
    ax1.legend(fontsize=7)
    degs, means = view_curve(cfg, seed=seed)
    ax2.plot(degs, means, "o-")
    ax2.axhline(0.85, color="k", ls="--", lw=1)
    ax2.set(xlabel="view difference (deg)", ylabel="mean cosine", title="Same instance vs viewing direction")
    fig.tight_layout()
    buf = __import__("io").BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    plt.close(fig)
    path = Path(path)
    write_bytes(path, buf.getvalue())
    return path
