"""Segment Anything as an automatic mask generator, then ROMAN's mask filter.

The image is embedded once (``SamModel.get_image_embeddings``); a regular grid of
``points_per_side`` x ``points_per_side`` point prompts is decoded ``batch_size`` points at
a time with three candidate masks each; masks are upsampled to the image by the folder's
image processor (``post_process_masks``), kept when their predicted IoU is at least
``pred_iou_thresh`` and their stability score (IoU of the mask thresholded at
+offset and -offset) at least ``stability_score_thresh``, de-duplicated by box
non-maximum suppression, and passed through ROMAN's area filter and erosion.

The suppression is written here in numpy because the transformers helper for it needs
torchvision, which does not install beside the pinned CPU torch.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.errors import MappingError
from roman_sim.core.sensors import Frame
from roman_sim.frontend.models.common import load_libraries, load_pretrained, set_threads, weights_dir
from roman_sim.frontend.models.config import SamConfig
from roman_sim.mapping.mask import Mask
from roman_sim.mapping.mask_filter import filter_masks

FIELD = "frontend.segmenter.params.weights"


class SamSegmenter:
    """``segment(frame)`` with a local SAM model (see the module docstring)."""

    needs_rgb = True
    reads_truth = False

    def __init__(self, cfg: SamConfig) -> None:
        self.cfg = cfg
        path = weights_dir(cfg.weights, FIELD, ("sam",))
        self._torch, tf = load_libraries("segmenter 'sam'")
        set_threads(self._torch, cfg.threads)
        self.model = load_pretrained(tf.SamModel, path, FIELD).eval()
        self.processor = load_pretrained(tf.AutoImageProcessor, path, FIELD, backend="pil")

    def segment(self, frame: Frame) -> list[Mask]:
        """Filtered masks of one frame (``frame.rgb`` required)."""
        if frame.rgb is None:
            raise MappingError(
                f"segmenter 'sam': frame {frame.index} of robot {frame.robot} has no RGB (set render_rgb: true)"
            )
        masks, scores = self.candidates(np.asarray(frame.rgb))
        if not masks:
            return []
        boxes = np.array([_box(m) for m in masks], dtype=np.float64)
        kept = box_nms(boxes, np.asarray(scores, dtype=np.float64), self.cfg.nms_iou)
        return filter_masks([masks[i] for i in kept], self.cfg)

    def points(self, shape: tuple[int, int]) -> NDArray[np.float64]:
        """(P, 2) grid prompts (x, y) in image pixels, cell centres."""
        h, w = shape
        n = self.cfg.points_per_side
        xs = (np.arange(n) + 0.5) * w / n
        ys = (np.arange(n) + 0.5) * h / n
        return np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)

    def candidates(self, rgb: NDArray[np.uint8]) -> tuple[list[NDArray[np.bool_]], list[float]]:
        """Binary masks at image size and their predicted IoUs that pass the IoU and stability tests.

        Three candidates per prompt; each batch of prompts is decoded, upsampled and tested
        before the next, so memory stays at one batch of logits.
        """
        torch = self._torch
        inputs = self.processor(
            images=[np.ascontiguousarray(rgb)], return_tensors="pt", input_data_format="channels_last"
        )
        orig, resized = inputs["original_sizes"], inputs["reshaped_input_sizes"]
        scale = np.array([float(resized[0][1]) / rgb.shape[1], float(resized[0][0]) / rgb.shape[0]])
        pts = self.points(rgb.shape[:2]) * scale
        masks: list[NDArray[np.bool_]] = []
        scores: list[float] = []
        with torch.inference_mode():
            emb = self.model.get_image_embeddings(inputs["pixel_values"])
            for k in range(0, len(pts), self.cfg.batch_size):
                chunk = torch.as_tensor(pts[k : k + self.cfg.batch_size], dtype=torch.float32)[None, :, None, :]
                labels = torch.ones(chunk.shape[:3], dtype=torch.long)
                out = self.model(image_embeddings=emb, input_points=chunk, input_labels=labels, multimask_output=True)
                up = self.processor.post_process_masks(out.pred_masks, orig, resized, binarize=False)[0]
                logits = up.reshape(-1, *up.shape[-2:]).float().numpy()
                iou = out.iou_scores[0].reshape(-1).float().numpy()
                for i in passing(logits, iou, self.cfg):
                    masks.append(logits[i] > 0.0)
                    scores.append(float(iou[i]))
        return masks, scores


def stability_scores(logits: NDArray[np.float32], offset: float) -> NDArray[np.float64]:
    """(M,) IoU of each mask thresholded at +offset with the same mask at -offset."""
    hi = (logits > offset).reshape(len(logits), -1).sum(axis=1)
    lo = (logits > -offset).reshape(len(logits), -1).sum(axis=1)
    return np.where(lo > 0, hi / np.maximum(lo, 1), 0.0)


def box_nms(boxes: NDArray[np.float64], scores: NDArray[np.float64], iou: float) -> list[int]:
    """Indices kept by greedy non-maximum suppression of (row0, row1, col0, col1) boxes, best first."""
    order = list(np.argsort(-scores, kind="stable"))
    area = (boxes[:, 1] - boxes[:, 0]) * (boxes[:, 3] - boxes[:, 2])
    keep: list[int] = []
    for i in order:
        ok = True
        for j in keep:
            ih = min(boxes[i, 1], boxes[j, 1]) - max(boxes[i, 0], boxes[j, 0])
            iw = min(boxes[i, 3], boxes[j, 3]) - max(boxes[i, 2], boxes[j, 2])
            inter = max(ih, 0) * max(iw, 0)
            if inter / max(area[i] + area[j] - inter, 1e-12) > iou:
                ok = False
                break
        if ok:
            keep.append(int(i))
    return keep


def passing(logits: NDArray[np.float32], scores: NDArray[np.float32], cfg: SamConfig) -> list[int]:
    """Indices of masks with predicted IoU >= ``pred_iou_thresh``, stability >= the threshold, non-empty."""
    stab = stability_scores(logits, cfg.stability_score_offset)
    nonempty = (logits > 0.0).reshape(len(logits), -1).any(axis=1)
    ok = (scores >= cfg.pred_iou_thresh) & (stab >= cfg.stability_score_thresh) & nonempty
    return [int(i) for i in np.flatnonzero(ok)]


def _box(m: NDArray[np.bool_]) -> tuple[int, int, int, int]:
    rows, cols = np.flatnonzero(m.any(axis=1)), np.flatnonzero(m.any(axis=0))
    return int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1
