"""A bag-of-binary-words vocabulary as DBoW2 builds and uses it.

Written here because no maintained Python package does it well: ``pydbow`` (0.1.2, 2022)
loops in Python per descriptor, seeds from numpy's global RNG, scores with an L2 norm and
stores pickles; ``dbow3py`` (0.0.4, 2020) is a source-only CMake build against C++ DBoW3,
OpenCV and Boost; ``pydbow3`` is not on the package index.

Training (DBoW2's ``HKmeansStep``): hierarchical k-majority clustering under Hamming
distance, ``k`` branches, ``L`` levels. A node with at most ``k`` descriptors gets one
child per descriptor; otherwise k-means++ seeding (first centre uniform, each next one
drawn with probability proportional to D(x)^2) and Lloyd iterations (assign to the nearest
centre, centre = bitwise majority) until the assignment stops changing or
``max_iterations``. Children with a single descriptor, and nodes at level ``L``, are
words. Each node draws from its own stream ``child_rng(seed, "vocabulary", node)``, so
the same seed and descriptors give the same bytes.

Weights: tf-idf. ``idf(w) = log(N / N_w)`` over the N training images, N_w of them
containing word w. A BoW vector adds ``idf(w)`` per feature landing in w (words of weight
0 are skipped) and is L1-normalised; DBoW2's L1 score of two such vectors is
``s = 1 - 0.5 |v1 - v2|_1``, which equals the sum over shared words of ``min(v1_w, v2_w)``.
"""

from __future__ import annotations

import logging
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from roman_sim.align.visual.bow import BowVector
from roman_sim.align.visual.hamming import hamming, hamming_matrix, majority_by_label
from roman_sim.core.atomic import write_npz
from roman_sim.core.errors import ConfigError, StorageError
from roman_sim.core.records import OMIT_NONE, RecordError, dumps_record, loads_record
from roman_sim.core.seeding import child_rng

log = logging.getLogger(__name__)

VOCABULARY_FORMAT = "roman_sim.orb_vocabulary"
VOCABULARY_VERSION = 1


@dataclass(frozen=True)
class TrainingFacts:
    """How a vocabulary was trained: seed, k-majority iterations, images and descriptors, and (for
    the bundled one) the image size and the training worlds (preset, seed, lighting)."""

    seed: int
    max_iterations: int
    n_images: int
    n_descriptors: int
    image_size: tuple[int, int] | None = field(default=None, metadata=OMIT_NONE)
    worlds: list[tuple[str, int, str]] | None = field(default=None, metadata=OMIT_NONE)


@dataclass(frozen=True)
class VocabularyHeader:
    """The header of a vocabulary file: format, version, branching, depth and the training facts."""

    format: str
    version: int
    k: int
    L: int
    meta: TrainingFacts


#: (preset, seed, lighting preset) of the worlds the shipped vocabulary is trained on
#: (``tools/train_vocabulary.py``): far from every scenario's seed.
TRAINING_WORLDS: tuple[tuple[str, int, str], ...] = (
    ("forest", 9101, "noon"),
    ("orchard", 9102, "morning"),
    ("park", 9103, "evening"),
    ("suburb", 9104, "overcast"),
    ("offroad", 9105, "random"),
    ("parking", 9106, "noon"),
)


@dataclass
class Vocabulary:
    """A trained vocabulary tree.

    Attributes:
        k: branching factor.
        L: depth (levels below the root).
        centers: (n_nodes, 32) uint8 node centres; node 0 is the root (centre unused).
        parent: (n_nodes,) int32 parent node (-1 for the root); children follow their
            parent in breadth-first order.
        word_of_node: (n_nodes,) int32 word id of a leaf, -1 for internal nodes.
        weights: (n_words,) float32 idf weight per word.
        meta: training facts (seed, images, descriptors, iterations).
    """

    k: int
    L: int
    centers: NDArray[np.uint8]
    parent: NDArray[np.int32]
    word_of_node: NDArray[np.int32]
    weights: NDArray[np.float32]
    meta: TrainingFacts

    def __post_init__(self) -> None:
        n = len(self.parent)
        self.children = np.full((n, self.k), -1, dtype=np.int32)
        fill = np.zeros(n, dtype=np.int64)
        for node in range(1, n):
            p = int(self.parent[node])
            self.children[p, fill[p]] = node
            fill[p] += 1

    @property
    def n_words(self) -> int:
        """Number of words (leaves)."""
        return len(self.weights)

    def words(self, descriptors: NDArray[np.uint8]) -> NDArray[np.int32]:
        """Word id of each descriptor (n, 32): greedy descent to the nearest child per level."""
        d = np.ascontiguousarray(descriptors, dtype=np.uint8)
        node = np.zeros(len(d), dtype=np.int32)
        for _ in range(self.L):
            ch = self.children[node]
            active = ch[:, 0] >= 0
            if not active.any():
                break
            cha = ch[active]
            dist = hamming(d[active][:, None, :], self.centers[np.maximum(cha, 0)])
            dist[cha < 0] = np.iinfo(np.int32).max
            node[active] = cha[np.arange(len(cha)), np.argmin(dist, axis=1)]
        return self.word_of_node[node]

    def transform(self, descriptors: NDArray[np.uint8]) -> BowVector:
        """The L1-normalised tf-idf BoW vector of one image's descriptors."""
        if len(descriptors) == 0:
            return BowVector.empty()
        w = self.words(descriptors)
        wt = self.weights[w]
        keep = wt > 0
        ids, inv = np.unique(w[keep], return_inverse=True)
        vals = np.bincount(inv.reshape(-1), weights=wt[keep].astype(np.float64), minlength=len(ids))
        total = vals.sum()
        if total <= 0:
            return BowVector.empty()
        return BowVector(ids.astype(np.int32), (vals / total).astype(np.float32))

    def save(self, path: str | Path) -> None:
        """Write the vocabulary atomically as an ``.npz`` (packed uint8 centres + weights)."""
        header = VocabularyHeader(VOCABULARY_FORMAT, VOCABULARY_VERSION, self.k, self.L, self.meta)
        write_npz(
            path,
            header=np.frombuffer(dumps_record(header).encode(), dtype=np.uint8),
            centers=self.centers,
            parent=self.parent,
            word_of_node=self.word_of_node,
            weights=self.weights,
        )

    @classmethod
    def load(cls, path: str | Path) -> Vocabulary:
        """Read a file written by ``save``.

        Raises:
            StorageError: missing, unreadable or of another format/version.
        """
        path = Path(path)
        if not path.is_file():
            raise StorageError(f"{path}: vocabulary file not found")
        try:
            with np.load(path, allow_pickle=False) as z:
                a = {k: z[k] for k in z.files}
            h = loads_record(a.pop("header").tobytes(), VocabularyHeader, f"{path}: header")
            if h.format != VOCABULARY_FORMAT or h.version != VOCABULARY_VERSION:
                raise StorageError(f"{path}: not a version-{VOCABULARY_VERSION} ORB vocabulary")
            return cls(h.k, h.L, a["centers"], a["parent"], a["word_of_node"], a["weights"], h.meta)
        except RecordError:
            raise
        except (OSError, ValueError, KeyError, EOFError) as err:
            raise StorageError(f"{path}: not a readable vocabulary ({type(err).__name__})") from None


