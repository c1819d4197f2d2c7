"""How much the sun's side moves an embedding: the measurement of ``lighting_fall``
(``frontend.semantics``).

For each built-in family in ``FAMILIES`` (variant 0 of seed 0, its family colours), the same
shape is rasterised from the same camera direction twice (``view_asymmetry.rasterise``, 96 x 96,
orthographic, from ``VIEWS`` azimuths) under a ``view_asymmetry.Light``: the sun at the horizon
behind the camera (front-lit) and in front of it (back-lit: the camera looks into the sun and
sees the shape's shaded side). Both images are encoded by the project's pixel encoder
(``frontend.image_encoder``); the figure is 1 - cosine, per family and as the mean over
families and views (and, to show where it comes from, with each of the encoder's colour,
gradient and texture blocks alone).

Light: the world's lighting equation (``world.appearance.LightingSpec``: colour times
``ambient + headlight * cos(view angle) + sun * colour * cos(sun angle)``, clipped at 1) with a
preset's intensities and sun colour and the sun moved to the horizon. A Lambertian face turned
away from the sun gets nothing from it, so back-lit every face the camera sees shows ambient and
headlight only; front-lit the sun adds ``sun * cos(view angle)``. Shadows are left out and change
neither image: with the sun exactly behind the orthographic camera every face the camera sees is
seen by the sun too, and with it exactly in front every face the camera sees is turned away.

The ambient share is the world's default lighting's (``noon``: sun 0.5, ambient 0.3, headlight
0.2, a sun share of 0.5); under the sun alone (share 1) a back-lit face would be black and show
the encoder nothing. ``lighting_fall`` is the drop at the encoder term's full strength (share 1,
at the horizon) and the term is linear in its strength ``share * cos(elevation)``, so the figure
compared with it is the measured drop over the sun share. The other presets (``morning``,
``evening``, ``overcast``, the sun at the horizon likewise) are measured too, to show how far
that linear scaling holds.

Why the rasteriser and not MuJoCo: it is the renderer the appearance weights were measured with
(``benchmarks/measure_appearance.py``), it draws the world's lighting equation without building a
world and a camera per family, and the whole measurement takes seconds.

``SemanticConfig.lighting_fall``'s default is the noon figure rounded to 0.01 (the docs test
checks it against the committed JSON, which records the default it was written with).

Writes ``benchmarks/out/lighting_fall.json``.

Usage: python benchmarks/measure_lighting.py
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from roman_sim.core.atomic import write_json
from roman_sim.frontend.image_encoder import ImageEncoder, ImageEncoderConfig
from roman_sim.frontend.semantics import SemanticConfig
from roman_sim.frontend.view_asymmetry import Light, rasterise
from roman_sim.interop.looks import scene_light
from roman_sim.world.appearance import LIGHTING, LightingSpec
from roman_sim.world.assets import FAMILIES
from roman_sim.world.catalog import variant_parts

OUT = Path(__file__).resolve().parent / "out" / "lighting_fall.json"
VIEWS = (0.0, 1.3, 2.6, 3.9, 5.2)
SIZE = 96
PRESET = "noon"  # the worlds' default lighting
CHECKS = ("morning", "evening", "overcast")
BLOCKS = ("colour", "orient", "lbp")  # the pixel encoder's blocks, measured one at a time under PRESET


def horizon_lights(spec: LightingSpec, azimuth: float) -> tuple[Light, Light]:
    """(front-lit, back-lit) lights of ``spec`` for a camera looking along ``azimuth`` (camera -> object):
    the sun at the horizon behind the camera, and in front of it."""
    x, y = float(np.cos(azimuth)), float(np.sin(azimuth))
    r, g, b = (float(spec.sun * c) for c in spec.colour)
    front = Light((-x, -y, 0.0), (r, g, b), spec.ambient, spec.headlight)
    back = Light((x, y, 0.0), (r, g, b), spec.ambient, spec.headlight)
    return front, back


def _encode(enc: ImageEncoder, img: np.ndarray) -> np.ndarray:
    mask = img.sum(axis=2) > 0
    return enc.encode(np.round(np.clip(img, 0, 1) * 255).astype(np.uint8), mask, None).astype(np.float64)


def drop(enc: ImageEncoder, mesh: list, spec: LightingSpec) -> float:
    """Mean over ``VIEWS`` of 1 - cosine between the front-lit and the back-lit encodings of ``mesh``."""
    out = []
    for az in VIEWS:
        front, back = horizon_lights(spec, az)
        a = _encode(enc, rasterise(mesh, az, SIZE, light=front))
        b = _encode(enc, rasterise(mesh, az, SIZE, light=back))
        out.append(1.0 - float(a @ b))
    return float(np.mean(out))


def measure() -> dict[str, object]:
    """Per preset: the sun share, the mean front-lit against back-lit drop per family and overall,
    and that drop over the share; the drop under ``PRESET`` with each encoder block alone; and the
    configured default it is compared with."""
    enc = ImageEncoder()
    meshes: dict[str, list] = {
        fam: [(p.mesh.vertices, p.mesh.faces, np.asarray(p.rgba[:3])) for p in variant_parts(0, fam, 0)]
        for fam in FAMILIES.names()
    }
    presets: dict[str, dict[str, object]] = {}
    for name in (PRESET, *CHECKS):
        spec = LIGHTING.get(name)
        share = scene_light(spec, 0.0, 0.0).strength  # the encoder term's strength: the sun share at the horizon
        per = {fam: drop(enc, mesh, spec) for fam, mesh in meshes.items()}
        mean = float(np.mean(list(per.values())))
        presets[name] = {
            "sun": spec.sun,
            "ambient": spec.ambient,
            "headlight": spec.headlight,
            "sun_share": share,
            "per_family": per,
            "one_minus_cos": mean,
            "per_share": mean / share if share > 0 else None,
        }
    spec = LIGHTING.get(PRESET)
    blocks = {}
    for block in BLOCKS:
        alone = ImageEncoder(ImageEncoderConfig(**{f"{b}_weight": float(b == block) for b in BLOCKS}))
        blocks[block] = float(np.mean([drop(alone, mesh, spec) for mesh in meshes.values()]))
    main = presets[PRESET]
    return {
        "preset": PRESET,
        "views": list(VIEWS),
        "size": SIZE,
        "one_minus_cos": main["one_minus_cos"],
        "sun_share": main["sun_share"],
        "lighting_fall": main["per_share"],
        "configured_default": SemanticConfig().lighting_fall,
        "blocks": blocks,
        "presets": presets,
    }


def main() -> None:
    out = measure()
    write_json(OUT, out)
    summary = {k: out[k] for k in ("one_minus_cos", "sun_share", "lighting_fall", "configured_default")}
    summary["per_share"] = {k: v["per_share"] for k, v in out["presets"].items()}  # type: ignore[attr-defined]
    print(json.dumps(summary, indent=1))  # noqa: T201


if __name__ == "__main__":
    main()
