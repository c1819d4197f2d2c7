"""Export a world folder (``world.xml``, ``meshes/``, ``truth.json``, ``spec.yaml``) and load it back.

Meshes are written in MuJoCo's binary ``.msh`` format, or as Wavefront ``.obj`` when they
carry texture coordinates (``.msh`` holds one texture coordinate per vertex, the box
projection one per face corner); the terrain as a binary hfield file (``meshes/terrain.bin``),
float32 exactly as compiled, and the ground and surface textures as PNG files, so the
reloaded model equals the generated one. With per-instance textures every object part has its
own mesh copy (``shape@object_id``, its own texture coordinates), written as its own file.
``world.xml`` loads with plain ``mujoco.MjModel.from_xml_path``.
"""

from __future__ import annotations

import io
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
import trimesh
from numpy.typing import NDArray
from PIL import Image

from roman_sim.core.atomic import output_folder, write_bytes, write_text
from roman_sim.core.config import dump_yaml, load_model
from roman_sim.core.errors import WorldError
from roman_sim.core.records import RecordError, from_json, read_json, write_record
from roman_sim.world.build import World
from roman_sim.world.mjcf import GROUND, MATERIAL_PREFIX, shape_of
from roman_sim.world.spec import WorldSpec
from roman_sim.world.truth import ObjectTruthRow, Terrain, WorldMeta, WorldTruth

TRUTH_VERSION = 1
MESH_DIR = "meshes"
HFIELD_FILE = "terrain.bin"
TEXTURE_FILE = "ground.png"


def _msh_bytes(mesh: trimesh.Trimesh) -> bytes:
    v = np.asarray(mesh.vertices, dtype=np.float32)
    f = np.asarray(mesh.faces, dtype=np.int32)
    header = np.array([len(v), 0, 0, len(f)], dtype=np.int32)
    return header.tobytes() + v.tobytes() + f.tobytes()


def _mesh_texcoords(model: mujoco.MjModel, name: str) -> tuple[NDArray[np.float32], NDArray[np.int64]] | None:
    """(texcoords (T, 2), face texcoord indices (F, 3)) of mesh ``name``, or None when untextured."""
    i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_MESH, name)
    adr, num = int(model.mesh_texcoordadr[i]), int(model.mesh_texcoordnum[i])
    if num == 0:
        return None
    fadr, fnum = int(model.mesh_faceadr[i]), int(model.mesh_facenum[i])
    return model.mesh_texcoord[adr : adr + num].copy(), model.mesh_facetexcoord[fadr : fadr + fnum].astype(np.int64)


def _obj_text(mesh: trimesh.Trimesh, uv: NDArray[np.float32], ft: NDArray[np.int64]) -> str:
    """Wavefront OBJ with per-corner texture coordinates (``.msh`` holds only one per vertex).

    MuJoCo reads an OBJ's ``vt`` as ``(u, 1 - v)``, so ``1 - v`` is written.
    """
    v = np.asarray(mesh.vertices, dtype=np.float32)
    f = np.asarray(mesh.faces, dtype=np.int64) + 1
    lines = [f"v {a:.9g} {b:.9g} {c:.9g}" for a, b, c in v]
    lines += [f"vt {a:.9g} {b:.9g}" for a, b in zip(uv[:, 0], np.float32(1.0) - uv[:, 1])]
    lines += [f"f {a}/{ta} {b}/{tb} {c}/{tc}" for (a, b, c), (ta, tb, tc) in zip(f, ft + 1)]
    return "\n".join(lines) + "\n"


def _read_obj(path: Path) -> trimesh.Trimesh:
    """Vertices and faces of an OBJ written by ``_obj_text``, in file order."""
    rows = [line.split() for line in path.read_text(encoding="utf-8").splitlines()]
    v = np.array([r[1:4] for r in rows if r and r[0] == "v"], dtype=np.float32)
    f = np.array([[int(c.split("/")[0]) - 1 for c in r[1:4]] for r in rows if r and r[0] == "f"], dtype=np.int64)
    return trimesh.Trimesh(v.astype(np.float64), f, process=False)


def _mesh_file(model: mujoco.MjModel, name: str) -> str:
    return f"{name}.obj" if _mesh_texcoords(model, name) is not None else f"{name}.msh"


