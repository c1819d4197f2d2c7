"""Model adapters (CLIP, DINOv2, SAM) on tiny randomly initialised models saved to a local folder.

The models have the real classes and pre-processing; only their sizes are tiny, so the
whole adapter path (crop, pre-processing, batching, embedding, normalisation; prompt grid,
mask decoding, filtering) runs on rendered frames in seconds.
"""

import os

import numpy as np
import pytest
import torch
import transformers

from roman_sim.core.errors import ConfigError
from roman_sim.frontend.components import build_encoder, build_segmenter
from roman_sim.frontend.image_segmenter import ImageSegmenter
from roman_sim.frontend.models.common import box_crops
from roman_sim.frontend.models.config import ClipConfig, Dinov2Config, SamConfig
from roman_sim.mapping.mapper import Mapper
from roman_sim.mapping.mask import Mask
from roman_sim.mapping.tracker import MappingConfig


@pytest.fixture(scope="module")
def clip_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("clip")
    torch.manual_seed(0)
    cfg = transformers.CLIPVisionConfig(
        hidden_size=32,
        intermediate_size=37,
        num_hidden_layers=1,
        num_attention_heads=2,
        image_size=32,
        patch_size=8,
        projection_dim=16,
    )
    transformers.CLIPVisionModelWithProjection(cfg).save_pretrained(d)
    transformers.CLIPImageProcessorPil(
        size={"shortest_edge": 32}, crop_size={"height": 32, "width": 32}
    ).save_pretrained(d)
    return d


@pytest.fixture(scope="module")
def dino_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("dinov2")
    torch.manual_seed(1)
    cfg = transformers.Dinov2Config(
        hidden_size=32, num_hidden_layers=1, num_attention_heads=2, intermediate_size=37, patch_size=8, image_size=32
    )
    transformers.Dinov2Model(cfg).save_pretrained(d)
    transformers.BitImageProcessorPil(
        size={"shortest_edge": 32}, crop_size={"height": 32, "width": 32}
    ).save_pretrained(d)
    return d


@pytest.fixture(scope="module")
def sam_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("sam")
    torch.manual_seed(2)
    vision = transformers.SamVisionConfig(
        hidden_size=16,
        output_channels=16,
        num_hidden_layers=1,
        num_attention_heads=1,
        image_size=64,
        patch_size=16,
        mlp_dim=32,
        global_attn_indexes=[0],
        window_size=0,
        num_pos_feats=8,
    )
    prompt = transformers.SamPromptEncoderConfig(hidden_size=16, image_size=64, patch_size=16, mask_input_channels=4)
    decoder = transformers.SamMaskDecoderConfig(
        hidden_size=16, num_hidden_layers=1, num_attention_heads=1, mlp_dim=32, iou_head_hidden_dim=16
    )
    cfg = transformers.SamConfig(
        vision_config=vision.to_dict(), prompt_encoder_config=prompt.to_dict(), mask_decoder_config=decoder.to_dict()
    )
    transformers.SamModel(cfg).save_pretrained(d)
    transformers.SamImageProcessorPil(
        size={"longest_edge": 64},
        pad_size={"height": 64, "width": 64},
        mask_size={"longest_edge": 16},
        mask_pad_size={"height": 16, "width": 16},
    ).save_pretrained(d)
    return d


@pytest.fixture(scope="module")
def frame_and_masks(tiny_rgb_frames):
    perfect = build_segmenter("perfect")
    f = max(tiny_rgb_frames, key=lambda fr: len(perfect.segment(fr)))
    masks = perfect.segment(f)
    assert len(masks) >= 3
    return f, masks


def _reference_clip(model_dir, crops):
    proc = transformers.AutoImageProcessor.from_pretrained(model_dir, local_files_only=True, backend="pil")
    model = transformers.CLIPVisionModelWithProjection.from_pretrained(model_dir, local_files_only=True).eval()
    out = []
    for c in crops:
        with torch.inference_mode():
            e = model(**proc(images=[c], return_tensors="pt", input_data_format="channels_last")).image_embeds[0]
        out.append((e / e.norm()).numpy())
    return np.stack(out)


def test_clip_embeds_each_box_crop(clip_dir, frame_and_masks):
    f, masks = frame_and_masks
    enc = build_encoder({"name": "clip", "params": {"weights": str(clip_dir), "batch_size": 2}})
    assert enc.dim == 16 and os.environ["HF_HUB_OFFLINE"] == "1"
    E = enc.encode_batch(f.rgb, masks, [None] * len(masks))
    assert E.shape == (len(masks), 16) and E.dtype == np.float32
    np.testing.assert_allclose(np.linalg.norm(E, axis=1), 1.0, atol=1e-6)
    crops = [f.rgb[m.bbox[0] : m.bbox[1], m.bbox[2] : m.bbox[3]] for m in masks]
    big = [k for k, c in enumerate(crops) if min(c.shape[:2]) >= 2]
    assert len(big) >= 3
    np.testing.assert_allclose(E[big], _reference_clip(clip_dir, [crops[k] for k in big]), atol=1e-5)
    # A box smaller than 2 px is grown about its centre to 2 x 2 (CLIP's resize needs two pixels).
    dot = np.zeros(f.depth.shape, bool)
    dot[5, 7] = True
    np.testing.assert_array_equal(box_crops(f.rgb, [Mask(dot)], 2)[0], f.rgb[4:6, 6:8])
    one = build_encoder({"name": "clip", "params": {"weights": str(clip_dir), "batch_size": 64}})
    np.testing.assert_allclose(one.encode_batch(f.rgb, masks, [None] * len(masks)), E, atol=1e-5)
    np.testing.assert_allclose(enc.encode(crops[0], masks[0].pixels, None), E[0], atol=1e-5)
    assert float(np.min(E @ E.T)) < 0.999, "different crops give different embeddings"


