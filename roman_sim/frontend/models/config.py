"""Parameters of the model adapters (importable without torch or transformers)."""

from __future__ import annotations

from pathlib import Path

from pydantic import Field

from roman_sim.core.config import StrictModel
from roman_sim.mapping.mask_filter import MaskFilterConfig


class ModelConfig(StrictModel):
    """A local model folder (``save_pretrained`` layout: config, weights, preprocessor config)."""

    weights: Path = Field(..., description="local model folder; nothing is ever downloaded")
    batch_size: int = Field(16, ge=1, le=1024, description="images (or prompt points) per forward pass")
    threads: int | None = Field(None, ge=1, le=256, description="torch CPU threads (None: torch's default)")


class ClipConfig(ModelConfig):
    """CLIP image encoder on the mask's bounding-box crop (the paper: ViT-L/14, 768-d)."""

    min_crop_px: int = Field(2, ge=1, description="crops are grown to at least this many pixels per side")


class Dinov2Config(ModelConfig):
    """DINOv2 patch features averaged over the mask (the current reference: DINOv2-base, 768-d)."""

    short_side_patches: int = Field(
        16, ge=1, le=128, description="patches along the image's shorter side (16 x 14 = 224 px for DINOv2)"
    )


class SamConfig(ModelConfig, MaskFilterConfig):
    """Segment Anything as an automatic mask generator, then ROMAN's mask filter."""

    points_per_side: int = Field(16, ge=1, le=128, description="grid of point prompts per image side")
    pred_iou_thresh: float = Field(0.88, ge=0, le=1, description="smallest predicted IoU a mask keeps")
    stability_score_thresh: float = Field(0.95, ge=0, le=1)
    stability_score_offset: float = Field(1.0, ge=0)
    nms_iou: float = Field(0.7, gt=0, le=1, description="box IoU above which the lower-scored mask is dropped")
