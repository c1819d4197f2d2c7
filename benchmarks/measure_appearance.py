"""How much a full difference in one appearance attribute moves an embedding: the weights'
measurement for ``frontend.semantics.appearance``.

For each built-in family in ``FAMILIES`` (variant 0 of seed 0, its family colours), two
instances that differ in ONE attribute are rasterised (``view_asymmetry.rasterise``, 96 x 96,
orthographic, headlight shading, from ``VIEWS`` azimuths) and encoded by the project's
pixel encoder (``frontend.image_encoder``, colour, gradient and texture statistics of the
masked pixels); the figure per attribute is the mean of 1 - cosine over families and views:

- shape: variant 0 against variant 1 (same colours, each framed on itself);
- scale: the family's smallest against its largest scale level, in one fixed frame;
- colour: every part at the two ends of its colour range (``vary_rgba`` with all draws -1
  against +1 at ``instance_variation`` 0.5, the worlds' default);
- texture: the part's surface texture laid over the image from two independent offsets of
  the atlas (the same pattern, another region of it).

The weights are these figures over their sum. Writes ``benchmarks/out/appearance_weights.json``.
The pixel encoder is a histogram: it is nearly blind to silhouettes, so the shape figure is
a lower bound for a CLIP-like encoder (``docs/mapping.md``).

Usage: python benchmarks/measure_appearance.py
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from roman_sim.core.atomic import write_json
from roman_sim.core.seeding import child_rng
from roman_sim.frontend.image_encoder import ImageEncoder
from roman_sim.frontend.view_asymmetry import rasterise
from roman_sim.world.appearance import vary_rgba
from roman_sim.world.assets import FAMILIES, Part
from roman_sim.world.catalog import variant_parts
from roman_sim.world.presets import load_world_spec
from roman_sim.world.textures import SURFACES, texture_image

OUT = Path(__file__).resolve().parent / "out" / "appearance_weights.json"
VIEWS = (0.0, 1.3, 2.6, 3.9, 5.2)
SIZE = 96
AMOUNT = 0.5  # the worlds' default instance_variation


def _mesh(parts: list[Part], colours: list[np.ndarray], scale: float = 1.0) -> list:
    return [(p.mesh.vertices * scale, p.mesh.faces, c) for p, c in zip(parts, colours)]


def _encode(enc: ImageEncoder, img: np.ndarray) -> np.ndarray:
    mask = img.sum(axis=2) > 0
    return enc.encode(np.round(np.clip(img, 0, 1) * 255).astype(np.uint8), mask, None).astype(np.float64)


def _textured(img: np.ndarray, parts: list[Part], seed: int) -> np.ndarray:
    tex = texture_image(parts[0].surface, child_rng(0, "measure", "texture", parts[0].surface), 4 * SIZE, SIZE)
    rng = np.random.default_rng(seed)
    r, c = rng.integers(0, 3 * SIZE, 2)
    return img * tex[r : r + SIZE, c : c + SIZE, :] / 255.0 / 0.6


def measure() -> dict[str, object]:
    """Mean 1 - cosine of the pixel encoder per attribute, per family and overall, and the weights."""
    enc = ImageEncoder()
    spec = {f.name: f for f in load_world_spec("tiny").families}
    per: dict[str, dict[str, float]] = {}
    for fam in FAMILIES.names():
        parts, other = variant_parts(0, fam, 0), variant_parts(0, fam, 1)
        base = [np.asarray(p.rgba[:3]) for p in parts]
        var = [p.variation or SURFACES.get(p.surface).variation for p in parts]
        lo = [vary_rgba(p.rgba, v, AMOUNT, -np.ones(3))[:3] for p, v in zip(parts, var)]
        hi = [vary_rgba(p.rgba, v, AMOUNT, np.ones(3))[:3] for p, v in zip(parts, var)]
        s_lo, s_hi = spec[fam].scale if fam in spec else (0.8, 1.2)
        d = {"shape": [], "scale": [], "colour": [], "texture": []}
        for az in VIEWS:
            a = rasterise(_mesh(parts, base), az, SIZE)
            b = rasterise(_mesh(other, [np.asarray(p.rgba[:3]) for p in other]), az, SIZE)
            d["shape"].append(1 - _encode(enc, a) @ _encode(enc, b))
            half = float(max(np.abs(np.concatenate([p.mesh.vertices for p in parts])).max(), 1e-6)) * s_hi
            a = rasterise(_mesh(parts, base, s_lo), az, SIZE, half)
            b = rasterise(_mesh(parts, base, s_hi), az, SIZE, half)
            d["scale"].append(1 - _encode(enc, a) @ _encode(enc, b))
            a, b = rasterise(_mesh(parts, lo), az, SIZE), rasterise(_mesh(parts, hi), az, SIZE)
            d["colour"].append(1 - _encode(enc, a) @ _encode(enc, b))
            img = rasterise(_mesh(parts, base), az, SIZE)
            d["texture"].append(1 - _encode(enc, _textured(img, parts, 1)) @ _encode(enc, _textured(img, parts, 2)))
        per[fam] = {k: float(np.mean(v)) for k, v in d.items()}
    mean = {k: float(np.mean([p[k] for p in per.values()])) for k in ("shape", "scale", "colour", "texture")}
    total = sum(mean.values())
    return {"per_family": per, "one_minus_cos": mean, "weights": {k: v / total for k, v in mean.items()}}


def main() -> None:
    out = measure()
    write_json(OUT, out)
    print(json.dumps({k: out[k] for k in ("one_minus_cos", "weights")}, indent=1))  # noqa: T201


if __name__ == "__main__":
    main()
