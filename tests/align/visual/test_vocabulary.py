"""The vocabulary: determinism, clustering of known prototypes, idf weights, the shipped file."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest

from roman_sim.align.visual import default_vocabulary
from roman_sim.align.visual.bow import l1_score
from roman_sim.align.visual.vocabulary import TRAINING_WORLDS, Vocabulary, train_vocabulary
from roman_sim.core.errors import ConfigError, StorageError


def _flip(rng: np.random.Generator, proto: np.ndarray, n: int, bits: int) -> np.ndarray:
    """``n`` copies of ``proto`` (32,) with ``bits`` random bits flipped each."""
    b = np.tile(np.unpackbits(proto), (n, 1))
    for row in b:
        row[rng.choice(256, bits, replace=False)] ^= 1
    return np.packbits(b, axis=1)


def _images(seed: int = 0, n_protos: int = 4, per_image: int = 12, n_images: int = 10):
    """Images whose descriptors are noisy copies (8 of 256 bits flipped) of a few prototypes."""
    rng = np.random.default_rng(seed)
    protos = rng.integers(0, 256, (n_protos, 32), dtype=np.uint8)
    labels, images = [], []
    for i in range(n_images):
        lab = rng.integers(0, n_protos, per_image) if i else np.arange(per_image) % n_protos
        images.append(np.concatenate([_flip(rng, protos[j], 1, 8) for j in lab]))
        labels.append(lab)
    return protos, images, labels


def _sha(tmp_path, voc: Vocabulary, name: str) -> str:
    voc.save(tmp_path / name)
    return hashlib.sha256((tmp_path / name).read_bytes()).hexdigest()


def test_same_seed_same_bytes_other_seed_other_tree(tmp_path) -> None:
    rng = np.random.default_rng(3)
    images = [rng.integers(0, 256, (50, 32), dtype=np.uint8) for _ in range(8)]
    a = _sha(tmp_path, train_vocabulary(images, k=5, L=3, seed=7), "a.npz")
    b = _sha(tmp_path, train_vocabulary(images, k=5, L=3, seed=7), "b.npz")
    c = _sha(tmp_path, train_vocabulary(images, k=5, L=3, seed=8), "c.npz")
    assert a == b and a != c
    voc = Vocabulary.load(tmp_path / "a.npz")
    assert voc.n_words <= 5**3 and voc.k == 5 and voc.L == 3 and voc.meta.n_descriptors == 400


def test_one_level_recovers_the_prototypes_and_idf_by_hand() -> None:
    protos, images, labels = _images()
    voc = train_vocabulary(images, k=4, L=1, seed=0)
    assert voc.n_words == 4
    words = [voc.words(d) for d in images]
    # a word per prototype: descriptors of the same prototype share a word, others do not
    lab, w = np.concatenate(labels), np.concatenate(words)
    for j in range(4):
        assert len(set(w[lab == j])) == 1
    assert len(set(w)) == 4
    # every centre is its prototype (the bit majority of noisy copies)
    for j in range(4):
        centre = voc.centers[voc.word_of_node == w[lab == j][0]][0]
        assert np.unpackbits(centre ^ protos[j]).sum() <= 2
    # idf = log(N / N_w), N_w = images containing the word
    n_w = np.array([sum(word in set(ws) for ws in words) for word in range(4)])
    np.testing.assert_allclose(voc.weights, np.log(10 / n_w), rtol=1e-6)


def test_bow_vector_is_l1_normalised_tf_idf() -> None:
    _, images, _ = _images(n_protos=8, n_images=20)
    voc = train_vocabulary(images, k=8, L=1, seed=0)
    d = images[3]
    v = voc.transform(d)
    assert v.values.sum() == pytest.approx(1.0, abs=1e-6) and np.all(np.diff(v.words) > 0)
    w = voc.words(d)
    raw = np.bincount(w, weights=voc.weights[w], minlength=voc.n_words)
    raw = raw[raw > 0] / raw.sum()
    np.testing.assert_allclose(v.values, raw, rtol=1e-6)
    assert l1_score(v, v) == pytest.approx(1.0, abs=1e-6)
    assert len(voc.transform(np.zeros((0, 32), np.uint8))) == 0


def test_bad_training_input_and_bad_files(tmp_path) -> None:
    with pytest.raises(ConfigError, match="k must be"):
        train_vocabulary([np.zeros((3, 32), np.uint8)], k=1)
    with pytest.raises(ConfigError, match="no training descriptors"):
        train_vocabulary([np.zeros((0, 32), np.uint8)])
    with pytest.raises(StorageError, match="not found"):
        Vocabulary.load(tmp_path / "missing.npz")
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    with pytest.raises(StorageError, match="not a readable vocabulary"):
        Vocabulary.load(tmp_path / "junk.npz")


def test_shipped_vocabulary_is_trained_on_worlds_no_scenario_uses() -> None:
    voc = default_vocabulary()
    assert (voc.k, voc.L) == (10, 4) and 5000 < voc.n_words <= 10**4
    assert voc.meta.worlds is not None and [tuple(w) for w in voc.meta.worlds] == [tuple(w) for w in TRAINING_WORLDS]
    assert all(seed >= 9000 for _, seed, _ in TRAINING_WORLDS)
    assert np.all(voc.weights >= 0) and (voc.weights > 0).mean() > 0.9


def test_keyframe_scores_itself_one_and_an_unrelated_image_lower(shooter, other_shooter) -> None:
    voc = default_vocabulary()
    _, f = shooter.features(0.0, 0.0, 0.0)
    _, g = shooter.features(0.3, 0.1, 5.0)
    _, h = other_shooter.features(0.0, 0.0, 0.0)
    v, vg, vh = voc.transform(f.descriptors), voc.transform(g.descriptors), voc.transform(h.descriptors)
    assert l1_score(v, v) == pytest.approx(1.0, abs=1e-5)
    assert l1_score(v, vh) < l1_score(v, vg) < 1.0