def _kmeanspp(x: NDArray[np.uint8], k: int, rng: np.random.Generator) -> NDArray[np.uint8]:
    """k-means++ seeding under Hamming distance (fewer centres if all points are covered)."""
    centers = [x[rng.integers(len(x))]]
    dmin = hamming(x, centers[0][None, :]).astype(np.float64)
    while len(centers) < k:
        w = dmin * dmin
        total = w.sum()
        if total <= 0:
            break
        c = x[rng.choice(len(x), p=w / total)]
        centers.append(c)
        np.minimum(dmin, hamming(x, c[None, :]), out=dmin)
    return np.stack(centers)


def _kmajority(x: NDArray[np.uint8], k: int, rng: np.random.Generator, max_iter: int) -> tuple[NDArray, NDArray]:
    """Cluster ``x`` into at most k groups: (centres (c, 32), labels (m,) in 0..c-1)."""
    if len(x) <= k:
        return x.copy(), np.arange(len(x))
    centers = _kmeanspp(x, k, rng)
    labels = np.argmin(hamming_matrix(x, centers), axis=1)
    for _ in range(max_iter):
        new, nonempty = majority_by_label(x, labels, len(centers))
        centers = np.where(nonempty[:, None], new, centers)
        nxt = np.argmin(hamming_matrix(x, centers), axis=1)
        if np.array_equal(nxt, labels):
            break
        labels = nxt
    used, labels = np.unique(labels, return_inverse=True)
    return centers[used], labels.reshape(-1)


def train_vocabulary(
    images: list[NDArray[np.uint8]], k: int = 10, L: int = 4, seed: int = 0, max_iterations: int = 10
) -> Vocabulary:
    """Train a vocabulary on the ORB descriptors of ``images`` (one (n_i, 32) array each).

    Raises:
        ConfigError: bad ``k``/``L``, or no descriptors at all.
    """
    if not 2 <= k <= 64 or not 1 <= L <= 8:
        raise ConfigError(f"vocabulary: k must be in [2, 64] and L in [1, 8], got k={k}, L={L}")
    x = (
        np.concatenate([np.asarray(d, np.uint8).reshape(-1, 32) for d in images])
        if images
        else np.zeros((0, 32), np.uint8)
    )
    if len(x) == 0:
        raise ConfigError("vocabulary: no training descriptors")
    centers, parent, level = [np.zeros(32, np.uint8)], [-1], [0]
    queue = deque([(0, np.arange(len(x)))])
    leaves: list[int] = []
    while queue:
        node, idx = queue.popleft()
        if level[node] == L or len(idx) <= 1:
            leaves.append(node)
            continue
        cc, labels = _kmajority(x[idx], k, child_rng(seed, "vocabulary", node), max_iterations)
        for c in range(len(cc)):
            centers.append(cc[c])
            parent.append(node)
            level.append(level[node] + 1)
            queue.append((len(parent) - 1, idx[labels == c]))
    word_of_node = np.full(len(parent), -1, dtype=np.int32)
    word_of_node[np.array(sorted(leaves))] = np.arange(len(leaves), dtype=np.int32)
    meta = TrainingFacts(seed, max_iterations, len(images), len(x))
    voc = Vocabulary(
        k,
        L,
        np.stack(centers).astype(np.uint8),
        np.asarray(parent, np.int32),
        word_of_node,
        np.zeros(len(leaves), np.float32),
        meta,
    )
    voc.weights = idf_weights(voc, images)
    log.info("vocabulary: %d words from %d descriptors of %d images", voc.n_words, len(x), len(images))
    return voc


def idf_weights(voc: Vocabulary, images: list[NDArray[np.uint8]]) -> NDArray[np.float32]:
    """``log(N / N_w)`` per word over the N images (0 for a word no image contains)."""
    n_w = np.zeros(voc.n_words, dtype=np.int64)
    for d in images:
        if len(d):
            n_w[np.unique(voc.words(np.asarray(d, np.uint8)))] += 1
    with np.errstate(divide="ignore"):
        w = np.where(n_w > 0, np.log(len(images) / np.maximum(n_w, 1)), 0.0)
    return w.astype(np.float32)