def _read_msh(path: Path) -> trimesh.Trimesh:
    raw = path.read_bytes()
    if len(raw) < 16:
        raise ValueError(f"{len(raw)} bytes, shorter than the 16-byte header")
    nv, nn, nt, nf = (int(x) for x in np.frombuffer(raw[:16], dtype=np.int32))
    expected = 16 + 4 * (3 * nv + 3 * nn + 2 * nt + 3 * nf)
    if min(nv, nn, nt, nf) < 0 or len(raw) != expected:
        raise ValueError(f"{len(raw)} bytes, but the header (counts {nv}, {nn}, {nt}, {nf}) says {expected}")
    off = 16
    v = np.frombuffer(raw, np.float32, 3 * nv, off).reshape(-1, 3)
    off += 4 * (3 * nv + 3 * nn + 2 * nt)
    f = np.frombuffer(raw, np.int32, 3 * nf, off).reshape(-1, 3)
    return trimesh.Trimesh(v.astype(np.float64), f.astype(np.int64), process=False)


def _hfield_bytes(world: World) -> bytes:
    data = world.model.hfield_data.astype(np.float32)
    rows, cols = int(world.model.hfield_nrow[0]), int(world.model.hfield_ncol[0])
    return np.array([rows, cols], dtype=np.int32).tobytes() + data.tobytes()


def _file_spec(world: World) -> mujoco.MjSpec:
    """A copy of the world's MjSpec whose meshes and hfield point at files in ``meshes/``."""
    if world.mjspec is None:
        raise WorldError("world has no MjSpec to export (was it loaded from a folder? re-export that folder)")
    mjs = world.mjspec.copy()
    mjs.meshdir = MESH_DIR
    for mesh in mjs.meshes:
        mesh.file = _mesh_file(world.model, mesh.name)
        mesh.uservert = []
        mesh.userface = []
        mesh.usertexcoord = []
        mesh.userfacetexcoord = []
    hf = mjs.hfields[0]
    hf.file = HFIELD_FILE
    hf.userdata = []
    mjs.texturedir = MESH_DIR
    images = _image_textures(mjs)
    for tex in mjs.textures:
        if tex.name in images:
            tex.file = _texture_file(tex.name)
            tex.data = b""
    return mjs


def _image_textures(mjs: mujoco.MjSpec) -> list[str]:
    """Names of the textures held as images: the ground and the surface textures (not the sky)."""
    return [GROUND] + sorted(t.name for t in mjs.textures if t.name.startswith(MATERIAL_PREFIX))


def _texture_file(name: str) -> str:
    return TEXTURE_FILE if name == GROUND else f"{name}.png"


def _texture_bytes(world: World, name: str) -> bytes:
    tid = mujoco.mj_name2id(world.model, mujoco.mjtObj.mjOBJ_TEXTURE, name)
    w, h = int(world.model.tex_width[tid]), int(world.model.tex_height[tid])
    adr = int(world.model.tex_adr[tid])
    rgb = np.asarray(world.model.tex_data[adr : adr + 3 * w * h], dtype=np.uint8).reshape(h, w, 3)
    grey = bool(np.all(rgb[..., 0:1] == rgb[..., 1:]))  # the surface atlases: MuJoCo reads L as RGB
    buf = io.BytesIO()
    # noise hardly compresses: the fastest zlib level writes a 2048 px atlas in a fraction of the time
    Image.fromarray(rgb[..., 0] if grey else rgb).save(buf, format="PNG", compress_level=1)
    return buf.getvalue()


@dataclass(frozen=True)
class TerrainRow:
    """The terrain's size (m) and its heightfield file; the heights are the file's, scaled by the meta."""

    size_x: float
    size_y: float
    hfield: str


@dataclass(frozen=True)
class TruthFile:
    """What ``truth.json`` holds: the seed, every object, the terrain, the roads and how the world was made."""

    version: int
    seed: int
    objects: list[ObjectTruthRow]
    terrain: TerrainRow
    roads: list[list[list[float]]]
    meta: WorldMeta | None


def truth_file(world: World) -> TruthFile:
    """The ``truth.json`` record of ``world``."""
    t = world.truth
    terrain = TerrainRow(t.terrain.size_x, t.terrain.size_y, f"{MESH_DIR}/{HFIELD_FILE}")
    roads: list[list[list[float]]] = [np.round(r, 6).tolist() for r in t.roads]
    return TruthFile(TRUTH_VERSION, world.seed, [ObjectTruthRow.of(o) for o in t.objects], terrain, roads, t.meta)


