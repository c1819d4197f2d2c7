"""Generate a world: terrain, roads, placed objects -> ``mujoco.MjSpec`` -> ``MjModel`` + truth."""

from __future__ import annotations

import logging
import pickle
from dataclasses import dataclass, field, replace
from typing import Protocol, cast

import mujoco
import numpy as np
import trimesh

from roman_sim.core.errors import WorldError
from roman_sim.core.geometry import make_T, rot_z
from roman_sim.core.seeding import child_rng
from roman_sim.world.appearance import Sun, check_texture_memory, resolve_sun
from roman_sim.world.assets import concat_meshes
from roman_sim.world.catalog import Asset, family_assets
from roman_sim.world.ground import ground_texture
from roman_sim.world.layout import LAYOUTS, LayoutContext, Placer
from roman_sim.world.mjcf import Looks, add_object_geoms, new_spec
from roman_sim.world.roads import Polyline, make_roads
from roman_sim.world.spec import FamilySpec, WorldSpec
from roman_sim.world.terrain import footprint_min_height, make_terrain
from roman_sim.world.truth import ObjectTruth, SunMeta, Terrain, WorldMeta, WorldTruth

log = logging.getLogger(__name__)


class HasTruth(Protocol):
    """Anything that carries a world's truth: a ``World`` or a ``TruthOnlyWorld``."""

    @property
    def truth(self) -> WorldTruth: ...


@dataclass(frozen=True)
class TruthOnlyWorld:
    """A world's spec, seed and truth without its MuJoCo model (``generate_truth``): enough to plan
    and drive robots and to count what they see, not to render."""

    spec: WorldSpec
    seed: int
    truth: WorldTruth


@dataclass
class World:
    """A generated world: its spec and seed, the compiled model, the truth and the meshes."""

    spec: WorldSpec
    seed: int
    model: mujoco.MjModel
    truth: WorldTruth
    meshes: dict[str, trimesh.Trimesh]  # mesh asset name -> mesh in its local frame
    mjspec: mujoco.MjSpec | None = field(default=None, repr=False)

    def object_mesh_world(self, obj_id: int) -> trimesh.Trimesh:
        """The full mesh of object ``obj_id`` in the world frame."""
        if not 0 <= obj_id < len(self.truth.objects):
            raise WorldError(f"obj_id {obj_id} out of range (0..{len(self.truth.objects) - 1})")
        obj = self.truth.objects[obj_id]
        mesh = concat_meshes(self.meshes[n] for n in obj.mesh_names)
        return mesh.apply_transform(obj.T_world_obj)


@dataclass(frozen=True)
class PickledWorld:
    """A world pickled once by the run's process, for its local workers (loading it takes a fraction
    of the seconds generating it does).

    The world goes without its ``MjSpec``, which cannot be pickled and which only exporting
    reads; the compiled model, truth and meshes are the generated world's, byte for byte.
    """

    data: bytes

    @classmethod
    def of(cls, world: World) -> PickledWorld:
        """``world`` pickled (its ``mjspec`` left out)."""
        return cls(pickle.dumps(replace(world, mjspec=None), protocol=pickle.HIGHEST_PROTOCOL))

    def load(self) -> World:
        """The world back."""
        world = pickle.loads(self.data)  # noqa: S301 (bytes this run's own process pickled)
        return cast("World", world)


@dataclass(frozen=True)
class _Placed:
    asset: Asset
    x: float
    y: float
    yaw: float


def effective_densities(spec: WorldSpec) -> list[float]:
    """Per-family densities after ``class_diversity`` moves objects into the densest family."""
    cd = spec.knobs()[0]
    dens = np.array([f.density for f in spec.families], dtype=np.float64)
    out = cd * dens
    out[int(np.argmax(dens))] += (1.0 - cd) * dens.sum()
    return out.tolist()


def _place_family(
    spec: WorldSpec, seed: int, fam: FamilySpec, n: int, assets: list[Asset], placer: Placer, roads: list
) -> list[_Placed]:
    """Up to ``n`` objects of ``fam`` from its layout's candidates, in candidate order."""
    rng = child_rng(seed, "world", "layout", fam.name)
    reg = spec.knobs()[2]
    ctx = LayoutContext(spec.extent_m, roads, spec.roads.width_m, spec.layout, reg, max(a.radius for a in assets))
    pts, yaws = LAYOUTS.get(spec.family_layout(fam).value)(rng, n, ctx)
    choice = rng.integers(0, len(assets), len(pts))
    radii = np.array([assets[c].radius for c in choice])
    ok = placer.feasible(pts, radii)
    out: list[_Placed] = []
    for i in np.flatnonzero(ok):
        if len(out) >= n:
            break
        if placer.try_add(pts[i], radii[i]):
            out.append(_Placed(assets[choice[i]], float(pts[i, 0]), float(pts[i, 1]), float(yaws[i])))
    if len(out) < n:
        log.info("family %s: placed %d of %d requested", fam.name, len(out), n)
    return out


