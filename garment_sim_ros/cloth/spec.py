"""Garment specs: one description for every garment, built-in or the user's own mesh (ROS-free).

A spec is a YAML file (documented in the README, "Your own garments")::

    name: cape
    mesh: cape.obj                  # OBJ, PLY, STL, glTF/GLB, relative to the spec; or {procedural: pants}
    units: m                        # m, cm, mm, in
    up_axis: z                      # z (x forward, y left) or y (glTF/Blender export: +z forward, +x left)
    placement: {mode: fit, anchor: neck}     # or {mode: as_is, reference_height: 1.75}
    attach:                         # which vertices ride on which joint-map role
      - role: chest
        vertices: {loop: top}       # or {group: NAME}, {colour: [r, g, b]}, {indices: [..]}
        falloff: 0.02               # m: the vertices this close to the selected ones ride too
        blend: {role: spine, weight: 0.5}    # optional: skinned to a second role too
    material: cotton_shirting       # a preset (cloth.materials) or {preset: .., areal_density: ..}
    layer: 0                        # 0 closest to the skin
    max_vertices: 6000              # more is refused (decimate: --decimate / decimate: true)
    decimate: false
    detailed_body: false            # fit the 15-volume body (neck, forearms, feet)

``load_spec`` validates a file (``SpecError`` names the file and the key); ``BUILTIN_SPECS`` are the four
procedural garments as specs; ``resolve_garment`` turns a name or a path into a spec; ``build_mesh``
makes the ``GarmentMesh`` on a body: read, decimate if asked, check (``mesh_check``), place, attach.
Placement and attachment are in the rest pose's root frame (origin at the pelvis joint, x forward,
y left, z up, metres), the frame the procedural garments are cut in.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

import numpy as np

from ..body.fitting import ANKLE_HEIGHT_PER_STATURE
from ..body.joint_map import ROLES
from ..body.measurements import BodyMeasurements
from ..config_files import read_yaml
from ..params import ParameterError
from .garments import GARMENT_NAMES, GarmentMesh, build_garment
from .materials import material_overrides
from .mesh_check import UNITS, GarmentMeshError, boundary_loops, check_mesh
from .mesh_file import FORMATS, UP_AXES, MeshFile, decimate, load_mesh_file

SPEC_SUFFIXES = (".yaml", ".yml")
PLACEMENTS = ("as_is", "fit")
ANCHORS = ("waist", "neck")
LOOP_NAMES = ("top", "bottom", "waist", "neck")
DEFAULT_MAX_VERTICES = 6000
REFERENCE_HEIGHT_M = 1.75  # the body a file garment was modelled on, unless the spec says
FIT_EASE_M = 0.012  # the anchor loop stands this far off the body (the procedural garments' ease)
_KEYS = ("name", "mesh", "units", "up_axis", "placement", "attach", "material", "layer", "max_vertices",
         "decimate", "detailed_body")
_LAYERS = {"pants": 0, "short_skirt": 1, "long_skirt": 1, "one_piece": 1}


class SpecError(ValueError):
    """A garment spec was refused; the message names the file and the key."""


@dataclass(frozen=True)
class Attach:
    role: str  # joint-map role that carries the vertices
    select: str  # loop, group, colour or indices
    value: Any  # the loop or group name, the RGB colour, the index tuple
    falloff: float = 0.0  # m
    blend_role: str | None = None
    blend_weight: float = 0.0


@dataclass(frozen=True)
class GarmentSpec:
    name: str
    mesh: Path | None  # the mesh file; None for a procedural source
    procedural: str | None = None  # a built-in template of cloth.garments
    units: str = "m"
    up_axis: str = "z"
    placement: str = "as_is"
    anchor: str = "waist"
    reference_height: float = REFERENCE_HEIGHT_M
    attach: tuple[Attach, ...] = ()
    material: Mapping[str, float] = field(default_factory=dict)  # solver parameters the fabric sets
    layer: int = 0
    max_vertices: int = DEFAULT_MAX_VERTICES
    decimate: bool = False
    detailed_body: bool = False
    path: Path | None = None  # the spec file

    @property
    def where(self) -> str:
        return str(self.path) if self.path else f"garment {self.name!r}"


BUILTIN_SPECS: dict[str, GarmentSpec] = {
    name: GarmentSpec(name, None, procedural=name, layer=_LAYERS[name], detailed_body=name == "one_piece")
    for name in GARMENT_NAMES
}


# ----------------------------------------------------------------------------- reading

def _get(data: Mapping, key: str, kind, where: str, default=None, choices: Sequence[str] = ()):
    value = data.get(key, default)
    if value is None:
        if default is None:
            raise SpecError(f"{where}: {key}: missing")
        return default
    if kind is float and isinstance(value, int) and not isinstance(value, bool):
        value = float(value)
    if not isinstance(value, kind) or (kind in (int, float) and isinstance(value, bool)):
        raise SpecError(f"{where}: {key}: expected {kind.__name__}, got {value!r}")
    if choices and value not in choices:
        raise SpecError(f"{where}: {key}: got {value!r}; allowed: {', '.join(choices)}")
    return value


def _attach(entry: Any, where: str) -> Attach:
    if not isinstance(entry, Mapping):
        raise SpecError(f"{where}: expected a mapping with role and vertices, got {entry!r}")
    unknown = sorted(set(entry) - {"role", "vertices", "falloff", "blend"})
    if unknown:
        raise SpecError(f"{where}: unknown key(s) {', '.join(unknown)}; allowed: role, vertices, falloff, blend")
    role = _get(entry, "role", str, where, choices=ROLES)
    vertices = entry.get("vertices")
    if not isinstance(vertices, Mapping) or len(vertices) != 1:
        raise SpecError(f"{where}.vertices: expected one of {{loop: NAME}}, {{group: NAME}}, {{colour: [r, g, b]}}, "
                        f"{{indices: [...]}}, got {vertices!r}")
    (select, value), = vertices.items()
    key = f"{where}.vertices.{select}"
    if select == "loop":
        if value not in LOOP_NAMES:
            raise SpecError(f"{key}: got {value!r}; allowed: {', '.join(LOOP_NAMES)}")
    elif select == "group":
        if not isinstance(value, str) or not value:
            raise SpecError(f"{key}: expected a vertex group name, got {value!r}")
    elif select == "colour":
        if (not isinstance(value, (list, tuple)) or len(value) != 3
                or not all(isinstance(c, int) and not isinstance(c, bool) and 0 <= c <= 255 for c in value)):
            raise SpecError(f"{key}: expected [r, g, b] in 0..255, got {value!r}")
        value = tuple(value)
    elif select == "indices":
        if (not isinstance(value, (list, tuple)) or not value
                or not all(isinstance(i, int) and not isinstance(i, bool) and i >= 0 for i in value)):
            raise SpecError(f"{key}: expected a non-empty list of vertex indices >= 0, got {value!r}")
        value = tuple(value)
    else:
        raise SpecError(f"{where}.vertices: unknown selector {select!r}; allowed: loop, group, colour, indices")
    falloff = _get(entry, "falloff", float, where, 0.0)
    if not (math.isfinite(falloff) and 0.0 <= falloff <= 0.5):
        raise SpecError(f"{where}.falloff: got {falloff!r}; allowed: [0, 0.5] m")
    blend_role, blend_weight = None, 0.0
    if "blend" in entry:
        blend = entry["blend"]
        if not isinstance(blend, Mapping) or set(blend) != {"role", "weight"}:
            raise SpecError(f"{where}.blend: expected {{role: ROLE, weight: 0..1}}, got {blend!r}")
        blend_role = _get(blend, "role", str, f"{where}.blend", choices=ROLES)
        blend_weight = _get(blend, "weight", float, f"{where}.blend")
        if not 0.0 <= blend_weight <= 1.0:
            raise SpecError(f"{where}.blend.weight: got {blend_weight!r}; allowed: [0, 1]")
    return Attach(role, select, value, falloff, blend_role, blend_weight)


def load_spec(path: str | Path) -> GarmentSpec:
    """The validated spec in ``path``; ``SpecError`` names the file and the key at fault."""
    path = Path(path)
    data = read_yaml(path, SpecError, "the garment spec")
    where = str(path)
    if not isinstance(data, Mapping):
        raise SpecError(f"{where}: expected a mapping of {', '.join(_KEYS)}, got {type(data).__name__}")
    unknown = sorted(set(data) - set(_KEYS))
    if unknown:
        raise SpecError(f"{where}: unknown key(s) {', '.join(map(str, unknown))}; allowed: {', '.join(_KEYS)}")
    name = _get(data, "name", str, where, path.stem)
    if not name.replace("_", "").isalnum():
        raise SpecError(f"{where}: name: {name!r} must be letters, digits and _ (it names topics and files)")
    source = data.get("mesh")
    mesh, procedural = None, None
    if isinstance(source, Mapping) and set(source) == {"procedural"}:
        procedural = source["procedural"]
        if procedural not in GARMENT_NAMES:
            raise SpecError(f"{where}: mesh.procedural: got {procedural!r}; allowed: {', '.join(GARMENT_NAMES)}")
    elif isinstance(source, str) and source:
        mesh = (path.parent / source).resolve()
        if mesh.suffix.lower() not in FORMATS:
            raise SpecError(f"{where}: mesh: {source!r} is not a supported mesh file; allowed: {', '.join(FORMATS)}")
        if not mesh.is_file():
            raise SpecError(f"{where}: mesh: {mesh} not found")
    else:
        raise SpecError(f"{where}: mesh: expected a mesh file (relative to the spec) or {{procedural: NAME}}, "
                        f"got {source!r}")
    placement = data.get("placement", {"mode": "as_is"})
    if not isinstance(placement, Mapping):
        raise SpecError(f"{where}: placement: expected a mapping with mode {' or '.join(PLACEMENTS)}, "
                        f"got {placement!r}")
    unknown = sorted(set(placement) - {"mode", "anchor", "reference_height"})
    if unknown:
        raise SpecError(f"{where}: placement: unknown key(s) {', '.join(unknown)}; allowed: mode, anchor, "
                        "reference_height")
    mode = _get(placement, "mode", str, f"{where}: placement", "as_is", PLACEMENTS)
    anchor = _get(placement, "anchor", str, f"{where}: placement", "waist", ANCHORS)
    reference_height = _get(placement, "reference_height", float, f"{where}: placement", REFERENCE_HEIGHT_M)
    if not 0.5 <= reference_height <= 2.5:
        raise SpecError(f"{where}: placement.reference_height: got {reference_height!r}; allowed: [0.5, 2.5] m")
    attach = data.get("attach", [])
    if not isinstance(attach, list) or (not attach and procedural is None):
        raise SpecError(f"{where}: attach: expected a non-empty list of {{role, vertices}} (a garment must hang "
                        f"on the body), got {attach!r}")
    try:
        material = material_overrides(data.get("material"), f"{where}: material")
    except ParameterError as err:
        raise SpecError(str(err)) from None
    max_vertices = _get(data, "max_vertices", int, where, DEFAULT_MAX_VERTICES)
    if not 16 <= max_vertices <= 100_000:
        raise SpecError(f"{where}: max_vertices: got {max_vertices!r}; allowed: [16, 100000]")
    layer = _get(data, "layer", int, where, 0)
    if not 0 <= layer <= 9:
        raise SpecError(f"{where}: layer: got {layer!r}; allowed: 0 (closest to the skin) .. 9")
    return GarmentSpec(
        name=name, mesh=mesh, procedural=procedural,
        units=_get(data, "units", str, where, "m", tuple(UNITS)),
        up_axis=_get(data, "up_axis", str, where, "z", tuple(UP_AXES)),
        placement=mode, anchor=anchor, reference_height=reference_height,
        attach=tuple(_attach(entry, f"{where}: attach[{k}]") for k, entry in enumerate(attach)),
        material=material, layer=layer, max_vertices=max_vertices,
        decimate=_get(data, "decimate", bool, where, False),
        detailed_body=_get(data, "detailed_body", bool, where, False), path=path,
    )


# ----------------------------------------------------------------------------- finding

def search_path(extra: Iterable[str | Path] = ()) -> list[Path]:
    """Folders searched for ``NAME.yaml`` specs: ``extra`` (the ``garment_path`` parameter), then
    ``config/garments/`` of the working directory and of the package."""
    from ..config_files import config_file

    folders = [Path(p) for p in extra if str(p)]
    folders.append(Path("config") / "garments")
    try:
        folders.append(config_file("garments"))
    except FileNotFoundError:
        pass
    return list(dict.fromkeys(p.resolve() for p in folders))


def find_specs(extra: Iterable[str | Path] = ()) -> list[Path]:
    """Every spec file in the search path, first folder first, one per name."""
    found: dict[str, Path] = {}
    for folder in search_path(extra):
        if folder.is_dir():
            for path in sorted(p for p in folder.iterdir() if p.suffix in SPEC_SUFFIXES):
                found.setdefault(path.stem, path)
    return list(found.values())


def resolve_garment(entry: str | GarmentSpec, garment_path: Iterable[str | Path] = ()) -> GarmentSpec:
    """A spec for ``entry``: a spec, a built-in's name, a spec file, or a spec's name in the search path."""
    if isinstance(entry, GarmentSpec):
        return entry
    if entry in BUILTIN_SPECS:
        return BUILTIN_SPECS[entry]
    if Path(entry).suffix in SPEC_SUFFIXES:
        return load_spec(entry)
    for path in find_specs(garment_path):
        if path.stem == entry:
            return load_spec(path)
    raise SpecError(f"unknown garment {entry!r}: not a built-in ({', '.join(GARMENT_NAMES)}), not a spec file "
                    f"(*.yaml) and no {entry}.yaml in {', '.join(map(str, search_path(garment_path)))}")


def parse_garment_list(text: str, garment_path: Iterable[str | Path] = ()) -> list[GarmentSpec]:
    """``'pants,config/garments/cape.yaml'`` -> the specs, validated; ``SpecError`` names the bad entry."""
    entries = [g.strip() for g in text.split(",") if g.strip()]
    if not entries:
        raise SpecError(f"--garments: no garment in {text!r}; built-ins: {', '.join(GARMENT_NAMES)}, or spec files")
    specs = [resolve_garment(e, garment_path) for e in entries]
    names = [s.name for s in specs]
    if len(set(names)) != len(names):
        raise SpecError(f"--garments: a garment is named twice in {names}")
    return specs


# ----------------------------------------------------------------------------- building

def build_mesh(spec: GarmentSpec, body: BodyMeasurements, resolution: float = 1.0,
               decimate_to: int | None = None) -> GarmentMesh:
    """``spec``'s garment on ``body``: read (or generate), check, place and attach.

    ``resolution`` scales a procedural garment; a file keeps its own vertices. ``decimate_to`` (the
    ``--decimate`` option) reduces a file mesh to that many vertices, as ``decimate: true`` does to
    ``max_vertices``."""
    if spec.procedural is not None:
        mesh = build_garment(spec.procedural, body, resolution)
        if not spec.attach:
            return mesh if mesh.name == spec.name else GarmentMesh(spec.name, *_fields(mesh))
        return _attached(spec, mesh.vertices, mesh.triangles, None, body)
    source = load_mesh_file(spec.mesh, spec.units, spec.up_axis, spec.where)
    budget = decimate_to or (spec.max_vertices if spec.decimate else None)
    if budget is not None:
        source = decimate(source, budget)
    if len(source.vertices) > spec.max_vertices:
        raise GarmentMeshError(
            f"{spec.where}: {spec.mesh.name} has {len(source.vertices)} vertices, more than max_vertices "
            f"{spec.max_vertices} (the solver's cost grows with them): decimate it (--decimate {spec.max_vertices}, "
            f"decimate: true in the spec, or fast-simplification / trimesh's simplify_quadric_decimation)")
    check_mesh(source.vertices, source.triangles, f"{spec.where}: {spec.mesh.name}", spec.units)
    vertices = _placed(spec, source.vertices, source.triangles, body)
    return _attached(spec, vertices, source.triangles, source, body)


def _fields(mesh: GarmentMesh) -> tuple:
    return (mesh.vertices, mesh.triangles, mesh.attachments, mesh.rings, mesh.limb_tubes, mesh.shared_attachments)


def _floor_z(body: BodyMeasurements) -> float:
    """The floor in the root frame: below the ankle joints by the ankle's height (Winter)."""
    return body.ankle_z - ANKLE_HEIGHT_PER_STATURE * body.height


