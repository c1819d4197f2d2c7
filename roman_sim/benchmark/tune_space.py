"""What ``roman-sim tune`` may vary: a method's declared parameters, their values, the settings grid.

Every method has three pipeline parameters:

- ``threshold``: the association threshold; a pair is a loop closure when the method found
  at least this many associations (``posegraph.lc_association_thresh``). Changing it only
  changes the evaluation: nothing is mapped or aligned again.
- ``gating.top_k`` and ``gating.min_similarity``: submap gating (``roman_sim.align.gating``),
  the number of nearest submaps kept per submap and the descriptor similarity that keeps a
  pair. Gating decides which pairs are registered; a gated-out pair is "no alignment", so a
  gating setting is applied to the ungated results of the same alignment (nothing re-aligned).

and the parameters its aligner declares through ``tunable_params`` (``align.base.Tunable``):
ROMAN the bounds of its semantic gate (``cos_min``, ``cos_max``). Each value of those is a
separate alignment (the maps are reused).

A parameter is given as ``NAME=LO:HI`` (integers: every integer in between; real numbers:
five evenly spaced values), ``NAME=LO:HI:N`` (N evenly spaced values, ends included) or
``NAME=V1,V2,...``. Named without values, a parameter takes its declared default values.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Any

from roman_sim.align.base import Tunable, declared_tunables
from roman_sim.core.config import stable_hash
from roman_sim.core.errors import ConfigError

#: The association threshold (every method).
THRESHOLD = "threshold"
#: Parameters of submap gating (every method): applied to the ungated results.
GATING = ("gating.top_k", "gating.min_similarity")
#: Pipeline parameters every method has.
PIPELINE_TUNABLES: dict[str, Tunable] = {
    THRESHOLD: Tunable(
        1,
        10000,
        integer=True,
        default=tuple(range(1, 31)),
        doc="association threshold: a loop closure needs at least this many associations",
    ),
    "gating.top_k": Tunable(1, 10000, integer=True, doc="submap gating: keep each submap's k most similar candidates"),
    "gating.min_similarity": Tunable(-1.0, 1.0, doc="submap gating: keep pairs whose descriptors are this similar"),
}
#: Values of a real-valued ``LO:HI`` range without a count.
DEFAULT_COUNT = 5


def method_factory(method: str) -> object:
    """The aligner class (or factory) of a registered name or a ``package.module:Class`` plug-in."""
    from roman_sim.align import ALIGNERS
    from roman_sim.core.registry import import_object

    if ":" in method and method not in ALIGNERS:
        return import_object(method, "aligner")
    if method not in ALIGNERS:
        raise ConfigError(f"--method: unknown method {method!r} (valid: {', '.join(ALIGNERS.names())})")
    return ALIGNERS.get(method)


def declared(method: str) -> dict[str, Tunable]:
    """Every parameter ``tune`` may vary for ``method``: the pipeline's, then its aligner's own."""
    own = declared_tunables(method_factory(method))
    return {**PIPELINE_TUNABLES, **own}


def _number(name: str, text: str, spec: Tunable) -> float:
    try:
        v = float(text)
    except ValueError:
        raise ConfigError(f"--param {name}: {text!r} is not a number") from None
    if not math.isfinite(v):
        raise ConfigError(f"--param {name}: {text!r} is not a finite number")
    if spec.integer and v != int(v):
        raise ConfigError(f"--param {name}: takes integers, got {text}")
    if not spec.low <= v <= spec.high:
        raise ConfigError(f"--param {name}: {text} is outside the allowed [{spec.low:g}, {spec.high:g}]")
    return float(int(v)) if spec.integer else v


def _values(name: str, raw: str, spec: Tunable) -> list[float]:
    """The values of one ``--param`` (see the module docstring)."""
    raw = raw.strip()
    if not raw:
        if not spec.default:
            raise ConfigError(f"--param {name}: empty range (give LO:HI, LO:HI:N or V1,V2,...)")
        return [float(v) for v in spec.default]
    if ":" in raw:
        parts = raw.split(":")
        if len(parts) not in (2, 3):
            raise ConfigError(f"--param {name}: expected LO:HI or LO:HI:N, got {raw!r}")
        lo, hi = _number(name, parts[0], spec), _number(name, parts[1], spec)
        if lo > hi:
            raise ConfigError(f"--param {name}: reversed range {raw} (LO must not exceed HI)")
        if len(parts) == 3:
            try:
                n = int(parts[2])
            except ValueError:
                raise ConfigError(f"--param {name}: N of LO:HI:N must be an integer, got {parts[2]!r}") from None
            if n < 1:
                raise ConfigError(f"--param {name}: empty range {raw} (N must be at least 1)")
        else:
            n = int(hi - lo) + 1 if spec.integer else DEFAULT_COUNT
        if n == 1 or lo == hi:
            vals = [lo]
        else:
            vals = [lo + (hi - lo) * i / (n - 1) for i in range(n)]
        out = [float(round(v)) if spec.integer else round(v, 12) for v in vals]
    else:
        out = [_number(name, t, spec) for t in raw.split(",") if t.strip()]
        if not out:
            raise ConfigError(f"--param {name}: empty list of values")
    return sorted(set(out))


def parse_params(method: str, items: list[str]) -> dict[str, list[float]]:
    """``NAME=SPEC`` items -> parameter -> its sorted values (ConfigError names the bad one).

    Without items: the threshold and the method's parameters that have default values.
    """
    allowed = declared(method)
    if not items:
        return {n: [float(v) for v in s.default] for n, s in allowed.items() if s.default}
    out: dict[str, list[float]] = {}
    for item in items:
        name, _, raw = item.partition("=")
        name = name.strip()
        if name not in allowed:
            raise ConfigError(
                f"--param {name or repr(item)}: {method} does not declare it (declared: {', '.join(allowed)})"
            )
        if name in out:
            raise ConfigError(f"--param {name}: given twice")
        out[name] = _values(name, raw, allowed[name])
    if THRESHOLD not in out:
        out[THRESHOLD] = [float(v) for v in allowed[THRESHOLD].default]
    return out


def _plain(v: float, spec: Tunable) -> int | float:
    return int(v) if spec.integer else float(v)


@dataclass(frozen=True)
class Config:
    """One setting of everything but the threshold: the aligner's parameters and the gating.

    Attributes:
        aligner: the aligner parameters set (name -> value), sorted by name.
        gating: the gating parameters set (``top_k``, ``min_similarity``), empty: no gating.
    """

    aligner: tuple[tuple[str, int | float], ...]
    gating: tuple[tuple[str, int | float], ...]

    @property
    def align_key(self) -> str:
        """What the alignment depends on (configs differing in gating share it)."""
        return stable_hash(list(self.aligner))[:12]

    @property
    def id(self) -> str:
        """A short stable id of the whole config."""
        return stable_hash(list(self.aligner), list(self.gating))[:12]

    def values(self) -> dict[str, int | float]:
        """Parameter name -> value (gating parameters as ``gating.<name>``)."""
        return {**dict(self.aligner), **{f"gating.{k}": v for k, v in self.gating}}

    def gating_config(self) -> dict[str, Any]:
        """The scenario's ``gating`` section of this config (disabled without gating parameters)."""
        if not self.gating:
            return {"enabled": False}
        g = dict(self.gating)
        return {"enabled": True, "top_k": g.get("top_k"), "min_similarity": g.get("min_similarity")}