def _place_all(spec: WorldSpec, seed: int, roads: list) -> tuple[list[_Placed], dict[str, tuple[int, int]]]:
    """Place every family; returns the placements and {family: [placed, requested]}."""
    sv = spec.knobs()[1]
    area_ha = spec.extent_m[0] * spec.extent_m[1] / 1e4
    todo = []
    for fam, dens in zip(spec.families, effective_densities(spec)):
        n = round(dens * area_ha)
        if n > 0:
            assets = family_assets(seed, fam, sv)
            todo.append((max(a.radius for a in assets), fam, n, assets))
    todo.sort(key=lambda t: (-t[0], t[1].name))  # large footprints first: they are hardest to fit
    placer = Placer(spec.extent_m, roads, spec.roads.width_m, spec.layout.min_gap_m, spec.max_objects)
    placed: list[_Placed] = []
    counts: dict[str, tuple[int, int]] = {}
    for _, fam, n, assets in todo:
        got = _place_family(spec, seed, fam, n, assets, placer, roads)
        placed += got
        counts[fam.name] = (len(got), n)  # families are unique (WorldSpec checks)
    if todo and not placed:
        raise WorldError(
            f"world {spec.name!r}: no object fits the extent {spec.extent_m} m next to roads of width "
            f"{spec.roads.width_m} m; enlarge extent_m or lower roads.width_m / family scales"
        )
    return placed, dict(sorted(counts.items()))


def _object_truth(i: int, p: _Placed, z: float) -> ObjectTruth:
    T = make_T(rot_z(p.yaw), [p.x, p.y, z])
    obb_T = T @ p.asset.obb_T_local
    return ObjectTruth(
        id=i,
        family=p.asset.family,
        T_world_obj=T,
        extents=np.sort(p.asset.obb_extents)[::-1].copy(),
        volume=float(np.prod(p.asset.obb_extents)),
        centroid=(T[:3, :3] @ p.asset.centroid_local + T[:3, 3]),
        geom_ids=[],
        mesh_names=[p.asset.mesh_name(part) for part in p.asset.parts],
        obb_T_world=obb_T,
        obb_extents=p.asset.obb_extents.copy(),
        radius=p.asset.radius,
    )


@dataclass(frozen=True)
class _Layout:
    terrain: Terrain
    base_z: float
    elevation: float
    roads: list[Polyline]
    placed: list[_Placed]
    objects: list[ObjectTruth]
    sun: Sun
    meta: WorldMeta

    def truth(self) -> WorldTruth:
        return WorldTruth(objects=self.objects, terrain=self.terrain, roads=self.roads, meta=self.meta)


def _layout(spec: WorldSpec, seed: int) -> _Layout:
    """Terrain, roads, placed objects and their truth: everything of a world but its model."""
    if not isinstance(seed, (int, np.integer)) or seed < 0:
        raise WorldError(f"seed must be a non-negative integer, got {seed!r}")
    seed = int(seed)
    terrain, base_z, elevation = make_terrain(spec.terrain, spec.extent_m, child_rng(seed, "world", "terrain"))
    roads = make_roads(spec.roads, spec.extent_m)
    placed, counts = _place_all(spec, seed, roads)
    objects = [
        _object_truth(i, p, footprint_min_height(terrain, p.x, p.y, p.asset.radius)) for i, p in enumerate(placed)
    ]
    if spec.appearance.textures:
        kinds = len({part.surface for p in placed for part in p.asset.parts})
        check_texture_memory(spec.appearance, kinds, spec.extent_m)
    sun = resolve_sun(spec.appearance.lighting, seed)
    meta = WorldMeta(
        spec.name, seed, base_z, elevation, spec.knobs(), counts, SunMeta(sun.azimuth_deg, sun.elevation_deg)
    )
    return _Layout(terrain, base_z, elevation, roads, placed, objects, sun, meta)


def generate_truth(spec: WorldSpec, seed: int) -> TruthOnlyWorld:
    """The truth of ``generate(spec, seed)`` (objects without geom ids) without building its model.

    Planning, driving and counting relevant pairs need only the truth; the model's textures
    and meshes are most of a large world's generation time.
    """
    return TruthOnlyWorld(spec=spec, seed=int(seed), truth=_layout(spec, seed).truth())


def generate(spec: WorldSpec, seed: int) -> World:
    """Generate the world of ``spec`` with ``seed`` (same inputs -> same model and truth)."""
    lay = _layout(spec, seed)
    seed = int(seed)
    app = spec.appearance
    ground = ground_texture(
        lay.terrain,
        lay.roads,
        spec.roads.width_m,
        child_rng(seed, "world", "ground"),
        app.ground_texel_m if app.textures else None,
    )
    mjs = new_spec(spec, lay.terrain, lay.base_z, lay.elevation, ground, lay.sun)
    meshes: dict[str, trimesh.Trimesh] = {}
    looks = Looks(spec.appearance, seed)
    for obj, p in zip(lay.objects, lay.placed):
        add_object_geoms(mjs, obj, p.asset, meshes, looks)
    try:
        model = mjs.compile()
    except Exception as err:  # noqa: BLE001  (MuJoCo raises plain ValueError on compile failures)
        raise WorldError(f"world {spec.name!r}: MuJoCo compile failed: {err}") from None
    for obj in lay.objects:
        obj.geom_ids = [
            mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, f"obj{obj.id}_{k}") for k in range(len(obj.mesh_names))
        ]
    truth = lay.truth()
    log.info("world %s seed %d: %d objects, %d geoms", spec.name, seed, len(lay.objects), model.ngeom)
    return World(spec=spec, seed=seed, model=model, truth=truth, meshes=meshes, mjspec=mjs)
