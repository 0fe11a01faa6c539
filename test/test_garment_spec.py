"""Garment specs: mesh files in every format, placement, attachment, materials, refused meshes, and the
spec path against the built-ins and on a real clip (issue 13)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
import trimesh
from node_harness import SkeletonPublisher, garment_node, running
from rclpy.parameter import Parameter

from garment_sim_ros.body.fitting import fit_body
from garment_sim_ros.body.measurements import STANDARD_BODY
from garment_sim_ros.body.sources import bvh_source, procedural_source
from garment_sim_ros.cloth.garments import GARMENT_NAMES, build_garment
from garment_sim_ros.cloth.materials import MATERIALS, material_overrides
from garment_sim_ros.cloth.mesh_check import GarmentMeshError, boundary_loops
from garment_sim_ros.cloth.model import build_cloth_model
from garment_sim_ros.cloth.spec import (
    BUILTIN_SPECS,
    FIT_EASE_M,
    SpecError,
    build_mesh,
    load_spec,
    parse_garment_list,
    resolve_garment,
)
from garment_sim_ros.collision.collider import Collider
from garment_sim_ros.dressing import DressedCharacter
from garment_sim_ros.params import DEFAULT_PARAMS, PARAMETER_TABLE, ParameterError
from garment_sim_ros.runtime.character_loop import Status
from garment_sim_ros.runtime.settings import check_garments

ROOT = Path(__file__).resolve().parents[1]
CAPE = ROOT / "config" / "garments" / "cape.yaml"
CLIP = ROOT / "test" / "data" / "cc_cmu_07_01_walk.bvh"
FORMATS = ("obj", "ply", "stl", "glb", "gltf")
RED = (255, 0, 0)


def skirt_tube(around: int = 24, levels: int = 6, top_radius=(0.14, 0.17), bottom_radius=(0.2, 0.24),
               top_z: float = 0.0, length: float = 0.4) -> tuple[np.ndarray, np.ndarray]:
    """A hand-made skirt: an open tube, metres, z up, counter-clockwise from outside; ring 0 on top."""
    angle = 2 * np.pi * np.arange(around) / around
    rings = []
    for k, t in enumerate(np.linspace(0.0, 1.0, levels)):
        rx, ry = (1 - t) * np.array(top_radius) + t * np.array(bottom_radius)
        rings.append(np.stack([rx * np.cos(angle), ry * np.sin(angle), np.full(around, top_z - t * length)], 1))
    triangles = []
    for k in range(levels - 1):
        for j in range(around):
            a, b = k * around + j, k * around + (j + 1) % around
            c, d = a + around, b + around
            triangles += [(a, c, d), (a, d, b)]
    return np.concatenate(rings), np.array(triangles)


def to_file_frame(vertices: np.ndarray, units: float) -> np.ndarray:
    """Project-frame metres -> a y-up file (x the model's left, z forward) in ``units`` metres per number."""
    return vertices[:, [1, 2, 0]] / units


def write_mesh(path: Path, vertices, triangles, colours=None, group=None) -> Path:
    mesh = trimesh.Trimesh(vertices, triangles, process=False)
    if colours is not None:
        mesh.visual = trimesh.visual.ColorVisuals(mesh, vertex_colors=colours)
    if group is not None:
        mesh.vertex_attributes["waistband"] = group.astype(np.float32)
    mesh.export(path)
    return path


def write_spec(path: Path, text: str) -> Path:
    path.write_text(textwrap.dedent(text))
    return path


def user_skirt(tmp_path: Path, fmt: str, attach: str = "{loop: top}", extra: str = "") -> Path:
    """The hand-made skirt in centimetres, y up, with the waistband red and in a vertex group."""
    vertices, triangles = skirt_tube()
    waistband = np.arange(len(vertices)) < 24
    colours = np.where(waistband[:, None], [*RED, 255], [200, 200, 200, 255]).astype(np.uint8)
    write_mesh(tmp_path / f"skirt.{fmt}", to_file_frame(vertices, 0.01), triangles, colours, waistband)
    return write_spec(tmp_path / f"skirt_{fmt}.yaml", f"""\
        name: my_skirt
        mesh: skirt.{fmt}
        units: cm
        up_axis: y
        placement: {{mode: fit, anchor: waist}}
        attach:
          - role: pelvis
            vertices: {attach}
        material: denim
        {extra}
        """)


def sorted_rows(a: np.ndarray) -> np.ndarray:
    return a[np.lexsort(np.round(a, 5).T[::-1])]


# ----------------------------------------------------------------------------- formats
@pytest.mark.parametrize("fmt", FORMATS)
def test_every_format_gives_the_same_hand_made_skirt_fitted_to_the_waist(tmp_path, fmt):
    reference = build_mesh(load_spec(user_skirt(tmp_path / "ref", "obj") if (tmp_path / "ref").mkdir() is None
                                     else None), STANDARD_BODY)
    mesh = build_mesh(load_spec(user_skirt(tmp_path, fmt)), STANDARD_BODY)
    assert mesh.name == "my_skirt" and len(mesh.vertices) == len(reference.vertices) == 144
    np.testing.assert_allclose(sorted_rows(mesh.vertices), sorted_rows(reference.vertices), atol=1e-5)
    # fit: the waistband (the top loop) is centred on the waist and sized to it plus ease; it rides the pelvis
    band = mesh.vertices[mesh.attachments["pelvis"]]
    assert len(band) == 24
    body = STANDARD_BODY
    np.testing.assert_allclose(band[:, 2], body.waist_z, atol=1e-5)
    np.testing.assert_allclose(0.5 * (band.max(0) - band.min(0))[:2],
                               [body.waist_rx + FIT_EASE_M, body.waist_ry + FIT_EASE_M], atol=1e-5)
    # heights scale by the stature ratio: 40 cm long on a 1.75 m body modelled for 1.75 m
    assert mesh.vertices[:, 2].max() - mesh.vertices[:, 2].min() == pytest.approx(0.4, abs=1e-5)
    # the y-up file's forward (+z) is the body's +x: the skirt's depth is along x (0.14 < 0.17 at the top)
    assert np.ptp(band[:, 0]) < np.ptp(band[:, 1])


@pytest.mark.parametrize("fmt", FORMATS)
def test_the_example_cape_loads_from_every_format(tmp_path, fmt):
    reference = build_mesh(load_spec(CAPE), STANDARD_BODY)
    loaded = trimesh.load(CAPE.with_suffix(".obj"), process=False, force="mesh")
    loaded.export(tmp_path / f"cape.{fmt}")
    spec = CAPE.read_text().replace("mesh: cape.obj", f"mesh: cape.{fmt}")
    mesh = build_mesh(load_spec(write_spec(tmp_path / "cape.yaml", spec)), STANDARD_BODY)
    assert len(mesh.vertices) == len(reference.vertices) and len(mesh.triangles) == len(reference.triangles)
    np.testing.assert_allclose(sorted_rows(mesh.vertices), sorted_rows(reference.vertices), atol=1e-5)
    np.testing.assert_allclose(sorted_rows(mesh.vertices[mesh.attachments["chest"]]),
                               sorted_rows(reference.vertices[reference.attachments["chest"]]), atol=1e-5)


# ----------------------------------------------------------------------------- attachment
@pytest.mark.parametrize("fmt, attach", [
    ("ply", "{colour: [255, 0, 0]}"), ("obj", "{colour: [255, 0, 0]}"), ("glb", "{colour: [255, 0, 0]}"),
    ("ply", "{group: waistband}"), ("glb", "{group: waistband}"),
    ("ply", "{indices: [" + ", ".join(map(str, range(24))) + "]}"), ("obj", "{loop: waist}"),
])
def test_each_selector_picks_the_waistband(tmp_path, fmt, attach):
    mesh = build_mesh(load_spec(user_skirt(tmp_path, fmt, attach)), STANDARD_BODY)
    band = mesh.vertices[mesh.attachments["pelvis"]]
    assert len(band) == 24
    np.testing.assert_allclose(band[:, 2], STANDARD_BODY.waist_z, atol=1e-5)


def test_falloff_takes_the_next_ring_and_blend_skins_to_a_second_role(tmp_path):
    spacing = 0.4 / 5  # between rings on the standard body
    user_skirt(tmp_path, "obj")
    spec = write_spec(tmp_path / "falloff.yaml", f"""\
        mesh: skirt.obj
        units: cm
        up_axis: y
        placement: {{mode: fit, anchor: waist}}
        attach:
          - role: pelvis
            vertices: {{loop: top}}
            falloff: {spacing * 1.05}
            blend: {{role: spine, weight: 0.3}}
        """)
    mesh = build_mesh(load_spec(spec), STANDARD_BODY)
    assert len(mesh.attachments["pelvis"]) == 48
    assert mesh.shared_attachments == {"pelvis": ("spine", 0.3)}


# ----------------------------------------------------------------------------- refused meshes
def _bad(tmp_path: Path, vertices, triangles, units: str = "m", extra: str = "", attach: str = "{loop: top}"):
    write_mesh(tmp_path / "bad.ply", vertices, triangles)
    spec = write_spec(tmp_path / "bad.yaml", f"""\
        mesh: bad.ply
        units: {units}
        attach:
          - role: pelvis
            vertices: {attach}
        {extra}
        """)
    return lambda: build_mesh(load_spec(spec), STANDARD_BODY)


def test_bad_meshes_are_refused_each_with_its_fault_and_fix(tmp_path):
    v, t = skirt_tube()
    cases = {
        "not manifold": (np.vstack([v, [[0.0, 0.0, -0.5]]]), np.vstack([t, [[t[0][0], t[0][1], len(v)]]])),
        "degenerate triangle": (np.vstack([v, v[:1] * 0.5 + v[1:2] * 0.5]), np.vstack([t, [[0, 1, len(v)]]])),
        "duplicate triangle": (v, np.vstack([t, t[5:6]])),
        "inconsistent winding": (v, np.vstack([t[:7], t[7:8, ::-1], t[8:]])),
        "in no triangle": (np.vstack([v, [[0.0, 0.0, 0.3]]]), t),
    }
    for words, (vertices, triangles) in cases.items():
        folder = tmp_path / words.replace(" ", "_")
        folder.mkdir()
        with pytest.raises(GarmentMeshError, match=words) as error:
            _bad(folder, vertices, triangles)()
        assert "bad.yaml" in str(error.value) and "bad.ply" in str(error.value)
    # a garment read in the wrong units: 17 m tall is the same file in cm
    (tmp_path / "units").mkdir()
    with pytest.raises(GarmentMeshError, match=r"wrong units.*set units: cm"):
        _bad(tmp_path / "units", v * 42.5, t)()
    # nothing to hang on: a colour the file does not have, a group it does not have
    (tmp_path / "colour").mkdir()
    with pytest.raises(GarmentMeshError, match=r"attach\[0\]\.vertices.*no vertex colours"):
        _bad(tmp_path / "colour", v, t, attach="{colour: [0, 255, 0]}")()
    (tmp_path / "group").mkdir()
    with pytest.raises(GarmentMeshError, match=r"no vertex group 'collar'"):
        _bad(tmp_path / "group", v, t, attach="{group: collar}")()


def test_a_selection_that_finds_no_vertex_is_refused(tmp_path):
    vertices, triangles = skirt_tube()
    colours = np.full((len(vertices), 4), 200, np.uint8)
    write_mesh(tmp_path / "skirt.ply", to_file_frame(vertices, 1.0), triangles, colours)
    spec = write_spec(tmp_path / "s.yaml", """\
        mesh: skirt.ply
        up_axis: y
        attach: [{role: pelvis, vertices: {colour: [255, 0, 0]}}]
        """)
    with pytest.raises(GarmentMeshError, match=r"s\.yaml: attach\[0\]\.vertices: no vertex selected by colour"):
        build_mesh(load_spec(spec), STANDARD_BODY)


def test_too_many_vertices_is_refused_with_the_decimate_hint_and_decimate_brings_it_under(tmp_path):
    vertices, triangles = skirt_tube(around=96, levels=40)  # 3840 vertices
    waistband = np.arange(len(vertices)) < 96
    write_mesh(tmp_path / "dense.ply", vertices, triangles, group=waistband)
    spec = load_spec(write_spec(tmp_path / "dense.yaml", """\
        mesh: dense.ply
        placement: {mode: fit, anchor: waist}
        attach: [{role: pelvis, vertices: {group: waistband}}]
        max_vertices: 1000
        """))
    with pytest.raises(GarmentMeshError, match=r"3840 vertices, more than max_vertices 1000.*--decimate 1000"):
        build_mesh(spec, STANDARD_BODY)
    mesh = build_mesh(spec, STANDARD_BODY, decimate_to=900)
    assert len(mesh.vertices) <= 900
    band = mesh.vertices[mesh.attachments["pelvis"]]
    assert len(band) > 10 and np.all(np.abs(band[:, 2] - band[:, 2].max()) < 0.02)  # still the top edge
    assert len(boundary_loops(mesh.triangles)) == 2  # still an open tube


def test_a_garment_that_starts_inside_the_body_is_moved_out_and_reported(tmp_path):
    source = procedural_source("walk")
    body = fit_body(source.rest_pose, source.joint_map)
    m = body.measurements
    # a skirt narrower than the hips: its middle rings start inside the pelvis and thighs
    vertices, triangles = skirt_tube(top_radius=(m.waist_rx + 0.01, m.waist_ry + 0.01),
                                     bottom_radius=(m.hip_rx * 0.8, m.hip_ry * 0.8), length=0.3)
    write_mesh(tmp_path / "tight.obj", vertices, triangles)
    spec = write_spec(tmp_path / "tight.yaml", """\
        mesh: tight.obj
        placement: {mode: fit, anchor: waist}
        attach: [{role: pelvis, vertices: {loop: top}}]
        """)
    character = DressedCharacter(body, [str(spec)], DEFAULT_PARAMS)
    assert len(character.notes) == 1 and "tight" in character.notes[0] and "moved out" in character.notes[0]
    model = character.solvers[0].model
    collider = Collider(body.volumes, model.num_points)
    poses = _rest_volume_poses(character)
    collider.begin_frame(*poses, *poses)
    free = np.setdiff1d(np.arange(model.num_points), model.attached)
    assert collider.penetration_depths(model.rest_positions)[free].max() <= DEFAULT_PARAMS.collision_epsilon
    # and what it replaced was inside: the same mesh as built, before the move
    built = build_mesh(load_spec(spec), m)
    assert collider.penetration_depths(np.ascontiguousarray(built.vertices))[free].max() > 0.01


def _rest_volume_poses(character):
    from garment_sim_ros.body.root import root_frame
    from garment_sim_ros.transforms import compose, inverse, yaw_quat

    rest = character.body.rest_pose
    position, yaw = root_frame(rest, character.joint_map)
    frames = [compose(*inverse(position, yaw_quat(yaw)), *rest.frame(f)) for f in character.body.volumes.frames]
    return character.body.volumes.world_poses(np.array([p for p, _ in frames]), np.array([q for _, q in frames]))


# ----------------------------------------------------------------------------- spec validation
@pytest.mark.parametrize("text, message", [
    ("mesh: skirt.obj\nattach: [{role: pelvis, vertices: {loop: top}}]\ncolour: red\n", r"unknown key\(s\) colour"),
    ("mesh: skirt.obj\nattach: [{role: hips, vertices: {loop: top}}]\n", r"attach\[0\]: role: got 'hips'"),
    ("mesh: skirt.obj\nattach: [{role: pelvis, vertices: {loop: middle}}]\n", r"attach\[0\]\.vertices\.loop"),
    ("mesh: skirt.obj\nunits: furlong\nattach: [{role: pelvis, vertices: {loop: top}}]\n", r"units: got 'furlong'"),
    ("mesh: skirt.obj\nattach: []\n", r"attach: expected a non-empty list"),
    ("mesh: nothere.obj\nattach: [{role: pelvis, vertices: {loop: top}}]\n", r"mesh: .*nothere\.obj not found"),
    ("mesh: skirt.txt\nattach: [{role: pelvis, vertices: {loop: top}}]\n", r"mesh: 'skirt.txt' is not a supported"),
    ("mesh: skirt.obj\nmaterial: tweed\nattach: [{role: pelvis, vertices: {loop: top}}]\n",
     r"material\.preset: unknown material 'tweed'; known: cotton_shirting"),
    ("mesh: skirt.obj\nmaterial: {preset: silk, friction: -1}\nattach: [{role: pelvis, vertices: {loop: top}}]\n",
     r"material\.friction: got -1"),
    ("mesh: skirt.obj\nplacement: {mode: fit, anchor: knee}\nattach: [{role: pelvis, vertices: {loop: top}}]\n",
     r"placement: anchor: got 'knee'; allowed: waist, neck"),
    ("mesh: skirt.obj\nlayer: -1\nattach: [{role: pelvis, vertices: {loop: top}}]\n", r"layer: got -1"),
    ("- just\n- a list\n", r"expected a mapping"),
])
def test_a_bad_spec_is_refused_naming_the_file_and_the_key(tmp_path, text, message):
    vertices, triangles = skirt_tube()
    write_mesh(tmp_path / "skirt.obj", vertices, triangles)
    spec = tmp_path / "broken.yaml"
    spec.write_text(text)
    with pytest.raises(SpecError, match=message) as error:
        load_spec(spec)
    assert str(error.value).startswith(str(spec))


def test_garment_lists_resolve_built_ins_files_and_names_in_the_search_path(tmp_path):
    specs = parse_garment_list("pants, cape")
    assert [s.name for s in specs] == ["pants", "cape"] and specs[1].path.resolve() == CAPE.resolve()
    assert resolve_garment(str(CAPE)).name == "cape"
    with pytest.raises(SpecError, match="named twice"):
        parse_garment_list(f"cape, {CAPE}")
    with pytest.raises(SpecError, match=r"unknown garment 'kilt'.*one_piece"):
        resolve_garment("kilt")
    own = tmp_path / "mine"
    own.mkdir()
    user_skirt(own, "obj")
    (own / "skirt_obj.yaml").rename(own / "my_skirt.yaml")
    assert resolve_garment("my_skirt", [own]).name == "my_skirt"
    check_garments(["pants", "my_skirt"], str(own))  # the node's check sees garment_path
    with pytest.raises(ParameterError, match=r"garments: unknown garment 'my_skirt'"):
        check_garments(["pants", "my_skirt"], "")


# ----------------------------------------------------------------------------- built-ins and materials
@pytest.mark.parametrize("name", GARMENT_NAMES)
def test_the_built_ins_through_a_spec_file_give_the_same_cloth_models(tmp_path, name):
    source = bvh_source(str(CLIP))
    body = fit_body(source.rest_pose, source.joint_map, detailed=BUILTIN_SPECS[name].detailed_body)
    spec = write_spec(tmp_path / f"{name}.yaml", f"mesh: {{procedural: {name}}}\nname: {name}\n")
    character = DressedCharacter(body, [str(spec)], DEFAULT_PARAMS)
    before = build_cloth_model(build_garment(name, body.measurements))
    after = character.solvers[0].model
    for field in ("rest_positions", "triangles", "springs", "rest_lengths", "attached", "attachment_weight2"):
        np.testing.assert_array_equal(getattr(after, field), getattr(before, field), err_msg=field)
    assert character.notes == []  # cut clear of the body: nothing moved


def test_a_built_in_exported_to_a_file_and_placed_as_is_is_the_built_in(tmp_path):
    source = procedural_source("walk")
    body = fit_body(source.rest_pose, source.joint_map).measurements
    skirt = build_garment("short_skirt", body)
    floor = body.ankle_z - 0.039 * body.height  # as_is: the file's origin is on the floor below the pelvis
    write_mesh(tmp_path / "skirt.obj", skirt.vertices - [0.0, 0.0, floor], skirt.triangles)
    (second, weight), = skirt.shared_attachments.values()
    spec = write_spec(tmp_path / "skirt.yaml", f"""\
        name: short_skirt
        mesh: skirt.obj
        placement: {{mode: as_is, reference_height: {body.height}}}
        attach:
          - role: pelvis
            vertices: {{indices: {skirt.attachments["pelvis"].tolist()}}}
            blend: {{role: {second}, weight: {weight}}}
        """)
    mesh = build_mesh(load_spec(spec), body)
    np.testing.assert_allclose(mesh.vertices, skirt.vertices, atol=1e-7)
    np.testing.assert_array_equal(mesh.triangles, skirt.triangles)
    np.testing.assert_array_equal(mesh.attachments["pelvis"], skirt.attachments["pelvis"])
    assert mesh.shared_attachments == skirt.shared_attachments


def test_material_presets_are_valid_parameters_and_a_garment_keeps_its_material(tmp_path):
    for name, values in MATERIALS.items():
        assert {k: PARAMETER_TABLE[k].check(v) for k, v in values.items()} == values
    assert MATERIALS["denim"]["areal_density"] > MATERIALS["cotton_shirting"]["areal_density"] > \
        MATERIALS["silk"]["areal_density"]
    assert MATERIALS["jersey_knit"]["limit_ratio"] > MATERIALS["denim"]["limit_ratio"]  # a knit stretches
    assert material_overrides({"preset": "silk", "friction": 0.1}, "x")["friction"] == 0.1
    source = procedural_source("walk")
    body = fit_body(source.rest_pose, source.joint_map)
    character = DressedCharacter(body, ["pants", str(user_skirt(tmp_path, "obj"))], DEFAULT_PARAMS)
    pants, skirt = character.solvers
    assert pants.params.areal_density == DEFAULT_PARAMS.areal_density
    assert skirt.params.areal_density == MATERIALS["denim"]["areal_density"]
    np.testing.assert_allclose(skirt.constants.mass, 0.44 * skirt.model.vertex_areas)
    character.set_params(DEFAULT_PARAMS.replace(areal_density=0.3, gravity=(0.0, 0.0, -5.0)))
    assert pants.params.areal_density == 0.3 and skirt.params.areal_density == 0.44
    assert skirt.params.gravity == (0.0, 0.0, -5.0)  # what the material does not set follows the run


# ----------------------------------------------------------------------------- real motion
def _evaluate(*args: str) -> dict:
    result = subprocess.run([sys.executable, "-m", "garment_sim_ros.cli", "evaluate", str(CLIP), "--json", *args],
                            capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert result.returncode in (0, 1), result.stderr
    return json.loads(result.stdout.splitlines()[0])


def test_a_user_skirt_from_a_file_stays_on_a_real_walk_like_the_built_in(tmp_path):
    """A skirt the user modelled for the clip's avatar (the short skirt's cut on its body) as an OBJ in
    centimetres, y up, fitted by its waistband: on the CC walk it meets issue 11's bones, depth and guard
    targets and moves as the built-in does (the same run, figure by figure). On the memo's 10 volumes: with the
    forearms the walk's arms pinch both skirts against the hip (one frame 1.5 mm deep, target a; issue 11)."""
    source = bvh_source(str(CLIP))
    body = fit_body(source.rest_pose, source.joint_map).measurements
    skirt = build_garment("short_skirt", body)
    (second, weight), = skirt.shared_attachments.values()
    write_mesh(tmp_path / "skirt.obj", to_file_frame(skirt.vertices, 0.01), skirt.triangles)
    spec = write_spec(tmp_path / "user_skirt.yaml", f"""\
        name: user_skirt
        mesh: skirt.obj
        units: cm
        up_axis: y
        placement: {{mode: fit, anchor: waist, reference_height: {body.height}}}
        attach: [{{role: pelvis, vertices: {{loop: top}}, blend: {{role: {second}, weight: {weight}}}}}]
        """)
    row = _evaluate("--garments", str(spec), "--no-forearms")
    builtin = _evaluate("--garments", "short_skirt", "--no-forearms")
    assert row["garment"] == "user_skirt" and row["frames"] == builtin["frames"] > 100
    assert row["targets"]["b"] and row["targets"]["a"] and row["targets"]["e"], row
    for figure in ("bones_frames", "deep_frames", "guard_firings"):
        assert row[figure] == builtin[figure], figure
    for figure in ("structural_stretch_p99", "shear_stretch_p99", "max_depth_mm"):
        assert row[figure] == pytest.approx(builtin[figure], abs=0.01), figure


def test_the_example_cape_hangs_on_a_real_walk_without_sinking_into_the_body():
    row = _evaluate("--garments", "cape")
    assert row["garment"] == "cape" and row["frames"] > 100
    # never sinks: no point deeper than the real-motion issue's 5 mm bound (its stricter share of frames
    # deeper than 1 mm is missed by the built-ins on this clip too: see the README's table), no guard
    assert row["max_depth_mm"] <= 5.0 and row["targets"]["e"], row
    assert row["bones_frames"] <= 0.1 * row["frames"], row  # arms under an open cape: see the README


def test_the_example_cape_keeps_its_corners_off_the_swinging_upper_arms():
    """cmu_131, 3 s at 1x: the cape meets every target, stretch (d) included. Cut 120 degrees wide, its top
    corners lay over the upper arms, which pinched its sides against the chest: structural p99 1.23, max 3.04
    (README, "Your own garments")."""
    from garment_sim_ros.commands.evaluate import Run, evaluate_run

    row = evaluate_run(Run(str(ROOT / "test" / "data" / "cmu_131_01_walk_mjstyle.bvh"), "cape", 1.0, 60.0, 3.0))
    assert row["frames"] == 180
    assert {k: ok for k, ok in row["targets"].items() if ok is False} == {}, row


# ----------------------------------------------------------------------------- the node
def test_the_node_wears_a_spec_file_and_dresses_again_when_it_is_saved(graph, tmp_path):
    shutil.copy(CAPE.with_suffix(".obj"), tmp_path / "cape.obj")
    spec = tmp_path / "cape.yaml"
    spec.write_text(CAPE.read_text())

    def save(text: str) -> None:
        stamp = spec.stat().st_mtime
        spec.write_text(text)
        os.utime(spec, (stamp + 1.0, stamp + 1.0))  # a new modification time, however coarse the clock

    node = garment_node(graph, garments=["pants", str(spec)])
    graph.add(SkeletonPublisher(graph.context).node)
    assert graph.spin_until(running(node, 5), 30.0), node.loop.detail
    first = node.loop.character
    assert first.garment_names == ["pants", "cape"]
    assert first.solvers[1].params.areal_density == MATERIALS["cotton_shirting"]["areal_density"]

    save(spec.read_text().replace("material: cotton_shirting", "material: denim"))
    assert graph.spin_until(lambda: node.loop.character not in (None, first) and node.loop.status == Status.RUNNING,
                            30.0), node.loop.detail
    assert node.loop.character.solvers[1].params.areal_density == MATERIALS["denim"]["areal_density"]

    # a broken save: not dressed, the reason names the file and the key; the fix dresses again
    save(spec.read_text().replace("role: chest", "role: cape_hook"))
    assert graph.spin_until(lambda: node.loop.status == Status.UNMAPPABLE, 30.0), node.loop.detail
    assert str(spec) in node.loop.detail and "attach[0]: role: got 'cape_hook'" in node.loop.detail
    save(spec.read_text().replace("role: cape_hook", "role: chest"))
    assert graph.spin_until(lambda: node.loop.status == Status.RUNNING, 30.0), node.loop.detail

    # a garments parameter naming a bad spec is refused with its reason, the running outfit stays
    bad = tmp_path / "bad.yaml"
    bad.write_text("mesh: nothere.obj\nattach: [{role: pelvis, vertices: {loop: top}}]\n")
    result = node.set_parameters_atomically([Parameter("garments", value=["pants", str(bad)])])
    assert not result.successful and str(bad) in result.reason and "not found" in result.reason
    assert node.get_parameter("garments").value == ["pants", str(spec)]


def test_the_command_line_takes_a_spec_refuses_a_dense_mesh_and_decimates_it_on_request(tmp_path):
    vertices, triangles = skirt_tube(around=64, levels=30)  # 1920 vertices
    write_mesh(tmp_path / "dense.ply", vertices, triangles)
    spec = write_spec(tmp_path / "dense.yaml", """\
        mesh: dense.ply
        placement: {mode: fit, anchor: waist}
        attach: [{role: pelvis, vertices: {loop: top}}]
        max_vertices: 800
        """)
    run = [sys.executable, "-m", "garment_sim_ros.cli", "simulate", "--garments", f"pants,{spec}", "--duration", "0.2",
           "--json"]
    refused = subprocess.run(run, capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert refused.returncode == 2 and "Traceback" not in refused.stderr
    assert "1920 vertices, more than max_vertices 800" in refused.stderr and "--decimate 800" in refused.stderr
    export = tmp_path / "run.npz"
    done = subprocess.run([*run, "--decimate", "700", "--export", str(export)], capture_output=True, text=True,
                          timeout=600, cwd=ROOT)
    assert done.returncode == 0, done.stderr
    summary = json.loads(done.stdout.splitlines()[-1])["summary"]
    assert summary["garments"] == ["pants", "dense"] and summary["bones_through_frames"] == 0
    with np.load(export) as run_file:
        assert list(run_file["garment_names"]) == ["pants", "dense"]
        assert 100 < run_file["garment_dense_positions"].shape[1] <= 700
