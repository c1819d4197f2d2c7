"""How a fixed setting's precision spreads from world to world: a beta-binomial model.

At one setting, world w accepts n_w pairs and h_w of them are correct. Worlds differ (their
layout, how repetitive the scene is), so the pairs of all worlds are not draws of one rate:
the pooled precision says what many worlds give together, not how far one new world falls
from it. The model: each world's precision is a draw p_w ~ Beta(a, b) and
h_w | p_w ~ Binomial(n_w, p_w), so h_w ~ BetaBinomial(n_w, a, b). (a, b) are fitted by
maximum likelihood over the worlds that accepted a pair; from the fit, for a new world:

- ``share(x)``: P(p_new >= x), the share of new worlds whose precision is at least x;
- ``interval(level)``: the central interval of p_new holding ``level`` of the worlds;
- ``hits_interval(n, level)``: the central interval of the hits of a new world that accepts
  n pairs (its own few pairs add binomial noise to p_new).

The likelihood is maximised over the mean m = a / (a + b) on the logit scale and the
concentration c = a + b on the log scale, both bounded (``MEAN_BOUNDS``, ``CONCENTRATION_BOUNDS``),
by scipy's L-BFGS-B from a few fixed starts (the best kept). A fit at the upper concentration
bound means the worlds agree beyond what their counts can tell apart (one binomial rate); at
the upper mean bound, no world had a false positive. Written here because scipy fits a
distribution to draws of one n only, and no maintained library fits a beta-binomial to counts
of differing n. Maximum likelihood understates the spread with few worlds: the fit needs
``MIN_WORLDS`` worlds with an accepted pair, and its figures are as good as the worlds are many.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import optimize, special, stats

log = logging.getLogger(__name__)

#: The fitted mean a / (a + b) stays in these bounds.
MEAN_BOUNDS = (1e-4, 1 - 1e-4)
#: The fitted concentration a + b stays in these bounds.
CONCENTRATION_BOUNDS = (1e-2, 1e5)
#: Fewer worlds with an accepted pair than this: no fit.
MIN_WORLDS = 2
_STARTS = (1.0, 10.0, 100.0)


def _logit(x: float) -> float:
    return float(np.log(x / (1 - x)))


@dataclass(frozen=True)
class WorldSpread:
    """A fitted Beta(a, b) of the precision of one world (``worlds``: how many worlds it was fitted on)."""

    a: float
    b: float
    worlds: int

    @property
    def mean(self) -> float:
        """The expected precision of a new world, a / (a + b)."""
        return self.a / (self.a + self.b)

    def share(self, x: float) -> float:
        """P(p_new >= x): the share of new worlds whose precision is at least ``x``."""
        return float(stats.beta.sf(x, self.a, self.b))

    def interval(self, level: float = 0.95) -> tuple[float, float]:
        """The central interval of p_new holding ``level`` of new worlds."""
        q = (1 - level) / 2
        lo, hi = stats.beta.ppf([q, 1 - q], self.a, self.b)
        return float(lo), float(hi)

    def hits_interval(self, n: int, level: float = 0.95) -> tuple[int, int]:
        """The central interval of a new world's hits when it accepts ``n`` pairs (BetaBinomial(n, a, b))."""
        q = (1 - level) / 2
        lo, hi = stats.betabinom.ppf([q, 1 - q], n, self.a, self.b)
        return int(lo), int(hi)


def _nll(x: np.ndarray, h: np.ndarray, n: np.ndarray) -> float:
    """Minus the log-likelihood of (logit m, log c), without the binomial coefficients (constant in a, b)."""
    m, c = special.expit(x[0]), np.exp(x[1])
    a, b = m * c, (1 - m) * c
    return float(-(special.betaln(h + a, n - h + b) - special.betaln(a, b)).sum())


def fit_spread(hits: Sequence[int], accepted: Sequence[int]) -> WorldSpread | None:
    """The maximum-likelihood ``WorldSpread`` of per-world ``hits`` out of ``accepted`` pairs (worlds with
    none accepted carry no information and are left out); None with fewer than ``MIN_WORLDS`` such worlds."""
    h = np.asarray(hits, dtype=np.float64)
    n = np.asarray(accepted, dtype=np.float64)
    keep = n > 0
    h, n = h[keep], n[keep]
    if len(n) < MIN_WORLDS:
        return None
    bounds = [(_logit(MEAN_BOUNDS[0]), _logit(MEAN_BOUNDS[1])), tuple(np.log(CONCENTRATION_BOUNDS))]
    m0 = float(np.clip(h.sum() / n.sum(), *MEAN_BOUNDS))
    best: optimize.OptimizeResult | None = None
    for c0 in _STARTS:
        r = optimize.minimize(_nll, [_logit(m0), np.log(c0)], args=(h, n), method="L-BFGS-B", bounds=bounds)
        if best is None or r.fun < best.fun:
            best = r
    assert best is not None
    # L-BFGS-B stops early where the likelihood is nearly flat in the concentration (worlds that agree):
    # a bounded Nelder-Mead from its point polishes it, kept only where it is higher
    nm = optimize.minimize(
        _nll, best.x, args=(h, n), method="Nelder-Mead", bounds=bounds, options={"xatol": 1e-9, "fatol": 1e-12}
    )
    if nm.fun < best.fun:
        best = nm
    m, c = float(special.expit(best.x[0])), float(np.exp(best.x[1]))
    log.debug("beta-binomial over %d worlds: mean %.4f, concentration %.3g", len(n), m, c)
    return WorldSpread(m * c, (1 - m) * c, int(len(n)))


__all__ = ["CONCENTRATION_BOUNDS", "MEAN_BOUNDS", "MIN_WORLDS", "WorldSpread", "fit_spread"]