def _placed(spec: GarmentSpec, vertices: np.ndarray, triangles: np.ndarray, body: BodyMeasurements) -> np.ndarray:
    """The vertices in the rest pose's root frame on ``body``.

    as_is: the file is in the canonical pose of a body ``reference_height`` tall, origin on the floor
    below the pelvis; scaled by the stature ratio about that origin. fit: the anchor loop (the mesh's top
    boundary loop: a waistband, a neckline) is centred on the body's waist or neck base and scaled across
    (x, y) to the body there plus ease; heights scale by the stature ratio."""
    ratio = body.height / spec.reference_height
    if spec.placement == "as_is":
        return vertices * ratio + np.array([0.0, 0.0, _floor_z(body)])
    loop = _named_loop("top", vertices, triangles, body, f"{spec.where}: placement.anchor")
    ring = vertices[loop]
    centre = 0.5 * (ring.max(axis=0) + ring.min(axis=0))
    half = 0.5 * (ring.max(axis=0) - ring.min(axis=0))
    if spec.anchor == "waist":
        target = np.array([body.waist_x, 0.0, body.waist_z])
        radii = np.array([body.waist_rx, body.waist_ry]) + FIT_EASE_M
    else:
        target = np.array([body.chest_x, 0.0, body.neck_z + FIT_EASE_M])  # above the trunk's top, round the neck
        radii = np.full(2, body.neck_radius + FIT_EASE_M)
    if np.any(half[:2] < 1e-3):
        raise GarmentMeshError(f"{spec.where}: placement.anchor {spec.anchor}: the top boundary loop is flat "
                               f"({half[0]:.3g} x {half[1]:.3g} m); it must go round the {spec.anchor}")
    scale = np.array([radii[0] / half[0], radii[1] / half[1], ratio])
    return (vertices - centre) * scale + target


