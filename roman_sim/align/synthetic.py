"""Synthetic submap pairs with known ground truth, for tests and benchmarks of aligners.

Objects come from a few families (trunk, bush, rock, car, ...) with characteristic box
extents and semantic descriptors: a descriptor is a unit vector mixing a scene-wide
component (different families still have cosine about 0.6-0.7, as with CLIP features), a
family component and per-instance and per-view noise. Shared objects are seen by both
submaps with centre noise and slightly different extents and descriptors.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.errors import ConfigError
from roman_sim.core.geometry import inv_T, rot_z, transform_points
from roman_sim.core.seeding import child_rng
from roman_sim.mapping.types import Submap, SubmapTruth

#: Base box extents (m) of the object families.
FAMILY_EXTENTS = np.array(
    [
        [4.0, 0.45, 0.45],  # trunk
        [1.6, 1.3, 1.0],  # bush
        [1.1, 0.8, 0.6],  # rock
        [4.4, 1.8, 1.5],  # car
        [1.8, 0.8, 0.6],  # bench
        [5.0, 0.2, 0.2],  # pole
        [2.5, 2.5, 2.2],  # shed
        [1.2, 1.2, 0.9],  # bin
    ]
)


def _features(extents: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """Sorted extents, volumes and PCA (linearity, planarity, scattering) of solid boxes."""
    ext = -np.sort(-extents, axis=1)
    ev = ext**2 / np.sum(ext**2, axis=1, keepdims=True)
    shape = np.stack([(ev[:, 0] - ev[:, 1]) / ev[:, 0], (ev[:, 1] - ev[:, 2]) / ev[:, 0], ev[:, 2] / ev[:, 0]], 1)
    return ext, np.prod(ext, axis=1), shape


def _unit(x: NDArray) -> NDArray:
    return x / np.linalg.norm(x, axis=-1, keepdims=True)


class _Scene:
    """Objects in submap a's frame: positions, families, instance extents and descriptors."""

    def __init__(self, seed: int, dim: int, n_families: int) -> None:
        self.rng = child_rng(seed, "align", "synthetic")
        drng = child_rng(seed, "align", "synthetic", "families")
        self.common = _unit(drng.normal(size=dim))
        self.family_vecs = _unit(drng.normal(size=(n_families, dim)))
        self.n_families = n_families

    def positions(self, n: int, radius: float, center: tuple[float, float] = (0.0, 0.0)) -> NDArray:
        r = radius * np.sqrt(self.rng.random(n))
        th = self.rng.uniform(0, 2 * np.pi, n)
        z = self.rng.uniform(0.0, 5.0, n)
        return np.stack([center[0] + r * np.cos(th), center[1] + r * np.sin(th), z], 1)

    def instances(self, fam: NDArray) -> tuple[NDArray, NDArray]:
        """Per-object extents (family +-20 %) and instance descriptors."""
        base = FAMILY_EXTENTS[fam % len(FAMILY_EXTENTS)]
        ext = base * self.rng.uniform(0.8, 1.2, size=base.shape)
        dim = len(self.common)
        noise = _unit(self.rng.normal(size=(len(fam), dim)))
        desc = 0.8 * self.common + 0.55 * self.family_vecs[fam] + 0.2 * noise
        return ext, _unit(desc)

    def observe(self, ext: NDArray, desc: NDArray) -> tuple[NDArray, NDArray]:
        """One submap's view: extents +-5 %, descriptor with view noise."""
        e = ext * self.rng.uniform(0.95, 1.05, size=ext.shape)
        noise = _unit(self.rng.normal(size=desc.shape))
        return e, _unit(desc + 0.08 * noise).astype(np.float32)


def _submap(robot: str, centers: NDArray, ext: NDArray, desc: NDArray, ids: NDArray, T: NDArray) -> Submap:
    e, vol, shape = _features(ext)
    return Submap(
        robot=robot,
        index=0,
        t=0.0,
        T_odom_submap=np.eye(4),
        segment_ids=np.arange(len(centers), dtype=np.int64),
        centers=centers,
        volumes=vol,
        shape=shape,
        descriptors=desc,
        extents=e,
        truth=SubmapTruth(T_world_submap=T, object_ids=ids.astype(np.int64), purity=np.ones(len(centers))),
    )


