"""The answer first: a short generated paragraph on who won at which operating point.

For the headline pair set it says, at max recall, at precision >= 0.9 and at the pose
graph's acceptance threshold, which method has the most hits, which methods its 95 % Wilson
interval separates it from (the other's interval lies wholly below) and which it does not;
whether the order of the methods changes between those points; and what each pose graph did
to the ATE against odometry. Every figure is read from the metrics and the ATE table; no
statement is made where a figure is undefined.
"""

from __future__ import annotations

from dataclasses import dataclass

from roman_sim.evaluation.atetable import ALL, AteTable
from roman_sim.evaluation.metrics import NO_SEGMENTS_NOTE
from roman_sim.evaluation.operating_points import OperatingPoint
from roman_sim.evaluation.types import PAIR_SET_LABELS, EvaluationMetrics

#: The operating points the paragraph speaks of, and how it names them.
LEAD_POINTS = {"max_recall": "max recall", "precision_90": "precision >= 0.9", "acceptance": "acceptance"}
#: ATE rows that are not a method's pose graph.
REFERENCE_ROWS = ("odometry", "odometry_no_prior", "oracle")


@dataclass(frozen=True)
class PointLead:
    """Who leads at one operating point.

    Attributes:
        point: operating point name.
        best: methods with the most hits (several when tied).
        hits, n_relevant: their hits and the relevant pairs.
        separated: methods whose interval lies wholly below the leaders'.
        overlapping: the other methods (their interval overlaps a leader's).
        order: every method, most hits first (ties by name).
    """

    point: str
    best: list[str]
    hits: int
    n_relevant: int
    separated: list[str]
    overlapping: list[str]
    order: list[str]


def point_lead(metrics: EvaluationMetrics, point: str, kind: str) -> PointLead | None:
    """Who leads ``kind``'s overall figures at ``point`` (None: no relevant pair or no such point)."""
    pts: dict[str, OperatingPoint] = {}
    for m in metrics.methods:
        p = metrics.stats(m, None, kind).operating_points.get(point)
        if p is not None and p.n_relevant and p.recall_ci is not None:
            pts[m] = p
    if not pts:
        return None
    order = sorted(pts, key=lambda m: (-pts[m].hits, m))
    top = pts[order[0]].hits
    best = [m for m in order if pts[m].hits == top]
    low = min(pts[m].recall_ci[0] for m in best)  # type: ignore[index]
    rest = [m for m in order if m not in best]
    separated = [m for m in rest if pts[m].recall_ci[1] < low]  # type: ignore[index]
    overlapping = [m for m in rest if m not in separated]
    return PointLead(point, best, top, pts[order[0]].n_relevant, separated, overlapping, order)


def _names(ms: list[str]) -> str:
    return ms[0] if len(ms) == 1 else ", ".join(ms[:-1]) + " and " + ms[-1]


def _cell(p: OperatingPoint) -> str:
    lo, hi = p.recall_ci  # type: ignore[misc]
    return f"{p.recall:.2f} ({p.hits}/{p.n_relevant}) [{lo:.2f}, {hi:.2f}]"


def _point_sentence(metrics: EvaluationMetrics, lead: PointLead, kind: str) -> str:
    name = LEAD_POINTS[lead.point]
    if lead.point == "acceptance" and metrics.acceptance_k is not None:
        name += f" (k = {metrics.acceptance_k})"
    p = metrics.stats(lead.best[0], None, kind).operating_points[lead.point]
    assert p is not None
    if lead.hits == 0:
        return f"At {name} no method aligns a relevant pair."
    several = len(lead.best) > 1
    s = f"At {name} {_names(lead.best)} {'lead, each' if several else 'leads'} with {_cell(p)}"
    its = "their intervals" if several else "its interval"
    if lead.separated and not lead.overlapping:
        return s + f", {its} above every other method's."
    if lead.separated:
        s += f", {its} above " + ("that of " if len(lead.separated) == 1 else "those of ") + _names(lead.separated)
    if lead.overlapping:
        s += f"{',' if lead.separated else ''} but not separated from " + _names(
            [
                f"{m} ({_cell(q)})"
                for m in lead.overlapping
                if (q := metrics.stats(m, None, kind).operating_points[lead.point]) is not None
            ]
        )
    return s + "."


def _order_sentence(leads: list[PointLead]) -> str | None:
    """The orders by hits when they differ between operating points."""
    if len(leads) < 2 or all(lead.order == leads[0].order for lead in leads):
        return None if len(leads) < 2 else "The order of the methods is the same at every operating point."
    parts = [f"{LEAD_POINTS[lead.point]}: {' > '.join(lead.order)}" for lead in leads]
    return "The order by hits changes between operating points (" + "; ".join(parts) + ")."


def _ate_sentence(ate: AteTable | None) -> str | None:
    """What each pose graph did to the ATE against odometry (SE(3) aligned, all robots)."""
    if ate is None or "odometry" not in ate.variants:
        return None
    odo = ate.rmse("odometry", "se3", ALL)
    if odo is None:
        return None
    said = []
    for name, row in ate.variants.items():
        if name in REFERENCE_ROWS:
            continue
        got = ate.rmse(name, "se3", ALL)
        if got is None:
            said.append(f"{name}'s placed {len(row.connected)} of {len(ate.robots)} robots")
        else:
            said.append(f"{name}'s {got:.2f} m ({got / odo:.0%} of odometry's)")
    if not said:
        return None
    s = f"ATE RMSE over all robots (SE(3) aligned): odometry {odo:.2f} m; pose graphs: " + ", ".join(said)
    if "oracle" in ate.variants and (orc := ate.rmse("oracle", "se3", ALL)) is not None:
        s += f"; with every true closure (oracle) {orc:.2f} m"
    return s + "."


def lead_paragraph(metrics: EvaluationMetrics, ate: AteTable | None = None, markdown: bool = True) -> list[str]:
    """The opening paragraph for the headline pair set (markdown lines, or plain text); empty without methods."""
    kind = metrics.headline
    if not metrics.methods or not metrics.n_pairs:
        return []
    n_rel = metrics.pairs[kind].n_relevant
    head = f"{PAIR_SET_LABELS[kind].capitalize()} pairs, {n_rel} relevant."
    head = f"**{head}**" if markdown else head
    if not n_rel:
        return [f"{head} No relevant pair: no method can be ranked.", ""]
    if NO_SEGMENTS_NOTE in metrics.notes:  # nothing to align: no figure to lead with, not even 0 of n_rel
        return [f"{head} Undefined: {NO_SEGMENTS_NOTE}.", ""]
    leads = [lead for p in LEAD_POINTS if (lead := point_lead(metrics, p, kind)) is not None]
    sentences = [_point_sentence(metrics, lead, kind) for lead in leads]
    sentences += [s for s in (_order_sentence(leads), _ate_sentence(ate)) if s]
    sentences.append("Intervals are 95 % Wilson; a method leads where its interval lies above another's.")
    return [" ".join([head, *sentences]), ""]


__all__ = ["LEAD_POINTS", "PointLead", "lead_paragraph", "point_lead"]