def _named_loop(name: str, vertices: np.ndarray, triangles: np.ndarray, body: BodyMeasurements,
                where: str) -> np.ndarray:
    """The boundary loop ``name`` names: the highest (top), lowest (bottom), or the one whose mean height is
    nearest the body's waist or neck base."""
    loops = boundary_loops(triangles)
    if not loops:
        raise GarmentMeshError(f"{where}: loop {name}: the mesh is closed, it has no boundary loop")
    heights = np.array([vertices[loop, 2].mean() for loop in loops])
    if name == "top":
        return loops[int(np.argmax(heights))]
    if name == "bottom":
        return loops[int(np.argmin(heights))]
    level = body.waist_z if name == "waist" else body.neck_z
    return loops[int(np.argmin(np.abs(heights - level)))]


def _selected(spec: GarmentSpec, attach: Attach, where: str, vertices: np.ndarray, triangles: np.ndarray,
              source: MeshFile | None, body: BodyMeasurements) -> np.ndarray:
    if attach.select == "loop":
        ids = _named_loop(attach.value, vertices, triangles, body, where)
    elif attach.select == "indices":
        count = len(source.file_to_mesh) if source is not None else len(vertices)
        bad = [i for i in attach.value if i >= count]
        if bad:
            raise GarmentMeshError(f"{where}: indices {bad[:5]} past the mesh's {count} vertices")
        ids = np.unique(source.file_to_mesh[list(attach.value)] if source is not None else list(attach.value))
    elif source is None:
        raise GarmentMeshError(f"{where}: a procedural garment has no vertex {attach.select}s; use loop or indices")
    elif attach.select == "group":
        if attach.value not in source.groups:
            raise GarmentMeshError(f"{where}: {source.path.name} has no vertex group {attach.value!r}; it has: "
                                   f"{', '.join(source.groups) or 'none'}")
        ids = np.flatnonzero(source.groups[attach.value])
    else:
        if source.colours is None:
            raise GarmentMeshError(f"{where}: {source.path.name} has no vertex colours")
        ids = np.flatnonzero(np.all(source.colours[:, :3] == np.array(attach.value), axis=1))
    if len(ids) == 0:
        raise GarmentMeshError(f"{where}: no vertex selected by {attach.select} {attach.value!r}: the garment would "
                               "fall off (check the group, colour or indices in the file)")
    if attach.falloff > 0.0:
        near = np.zeros(len(vertices), dtype=bool)
        for start in range(0, len(vertices), 2048):  # (chunk, selected) distances, bounded memory
            chunk = vertices[start:start + 2048]
            d2 = np.sum((chunk[:, None, :] - vertices[ids][None, :, :]) ** 2, axis=2)
            near[start:start + len(chunk)] = d2.min(axis=1) <= attach.falloff ** 2
        ids = np.flatnonzero(near)
    return np.asarray(ids, dtype=np.int64)