def test_dinov2_averages_patch_features_over_the_mask(dino_dir, frame_and_masks):
    f, masks = frame_and_masks
    enc = build_encoder({"name": "dinov2", "params": {"weights": str(dino_dir), "short_side_patches": 4}})
    h, w = f.rgb.shape[:2]
    assert enc.grid((h, w)) == (4, 5) and enc.dim == 32
    feats = enc.patch_features(f.rgb)
    assert feats.shape == (4, 5, 32)
    cell = np.zeros((h, w), bool)
    cell[: h // 4, w // 5 : 2 * (w // 5)] = True  # exactly patch cell (0, 1)
    D = enc.encode_batch(f.rgb, [*masks, Mask(cell)], [None] * (len(masks) + 1))
    np.testing.assert_allclose(D[-1], feats[0, 1] / np.linalg.norm(feats[0, 1]), atol=1e-5)
    for k, m in enumerate(masks):  # coverage share of each 30 x 32 cell, counted by hand
        share = m.pixels.reshape(4, h // 4, 5, w // 5).mean(axis=(1, 3))
        v = np.tensordot(share, feats, axes=([0, 1], [0, 1]))
        np.testing.assert_allclose(D[k], v / np.linalg.norm(v), atol=1e-5)


def test_sam_decoding_steps_by_hand():
    from roman_sim.frontend.models.sam import box_nms, passing, stability_scores

    logits = np.full((3, 4, 4), -5.0, np.float32)
    logits[0, :2, :2] = 5.0  # crisp square: stable
    logits[1, :2, :2] = 0.5  # weak square: above 0 but below +1 -> unstable
    logits[1, 2:, 2:] = -0.5
    np.testing.assert_allclose(stability_scores(logits, 1.0), [1.0, 0.0, 0.0])
    cfg = SamConfig(weights="unused", pred_iou_thresh=0.5, stability_score_thresh=0.9)
    assert passing(logits, np.array([0.9, 0.9, 0.9], np.float32), cfg) == [0]
    assert passing(logits, np.array([0.4, 0.9, 0.9], np.float32), cfg) == []
    boxes = np.array([[0, 10, 0, 10], [1, 10, 0, 10], [20, 30, 20, 30]], float)
    assert box_nms(boxes, np.array([0.5, 0.9, 0.7]), 0.7) == [1, 2]
    assert box_nms(boxes, np.array([0.5, 0.9, 0.7]), 0.95) == [1, 2, 0]


def test_sam_generates_filtered_masks(sam_dir, frame_and_masks):
    f, _ = frame_and_masks
    params = {
        "weights": str(sam_dir),
        "points_per_side": 4,
        "batch_size": 5,
        "pred_iou_thresh": 0.0,
        "stability_score_thresh": 0.0,
        "min_area_div": 30.0,
        "max_area_div": 1.01,
    }
    seg = build_segmenter({"name": "sam", "params": params})
    cand, scores = seg.candidates(f.rgb)
    assert len(cand) == len(scores) > 0 and all(c.shape == f.depth.shape for c in cand)
    masks = seg.segment(f.public())
    assert masks and all(isinstance(m, Mask) and m.pixels.shape == f.depth.shape for m in masks)
    A = f.depth.size
    assert all(0 < m.area <= A / 1.01**2 for m in masks)
    again = seg.segment(f.public())
    assert [m.bbox for m in again] == [m.bbox for m in masks]
    strict = build_segmenter({"name": "sam", "params": {**params, "max_area_div": 29.0}})
    assert all(m.area <= A / 29.0**2 for m in strict.segment(f.public()))


def test_models_run_through_the_mapper(clip_dir, tiny_rgb_frames):
    enc = build_encoder({"name": "clip", "params": {"weights": str(clip_dir)}})
    m = Mapper(MappingConfig(), ImageSegmenter(), enc)
    for f in tiny_rgb_frames[:30]:
        m.process(f)
    segs = m.finish().segments
    assert segs and all(s.descriptor is not None and s.descriptor.shape == (16,) for s in segs)


def test_missing_or_broken_weights_are_one_line_errors(tmp_path, clip_dir):
    with pytest.raises(ConfigError, match="frontend.encoder.params.weights: no model folder") as err:
        build_encoder({"name": "clip", "params": {"weights": str(tmp_path / "nope")}})
    assert "\n" not in str(err.value)
    (tmp_path / "config.json").write_text('{"model_type": "dinov2"}')
    with pytest.raises(ConfigError, match="frontend.encoder.params.weights: cannot load Dinov2Model"):
        build_encoder({"name": "dinov2", "params": {"weights": str(tmp_path)}})
    with pytest.raises(
        ConfigError, match="frontend.segmenter.params.weights: .* holds a 'clip_vision_model' model, expected 'sam'"
    ):
        build_segmenter({"name": "sam", "params": {"weights": str(clip_dir)}})
    assert ClipConfig(weights="x").batch_size == 16 and Dinov2Config(weights="x").short_side_patches == 16