def export_world(world: World, out_dir: str | Path) -> Path:
    """Write the world folder; returns the path of ``world.xml``."""
    out = output_folder(out_dir, "out_dir")
    output_folder(out / MESH_DIR, "out_dir")
    mjs = _file_spec(world)  # checks the world has an MjSpec
    for name in sorted(m.name for m in mjs.meshes):  # shared shapes or instances' own copies
        mesh, uv = world.meshes[shape_of(name)], _mesh_texcoords(world.model, name)
        if uv is None:
            write_bytes(out / MESH_DIR / f"{name}.msh", _msh_bytes(mesh))
        else:
            write_text(out / MESH_DIR / f"{name}.obj", _obj_text(mesh, *uv))
    write_bytes(out / MESH_DIR / HFIELD_FILE, _hfield_bytes(world))
    for name in _image_textures(mjs):
        write_bytes(out / MESH_DIR / _texture_file(name), _texture_bytes(world, name))
    mjs.modelfiledir = str(out)
    mjs.compile()  # to_xml needs a compiled spec; this also checks the files load
    write_text(out / "world.xml", mjs.to_xml())
    write_record(out / "truth.json", truth_file(world))
    write_text(out / "spec.yaml", dump_yaml(world.spec))
    return out / "world.xml"


def _truth_from(doc: TruthFile, model: mujoco.MjModel) -> WorldTruth:
    meta = doc.meta
    if meta is None:
        raise WorldError("truth.json: no meta (the terrain's base and elevation are needed)")
    rows, cols = int(model.hfield_nrow[0]), int(model.hfield_ncol[0])
    data = model.hfield_data[: rows * cols].reshape(rows, cols).astype(np.float64)
    heights = float(meta.base_z) + float(meta.elevation) * data
    terrain = Terrain(size_x=float(doc.terrain.size_x), size_y=float(doc.terrain.size_y), heights=heights)
    objects = [o.truth() for o in doc.objects]
    roads = [np.asarray(r, dtype=np.float64).reshape(-1, 2) for r in doc.roads]
    return WorldTruth(objects=objects, terrain=terrain, roads=roads, meta=meta)


def load_world(world_dir: str | Path) -> World:
    """Reload an exported world folder (``WorldError`` naming the missing or corrupt file)."""
    d = Path(world_dir)
    if not d.is_dir():
        raise WorldError(f"{d}: not a folder (an exported world folder holds world.xml, truth.json, spec.yaml)")
    for name in ("world.xml", "truth.json", "spec.yaml"):
        if not (d / name).is_file():
            raise WorldError(f"{d}: missing {name} (not an exported world folder)")
    model, mjs = _load_xml(d / "world.xml")
    doc = _load_truth_json(d / "truth.json")
    spec = load_model(WorldSpec, d / "spec.yaml")
    try:
        truth = _truth_from(doc, model)
    except ValueError as err:
        raise WorldError(f"{d / 'truth.json'}: corrupt: {type(err).__name__}: {err}") from None
    seed = doc.seed
    meshes = {}
    for m in mjs.meshes:
        if shape_of(m.name) in meshes:
            continue  # another instance's copy of a shape already read (copies differ in texture only)
        path = d / MESH_DIR / Path(m.file).name
        try:
            meshes[shape_of(m.name)] = (_read_obj if path.suffix == ".obj" else _read_msh)(path)
        except (OSError, ValueError, TypeError, IndexError) as err:
            raise WorldError(f"{path}: corrupt mesh file: {err}") from None
    return World(spec=spec, seed=seed, model=model, truth=truth, meshes=meshes, mjspec=mjs)


def _load_xml(path: Path) -> tuple[mujoco.MjModel, mujoco.MjSpec]:
    """The compiled model and the spec of ``world.xml``; MuJoCo's parse errors name the file."""
    try:
        return mujoco.MjModel.from_xml_path(str(path)), mujoco.MjSpec.from_file(str(path))
    except (ValueError, OSError) as err:
        detail = " ".join(str(err).split())
        raise WorldError(f"{path}: MuJoCo cannot load it: {detail}") from None


def _load_truth_json(path: Path) -> TruthFile:
    """``truth.json``; WorldError naming the file (and the field) when it is not this version's."""
    try:
        data = read_json(path)
        version = data.get("version") if isinstance(data, dict) else None
        if isinstance(data, dict) and version != TRUTH_VERSION:
            raise WorldError(f"{path}: version {version!r}, expected {TRUTH_VERSION}")
        return from_json(TruthFile, data, str(path))
    except RecordError as err:
        raise WorldError(str(err)) from None
