"""Re-train the shipped ORB vocabulary: ``python tools/train_vocabulary.py [--out PATH] [--check]``.

Training frames come from worlds no evaluation uses: every world preset at its own seed
(9101 + preset index, far from the scenarios' seeds), textured, each under another
lighting preset, one robot driving a loop, an RGB-D frame every ``frame_every`` steps at
640 x 480 (the D455 camera), ``frames_per_world`` frames each. ORB (the keyframes'
settings, ``OrbParams()``) runs on every frame; the vocabulary (k = 10, L = 4, seed 0) is
trained on their descriptors. Rendering and ORB are deterministic on one
machine, so the same command writes the same bytes; ``--check`` re-trains and compares
with the shipped file (another CPU or Mesa build may render slightly different pixels).
"""

from __future__ import annotations

import argparse
import hashlib
import logging
import sys
import time
from dataclasses import replace
from importlib import resources
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from roman_sim.align.visual.features import (
    OrbParams,
    depth_mask,
    make_orb,
    orb_descriptors,
)
from roman_sim.align.visual.vocabulary import TRAINING_WORLDS, Vocabulary, train_vocabulary

log = logging.getLogger(__name__)

K, L, SEED = 10, 4, 0


def training_images(frames_per_world: int = 60, frame_every: int = 6) -> list[NDArray[np.uint8]]:
    """ORB descriptors (one (n_i, 32) array per frame) of the training frames."""
    from roman_sim.sim.paths import PathConfig
    from roman_sim.sim.robot import RobotConfig
    from roman_sim.sim.source import robot_sources
    from roman_sim.world import generate, load_world_spec
    from roman_sim.world.appearance import AppearanceSpec

    params = OrbParams()
    orb = make_orb(params)
    out = []
    for preset, seed, lighting in TRAINING_WORLDS:
        spec = load_world_spec(preset)
        spec = spec.model_copy(update={"appearance": AppearanceSpec(textures=True, lighting=lighting)})
        world = generate(spec, seed)
        cfg = RobotConfig(
            name="vocabulary",
            path=PathConfig(kind="loop", radius_m=12.0),
            max_length_m=frames_per_world * frame_every / 6.0 + 1.0,
        )
        taken = 0
        for i, frame in enumerate(robot_sources(world, [cfg], seed)[0].frames()):
            if i % frame_every or frame.rgb is None:
                continue
            mask = depth_mask(frame.depth, params.mask_erode_px) if params.depth_mask else None
            out.append(orb_descriptors(frame.rgb, orb, mask)[1])
            taken += 1
            if taken == frames_per_world:
                break
        log.info("%s seed %d: %d frames so far", preset, seed, len(out))
    return out


def train_default() -> Vocabulary:
    """The shipped vocabulary, trained from scratch."""
    t0 = time.perf_counter()
    images = training_images()
    t1 = time.perf_counter()
    voc = train_vocabulary(images, k=K, L=L, seed=SEED)
    voc.meta = replace(voc.meta, worlds=list(TRAINING_WORLDS), image_size=(640, 480))
    log.info("frames %.1f s, training %.1f s", t1 - t0, time.perf_counter() - t1)
    return voc


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def main(argv: list[str] | None = None) -> int:
    """Command-line entry point (see the module docstring)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    shipped = Path(str(resources.files("roman_sim.align.visual") / "data" / "orb_vocabulary.npz"))
    ap.add_argument("--out", type=Path, default=shipped, help="where to write (default: the shipped file)")
    ap.add_argument("--check", action="store_true", help="re-train into a temporary file and compare with --out")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    voc = train_default()
    target = args.out.with_suffix(".check.npz") if args.check else args.out
    voc.save(target)
    log.info("%s: %d words, %d bytes, sha256 %s", target, voc.n_words, target.stat().st_size, _sha(target))
    if args.check:
        same = args.out.is_file() and _sha(target) == _sha(args.out)
        target.unlink()
        log.info("identical to %s: %s", args.out, same)
        return 0 if same else 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
