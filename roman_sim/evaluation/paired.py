"""Paired non-inferiority of one method against a baseline on the same relevant pairs.

Two methods scored on the same relevant pairs differ only on the *discordant* pairs: ``b``
that the baseline hits and the method misses, ``c`` the other way round. McNemar's exact
test asks whether ``b`` out of the ``m = b + c`` discordant pairs is more than a fair coin
gives (``scipy.stats.binomtest``). Non-inferiority asks more: that the method's recall is
not below the baseline's by ``margin`` or more. The loss ``delta = P(b) - P(c)`` equals
``p_d * (2 q - 1)`` where ``p_d`` is the chance that a relevant pair is discordant and ``q``
the chance that a discordant pair favours the baseline. Exact one-sided Clopper-Pearson
upper bounds of ``p_d`` (``m`` of ``n``) and of ``q`` (``b`` of ``m``), each at
``1 - (1 - level) / 2`` (Bonferroni), bound ``delta`` from above at ``level``; the method is
shown not worse when that bound is at most ``margin``. The bound is conservative: a sample
too small to show it fails, it never passes for lack of evidence. When it fails without the
observed loss reaching the margin, ``needed`` is the number of relevant pairs that would
show it if the observed proportions held.
"""

from __future__ import annotations

from dataclasses import dataclass

from scipy.stats import binomtest

#: Relevant pairs beyond which ``needed`` is not searched (None: more than this).
MAX_NEEDED = 1_000_000


@dataclass(frozen=True)
class PairedComparison:
    """A method against a baseline on ``n`` shared relevant pairs.

    Attributes:
        n: relevant pairs both methods were scored on.
        hits, baseline_hits: hits of the method and of the baseline.
        worse, better: discordant pairs the baseline hits and the method misses, and the reverse.
        loss: observed recall loss ``(worse - better) / n`` (negative: the method is better).
        loss_upper: upper bound of the loss at ``level`` (0 when it cannot be positive).
        mcnemar_p: McNemar's exact one-sided p-value that the method is worse (1 without discordance).
        margin, level: the non-inferiority margin and confidence level.
        needed: relevant pairs that would show non-inferiority at the observed proportions
            (None when the sample already does, or when the observed loss reaches the margin
            or no sample up to ``MAX_NEEDED`` would).
    """

    n: int
    hits: int
    baseline_hits: int
    worse: int
    better: int
    loss: float
    loss_upper: float
    mcnemar_p: float
    margin: float
    level: float
    needed: int | None

    @property
    def not_worse(self) -> bool:
        """Whether the sample shows the method within ``margin`` of the baseline."""
        return self.loss_upper <= self.margin


def _upper(k: int, n: int, level: float) -> float:
    """Exact one-sided upper Clopper-Pearson bound of k / n at ``level`` (1 when n == 0)."""
    if n == 0:
        return 1.0
    return float(binomtest(k, n, alternative="less").proportion_ci(confidence_level=level).high)


def loss_upper_bound(worse: int, better: int, n: int, level: float) -> float:
    """Upper bound at ``level`` of the recall loss from ``worse`` and ``better`` discordant pairs of ``n``."""
    each = 1.0 - (1.0 - level) / 2.0
    m = worse + better
    q = _upper(worse, m, each)
    if q <= 0.5:
        return 0.0
    return _upper(m, n, each) * (2.0 * q - 1.0)


def _needed(worse: int, better: int, n: int, margin: float, level: float) -> int | None:
    """Fewest relevant pairs whose bound reaches ``margin`` at the observed proportions."""

    def shows(size: int) -> bool:
        f = size / n
        return loss_upper_bound(round(worse * f), round(better * f), size, level) <= margin

    if (worse - better) / n >= margin:
        return None
    hi = n
    while not shows(hi):
        if hi >= MAX_NEEDED:
            return None
        hi = min(2 * hi, MAX_NEEDED)
    lo = n  # does not show at n
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if shows(mid) else (mid, hi)
    return hi


def compare_paired(hits: list[bool], baseline_hits: list[bool], margin: float, level: float) -> PairedComparison:
    """Compare per-pair hits of a method and a baseline on the same relevant pairs (same order)."""
    if len(hits) != len(baseline_hits):
        raise ValueError(f"compare_paired: {len(hits)} outcomes against {len(baseline_hits)}")
    n = len(hits)
    worse = sum(1 for h, hb in zip(hits, baseline_hits) if hb and not h)
    better = sum(1 for h, hb in zip(hits, baseline_hits) if h and not hb)
    m = worse + better
    upper = loss_upper_bound(worse, better, n, level) if n else 1.0
    p = float(binomtest(worse, m, 0.5, alternative="greater").pvalue) if m else 1.0
    needed = None if not n or upper <= margin else _needed(worse, better, n, margin, level)
    return PairedComparison(
        n=n,
        hits=sum(hits),
        baseline_hits=sum(baseline_hits),
        worse=worse,
        better=better,
        loss=(worse - better) / n if n else float("nan"),
        loss_upper=upper,
        mcnemar_p=p,
        margin=margin,
        level=level,
        needed=needed,
    )


__all__ = ["MAX_NEEDED", "PairedComparison", "compare_paired", "loss_upper_bound"]