@dataclass(frozen=True)
class Grid:
    """The settings of a tune: configs (aligner x gating values) and the thresholds tried."""

    method: str
    configs: list[Config]
    thresholds: list[int]

    @property
    def n_settings(self) -> int:
        """Configs times thresholds."""
        return len(self.configs) * len(self.thresholds)

    def alignments(self) -> list[tuple[tuple[str, int | float], ...]]:
        """The distinct aligner parameter sets (each one alignment per world)."""
        return list(dict.fromkeys(c.aligner for c in self.configs))


def build_grid(method: str, values: dict[str, list[float]], base_params: dict[str, Any] | None = None) -> Grid:
    """Every combination of ``values``; each aligner parameter set is validated by building the aligner.

    Raises:
        ConfigError: a combination the aligner refuses (e.g. ``cos_max`` not above ``cos_min``).
    """
    from roman_sim.align import build_aligner

    allowed = declared(method)
    own = [n for n in values if n != THRESHOLD and n not in GATING]
    gate = [n for n in GATING if n in values]
    aligners = []
    for combo in itertools.product(*(values[n] for n in own)):
        params = tuple(sorted((n, _plain(v, allowed[n])) for n, v in zip(own, combo, strict=True)))
        if ":" not in method:  # a plug-in is built (and dry-run) by the run itself
            try:
                build_aligner(method, {**(base_params or {}), **dict(params)})
            except ConfigError as err:
                shown = ", ".join(f"{n}={v:g}" for n, v in params)
                raise ConfigError(f"--param: {method} refuses {shown}: {err}") from None
        aligners.append(params)
    gatings = [
        tuple((n.split(".", 1)[1], _plain(v, allowed[n])) for n, v in zip(gate, combo, strict=True))
        for combo in itertools.product(*(values[n] for n in gate))
    ]
    configs = [Config(a, g) for a in aligners for g in gatings]
    return Grid(method, configs, [int(v) for v in values[THRESHOLD]])