def make_submap_pair(
    seed: int,
    n_inliers: int,
    n_outliers_a: int,
    n_outliers_b: int,
    T_a_b: NDArray | None = None,
    noise_m: float = 0.05,
    descriptor_dim: int = 768,
    repeated_layout: bool = False,
    n_families: int = 8,
    radius_m: float = 15.0,
) -> tuple[Submap, Submap, NDArray[np.int64]]:
    """Two submaps sharing ``n_inliers`` objects, with known relative pose ``T_a_b``.

    Args:
        seed: scenario seed (all randomness via ``child_rng``).
        n_inliers: objects seen by both submaps.
        n_outliers_a: objects seen by submap a only.
        n_outliers_b: objects seen by submap b only.
        T_a_b: 4x4 pose of b in a (maps b's points into a); default a 4-DoF pose.
        noise_m: std of the per-axis centre noise of each observation.
        descriptor_dim: semantic descriptor size.
        repeated_layout: a also holds an exact geometric copy of the shared layout (shifted
            by ``radius_m`` in x) made of other families, so that geometry alone is ambiguous.
        n_families: number of object families used.
        radius_m: objects are spread over a disc of this radius (heights 0-5 m).

    Returns: (submap_a, submap_b, true associations (n_inliers, 2) of (a_idx, b_idx)).

    Raises:
        ConfigError: negative counts or noise, descriptor_dim < 1, n_families < 2, or a
            ``T_a_b`` that is not a finite 4x4 matrix.
    """
    _check_args(n_inliers, n_outliers_a, n_outliers_b, noise_m, descriptor_dim, n_families, radius_m)
    T = np.asarray(T_a_b if T_a_b is not None else _default_T(), dtype=np.float64)
    if T.shape != (4, 4) or not np.all(np.isfinite(T)):
        raise ConfigError(f"T_a_b: expected a finite 4x4 matrix, got shape {T.shape}")
    sc = _Scene(seed, descriptor_dim, n_families)
    rng = sc.rng
    if repeated_layout:
        shared = sc.positions(n_inliers, radius_m / 2.5, (-radius_m / 2, 0.0))
    else:
        shared = sc.positions(n_inliers, radius_m)
    fam = rng.integers(0, n_families, n_inliers)
    ext_s, desc_s = sc.instances(fam)
    out_a, out_b = sc.positions(n_outliers_a, radius_m), sc.positions(n_outliers_b, radius_m)
    ext_a, desc_a = sc.instances(rng.integers(0, n_families, n_outliers_a))
    ext_b, desc_b = sc.instances(rng.integers(0, n_families, n_outliers_b))
    parts_a = [(shared, ext_s, desc_s), (out_a, ext_a, desc_a)]
    if repeated_layout:
        ext_d, desc_d = sc.instances((fam + 1 + rng.integers(0, n_families - 1, n_inliers)) % n_families)
        parts_a.append((shared + np.array([radius_m, 0.0, 0.0]), ext_d, desc_d))
    ca, ea, da = _stack_views(sc, parts_a, noise_m)
    parts_b = [(transform_points(inv_T(T), shared), ext_s, desc_s), (out_b, ext_b, desc_b)]
    cb, eb, db = _stack_views(sc, parts_b, noise_m)
    ids_a = np.concatenate([np.arange(n_inliers), 1000 + np.arange(len(ca) - n_inliers)])
    ids_b = np.concatenate([np.arange(n_inliers), 100000 + np.arange(n_outliers_b)])
    pa, pb = rng.permutation(len(ca)), rng.permutation(len(cb))
    a = _submap("a", ca[pa], ea[pa], da[pa], ids_a[pa], np.eye(4))
    b = _submap("b", cb[pb], eb[pb], db[pb], ids_b[pb], T)
    where_a, where_b = np.argsort(pa)[:n_inliers], np.argsort(pb)[:n_inliers]
    truth = np.stack([where_a, where_b], 1).astype(np.int64)
    return a, b, truth[np.argsort(truth[:, 0])]


def _check_args(n_in: int, n_oa: int, n_ob: int, noise: float, dim: int, fams: int, radius: float) -> None:
    checks = {
        "n_inliers": n_in >= 0,
        "n_outliers_a": n_oa >= 0,
        "n_outliers_b": n_ob >= 0,
        "noise_m": noise >= 0,
        "descriptor_dim": dim >= 1,
        "n_families": fams >= 2,
        "radius_m": radius > 0,
    }
    for name, ok in checks.items():
        if not ok:
            raise ConfigError(
                f"make_submap_pair: {name} out of range (counts and noise >= 0, "
                "descriptor_dim >= 1, n_families >= 2, radius_m > 0)"
            )


def _stack_views(
    sc: _Scene, parts: list[tuple[NDArray, NDArray, NDArray]], noise_m: float
) -> tuple[NDArray, NDArray, NDArray]:
    """Observed centres (with noise), extents and descriptors of all parts, stacked."""
    cs, es, ds = [], [], []
    for c, e, d in parts:
        e2, d2 = sc.observe(e, d)
        cs.append(c + sc.rng.normal(scale=noise_m, size=c.shape) if noise_m > 0 else c.copy())
        es.append(e2)
        ds.append(d2)
    return np.concatenate(cs), np.concatenate(es), np.concatenate(ds)


def _default_T() -> NDArray[np.float64]:
    T = np.eye(4)
    T[:3, :3] = rot_z(np.deg2rad(35.0))
    T[:3, 3] = [3.0, -2.0, 0.4]
    return T
