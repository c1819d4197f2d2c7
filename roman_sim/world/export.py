"""Export a world folder (``world.xml``, ``meshes/``, ``truth.json``, ``spec.yaml``) and load it back.

Meshes are written in MuJoCo's binary ``.msh`` format and the terrain as a binary hfield
file (``meshes/terrain.bin``), both float32 exactly as compiled, so the reloaded model
equals the generated one. ``world.xml`` loads with plain ``mujoco.MjModel.from_xml_path``.
"""

from __future__ import annotations

import io
import json
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import trimesh
import yaml
from PIL import Image

from roman_sim.core.atomic import write_bytes, write_json, write_text
from roman_sim.core.config import dump_yaml, validate_model
from roman_sim.core.errors import WorldError
from roman_sim.world.build import World
from roman_sim.world.mjcf import GROUND
from roman_sim.world.spec import WorldSpec
from roman_sim.world.truth import ObjectTruth, Terrain, WorldTruth

TRUTH_VERSION = 1
MESH_DIR = "meshes"
HFIELD_FILE = "terrain.bin"
TEXTURE_FILE = "ground.png"


def _msh_bytes(mesh: trimesh.Trimesh) -> bytes:
    v = np.asarray(mesh.vertices, dtype=np.float32)
    f = np.asarray(mesh.faces, dtype=np.int32)
    header = np.array([len(v), 0, 0, len(f)], dtype=np.int32)
    return header.tobytes() + v.tobytes() + f.tobytes()


def _read_msh(path: Path) -> trimesh.Trimesh:
    raw = path.read_bytes()
    nv, nn, nt, nf = np.frombuffer(raw[:16], dtype=np.int32)
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
        mesh.file = f"{mesh.name}.msh"
        mesh.uservert = []
        mesh.userface = []
    hf = mjs.hfields[0]
    hf.file = HFIELD_FILE
    hf.userdata = []
    mjs.texturedir = MESH_DIR
    tex = mjs.texture(GROUND)
    tex.file = TEXTURE_FILE
    tex.data = b""
    return mjs


def _texture_bytes(world: World) -> bytes:
    tid = mujoco.mj_name2id(world.model, mujoco.mjtObj.mjOBJ_TEXTURE, GROUND)
    w, h = int(world.model.tex_width[tid]), int(world.model.tex_height[tid])
    adr = int(world.model.tex_adr[tid])
    rgb = np.asarray(world.model.tex_data[adr : adr + 3 * w * h], dtype=np.uint8).reshape(h, w, 3)
    buf = io.BytesIO()
    Image.fromarray(rgb).save(buf, format="PNG")
    return buf.getvalue()


def truth_to_dict(world: World) -> dict[str, Any]:
    """The JSON document of ``truth.json``."""
    t = world.truth
    return {
        "version": TRUTH_VERSION,
        "seed": world.seed,
        "objects": [o.to_dict() for o in t.objects],
        "terrain": {"size_x": t.terrain.size_x, "size_y": t.terrain.size_y, "hfield": f"{MESH_DIR}/{HFIELD_FILE}"},
        "roads": [np.round(r, 6).tolist() for r in t.roads],
        "meta": t.meta,
    }


def export_world(world: World, out_dir: str | Path) -> Path:
    """Write the world folder; returns the path of ``world.xml``."""
    out = Path(out_dir)
    (out / MESH_DIR).mkdir(parents=True, exist_ok=True)
    for name, mesh in sorted(world.meshes.items()):
        write_bytes(out / MESH_DIR / f"{name}.msh", _msh_bytes(mesh))
    write_bytes(out / MESH_DIR / HFIELD_FILE, _hfield_bytes(world))
    write_bytes(out / MESH_DIR / TEXTURE_FILE, _texture_bytes(world))
    mjs = _file_spec(world)
    mjs.modelfiledir = str(out)
    mjs.compile()  # to_xml needs a compiled spec; this also checks the files load
    write_text(out / "world.xml", mjs.to_xml())
    write_json(out / "truth.json", truth_to_dict(world))
    write_text(out / "spec.yaml", dump_yaml(world.spec))
    return out / "world.xml"


def _truth_from(doc: dict[str, Any], model: mujoco.MjModel) -> WorldTruth:
    meta = doc["meta"]
    rows, cols = int(model.hfield_nrow[0]), int(model.hfield_ncol[0])
    data = model.hfield_data[: rows * cols].reshape(rows, cols).astype(np.float64)
    heights = float(meta["base_z"]) + float(meta["elevation"]) * data
    terrain = Terrain(size_x=float(doc["terrain"]["size_x"]), size_y=float(doc["terrain"]["size_y"]), heights=heights)
    objects = [ObjectTruth.from_dict(o) for o in doc["objects"]]
    roads = [np.asarray(r, dtype=np.float64).reshape(-1, 2) for r in doc["roads"]]
    return WorldTruth(objects=objects, terrain=terrain, roads=roads, meta=meta)


def load_world(world_dir: str | Path) -> World:
    """Reload an exported world folder (``WorldError`` on missing or corrupt files)."""
    d = Path(world_dir)
    for name in ("world.xml", "truth.json", "spec.yaml"):
        if not (d / name).is_file():
            raise WorldError(f"{d}: missing {name} (not an exported world folder)")
    try:
        model = mujoco.MjModel.from_xml_path(str(d / "world.xml"))
        mjs = mujoco.MjSpec.from_file(str(d / "world.xml"))
        doc = json.loads((d / "truth.json").read_text(encoding="utf-8"))
        spec = validate_model(WorldSpec, yaml.safe_load((d / "spec.yaml").read_text(encoding="utf-8")), str(d / "spec.yaml"))
        truth = _truth_from(doc, model)
        meshes = {m.name: _read_msh(d / MESH_DIR / f"{m.name}.msh") for m in mjs.meshes}
    except (ValueError, KeyError, TypeError, OSError, yaml.YAMLError) as err:
        raise WorldError(f"{d}: corrupt world folder: {type(err).__name__}: {err}") from None
    if doc.get("version") != TRUTH_VERSION:
        raise WorldError(f"{d}/truth.json: version {doc.get('version')!r}, expected {TRUTH_VERSION}")
    return World(spec=spec, seed=int(doc["seed"]), model=model, truth=truth, meshes=meshes, mjspec=mjs)
