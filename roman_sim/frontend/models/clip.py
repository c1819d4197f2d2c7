"""CLIP as the semantic encoder: the image embedding of each mask's bounding-box crop.

This is the paper's front end (CLIP ViT-L/14, 768-d projected embedding, compared with
cosine thresholds 0.85 / 1.0). The model is ``CLIPVisionModelWithProjection`` loaded from
``params.weights`` (a CLIP or CLIP-vision folder); pre-processing (resize, centre crop,
normalisation) is the folder's own image processor. Crops are embedded in batches of
``batch_size`` and unit-normalised.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from roman_sim.frontend.models.common import (
    box_crops,
    load_libraries,
    load_pretrained,
    set_threads,
    unit_rows,
    weights_dir,
)
from roman_sim.frontend.models.config import ClipConfig
from roman_sim.mapping.mask import Mask

FIELD = "frontend.encoder.params.weights"


class ClipEncoder:
    """``encode`` / ``encode_batch`` with a local CLIP vision model (see the module docstring)."""

    needs_rgb = True
    reads_truth = False

    def __init__(self, cfg: ClipConfig) -> None:
        self.cfg = cfg
        path = weights_dir(cfg.weights, FIELD, ("clip", "clip_vision_model"))
        self._torch, tf = load_libraries("encoder 'clip'")
        set_threads(self._torch, cfg.threads)
        self.model = load_pretrained(tf.CLIPVisionModelWithProjection, path, FIELD).eval()
        self.processor = load_pretrained(tf.AutoImageProcessor, path, FIELD, backend="pil")
        self.dim = int(self.model.config.projection_dim)

    def embed_crops(self, crops: list[NDArray[np.uint8]]) -> NDArray[np.float32]:
        """(N, dim) unit embeddings of RGB crops, ``batch_size`` at a time."""
        out = np.zeros((len(crops), self.dim), dtype=np.float32)
        for k in range(0, len(crops), self.cfg.batch_size):
            chunk = crops[k : k + self.cfg.batch_size]
            inputs = self.processor(images=chunk, return_tensors="pt", input_data_format="channels_last")
            with self._torch.inference_mode():
                emb = self.model(pixel_values=inputs["pixel_values"]).image_embeds
            out[k : k + len(chunk)] = unit_rows(emb.float().numpy())
        return out

    def encode(self, rgb_crop: NDArray[np.uint8] | None, mask: NDArray[np.bool_], context: Any) -> NDArray[np.float32]:
        """Unit embedding of one bounding-box crop (``mask`` is not used: CLIP sees the whole box)."""
        if rgb_crop is None:
            raise _no_rgb()
        whole = Mask(np.ones(rgb_crop.shape[:2], dtype=bool))
        return self.embed_crops(box_crops(rgb_crop, [whole], self.cfg.min_crop_px))[0]

    def encode_batch(
        self, rgb: NDArray[np.uint8] | None, masks: list[Mask], contexts: list[Any]
    ) -> NDArray[np.float32]:
        """(N, dim) unit embeddings of every mask's box crop of one frame."""
        if rgb is None:
            raise _no_rgb()
        return self.embed_crops(box_crops(np.asarray(rgb), masks, self.cfg.min_crop_px))


def _no_rgb() -> Exception:
    from roman_sim.core.errors import MappingError

    return MappingError("encoder 'clip': the frame has no RGB (set render_rgb: true)")