def _attached(spec: GarmentSpec, vertices: np.ndarray, triangles: np.ndarray, source: MeshFile | None,
              body: BodyMeasurements) -> GarmentMesh:
    """The mesh with the spec's attachments: per role the selected vertices (a vertex rides on the first
    entry that selects it), second carriers as ``shared_attachments``; the boundary loops as rings."""
    attachments: dict[str, np.ndarray] = {}
    shared: dict[str, tuple[str, float]] = {}
    taken = np.zeros(len(vertices), dtype=bool)
    for k, attach in enumerate(spec.attach):
        where = f"{spec.where}: attach[{k}].vertices"
        ids = _selected(spec, attach, where, vertices, triangles, source, body)
        ids = ids[~taken[ids]]
        taken[ids] = True
        if attach.role in attachments:
            if shared.get(attach.role) != ((attach.blend_role, attach.blend_weight) if attach.blend_role else None):
                raise SpecError(f"{spec.where}: attach[{k}]: role {attach.role} is attached twice "
                                "with different blends")
            attachments[attach.role] = np.union1d(attachments[attach.role], ids)
        else:
            attachments[attach.role] = ids
        if attach.blend_role:
            shared[attach.role] = (attach.blend_role, attach.blend_weight)
    loops = boundary_loops(triangles)
    rings = {f"boundary_{k}": [loop] for k, loop in enumerate(loops)}
    return GarmentMesh(spec.name, np.asarray(vertices, float), np.asarray(triangles, np.int64), attachments, rings,
                       shared_attachments=shared)
