"""DINOv2 as the semantic encoder: patch features averaged over each mask.

The current reference implementation's front end (DINOv2-base, 768-d, cosine thresholds
0.5 / 0.7). The whole frame goes through ``Dinov2Model`` once, resized (no centre crop, so
every mask stays inside) to ``short_side_patches`` patches along its shorter side and the
proportional number along the longer one, normalised by the folder's image processor. Each
mask's descriptor is the mean of the patch tokens weighted by the share of each patch cell
the mask covers (the same as averaging the features upsampled to pixels with nearest
interpolation), unit-normalised.
"""

from __future__ import annotations

from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from roman_sim.core.errors import MappingError
from roman_sim.frontend.models.common import load_libraries, load_pretrained, set_threads, unit_rows, weights_dir
from roman_sim.frontend.models.config import Dinov2Config
from roman_sim.mapping.mask import Mask

FIELD = "frontend.encoder.params.weights"


class Dinov2Encoder:
    """``encode_batch`` / ``encode`` with a local DINOv2 model (see the module docstring)."""

    needs_rgb = True
    reads_truth = False

    def __init__(self, cfg: Dinov2Config) -> None:
        self.cfg = cfg
        path = weights_dir(cfg.weights, FIELD, ("dinov2",))
        self._torch, tf = load_libraries("encoder 'dinov2'")
        set_threads(self._torch, cfg.threads)
        self.model = load_pretrained(tf.Dinov2Model, path, FIELD).eval()
        self.processor = load_pretrained(tf.AutoImageProcessor, path, FIELD, backend="pil")
        self.patch = int(self.model.config.patch_size)
        self.dim = int(self.model.config.hidden_size)

    def grid(self, shape: tuple[int, int]) -> tuple[int, int]:
        """(rows, cols) of the patch grid for an image of ``shape``."""
        h, w = shape
        n = self.cfg.short_side_patches
        return (n, max(1, round(n * w / h))) if h <= w else (max(1, round(n * h / w)), n)

    def patch_features(self, rgb: NDArray[np.uint8]) -> NDArray[np.float32]:
        """(rows, cols, dim) patch tokens of one image."""
        gh, gw = self.grid(rgb.shape[:2])
        inputs = self.processor(
            images=[np.ascontiguousarray(rgb)],
            return_tensors="pt",
            do_center_crop=False,
            size={"height": gh * self.patch, "width": gw * self.patch},
            input_data_format="channels_last",
        )
        with self._torch.inference_mode():
            tokens = self.model(pixel_values=inputs["pixel_values"]).last_hidden_state[0]
        n_reg = int(getattr(self.model.config, "num_register_tokens", 0) or 0)
        patches = tokens[1 + n_reg :].float().numpy()
        return patches.reshape(gh, gw, self.dim)

    def cell_weights(self, pixels: NDArray[np.bool_], grid: tuple[int, int]) -> NDArray[np.float64]:
        """(rows, cols) share of each patch cell covered by the mask."""
        share = cv2.resize(pixels.astype(np.float32), (grid[1], grid[0]), interpolation=cv2.INTER_AREA)
        return share.astype(np.float64)

    def encode_batch(
        self, rgb: NDArray[np.uint8] | None, masks: list[Mask], contexts: list[Any]
    ) -> NDArray[np.float32]:
        """(N, dim) unit mask-averaged features of one frame (one forward pass)."""
        if rgb is None:
            raise MappingError("encoder 'dinov2': the frame has no RGB (set render_rgb: true)")
        if not masks:
            return np.zeros((0, self.dim), dtype=np.float32)
        feats = self.patch_features(np.asarray(rgb))
        grid = feats.shape[:2]
        W = np.stack([self.cell_weights(m.pixels, grid).ravel() for m in masks])
        return unit_rows(W @ feats.reshape(-1, self.dim).astype(np.float64))

    def encode(self, rgb_crop: NDArray[np.uint8] | None, mask: NDArray[np.bool_], context: Any) -> NDArray[np.float32]:
        """Unit descriptor of one mask given its crop (the crop is the image the model sees)."""
        if rgb_crop is None:
            raise MappingError("encoder 'dinov2': the frame has no RGB (set render_rgb: true)")
        return self.encode_batch(rgb_crop, [Mask(np.asarray(mask, dtype=bool))], [context])[0]
