"""Rerun logging: a saved recording read back holds what was logged; bad arguments are refused."""

from __future__ import annotations

import numpy as np
import pytest

from garment_sim_ros.body.skeleton import Skeleton, forward_kinematics
from garment_sim_ros.collision.volumes import CAPSULE, ELLIPSOID, SPHERE, Volume, VolumeSet
from garment_sim_ros.rerun_log import RerunLogger, skeleton_segments, volume_ellipsoids
from garment_sim_ros.shading import shade
from garment_sim_ros.transforms import IDENTITY_QUAT, quat_from_axis_angle


def read_back(path) -> dict:
    """``{(entity, component, static): [row values...]}`` of a recording, via the SDK's RRD reader."""
    from rerun.chunk import RrdReader

    rows: dict = {}
    for chunk in RrdReader(str(path)).stream():
        batch = chunk.to_record_batch()
        times = batch.column("sim_time").to_pylist() if "sim_time" in batch.schema.names else None
        for name in batch.schema.names:
            if ":" in name:
                key = (chunk.entity_path, name, chunk.is_static)
                rows.setdefault(key, []).extend(zip(times or [None] * batch.num_rows, batch.column(name).to_pylist()))
    return rows


def square_garment(n_side: int = 4):
    xs, ys = np.meshgrid(np.linspace(0, 1, n_side), np.linspace(0, 1, n_side))
    positions = np.column_stack([xs.ravel(), ys.ravel(), np.ones(xs.size)])
    triangles = []
    for i in range(n_side - 1):
        for j in range(n_side - 1):
            a = i * n_side + j
            triangles += [(a, a + 1, a + n_side), (a + 1, a + n_side + 1, a + n_side)]
    normals = np.tile([0.0, 0.0, 1.0], (len(positions), 1))
    return ("square", positions, normals, np.array(triangles), shade(normals, (200, 100, 50)))


def test_saved_recording_holds_mesh_volumes_skeleton_and_timings(tmp_path):
    path = tmp_path / "run.rrd"
    garment = square_garment()
    volumes = (np.zeros((2, 3)), np.tile(IDENTITY_QUAT, (2, 1)), np.array([[0.1, 0.1, 0.1], [0.05, 0.06, 0.3]]))
    segments = np.array([[[0, 0, 0], [0, 0, 1.0]], [[0, 0, 1.0], [0, 0.2, 1.2]]])
    with RerunLogger("save", path=path, recording_name="test") as logger:
        assert logger.enabled
        for k, t in enumerate((0.5, 0.75)):
            moved = (garment[0], garment[1] + [0.0, 0.0, 0.1 * k]) + garment[2:]
            logger.log_frame(t, [moved], volumes, segments, {"integration": 1.5 + k, "collision": 0.25})
    rows = read_back(path)

    positions = rows[("/world/garments/square", "Mesh3D:vertex_positions", False)]
    # on the sim_time timeline, as timestamps (seconds since 1970), not durations
    assert [t.timestamp() for t, _ in positions] == [0.5, 0.75]
    assert len(positions[1][1]) == 16
    assert positions[1][1][0][2] == pytest.approx(1.1)
    assert len(rows[("/world/garments/square", "Mesh3D:vertex_normals", False)][0][1]) == 16
    # what does not change is static, sent once: triangles, the garment's colour (the viewer lights it),
    # the volumes' sizes and colour, the bones' radius and colour
    triangles = rows[("/world/garments/square", "Mesh3D:triangle_indices", True)]
    assert len(triangles) == 1 and len(triangles[0][1]) == 18
    assert len(rows[("/world/garments/square", "Mesh3D:albedo_factor", True)]) == 1
    assert not any(key[0].startswith("/world") and key[2] is False and key[1].split(":")[1] in (
        "triangle_indices", "vertex_colors", "albedo_factor", "half_sizes", "colors", "radii") for key in rows)
    assert [v for _, v in rows[("/timings/integration", "Scalars:scalars", False)]] == [[1.5], [2.5]]
    assert [v for _, v in rows[("/timings/collision", "Scalars:scalars", False)]] == [[0.25], [0.25]]
    half_sizes = rows[("/world/body/volumes", "Ellipsoids3D:half_sizes", True)][0][1]
    assert np.allclose(half_sizes, volumes[2])
    strips = rows[("/world/body/skeleton", "LineStrips3D:strips", False)][0][1]
    assert np.allclose(strips, segments)


def test_changed_triangles_are_sent_again(tmp_path):
    path = tmp_path / "run.rrd"
    name, positions, normals, triangles, colors = square_garment()
    with RerunLogger("save", path=path) as logger:
        logger.log_frame(0.0, [(name, positions, normals, triangles, colors)])
        logger.log_frame(0.1, [(name, positions, normals, triangles, colors)])
        logger.log_frame(0.2, [(name, positions, normals, triangles[:4], colors)])
    sent = read_back(path)[("/world/garments/square", "Mesh3D:triangle_indices", True)]
    assert [len(v) for _, v in sent] == [18, 4]


def test_two_loggers_write_separate_recordings(tmp_path):
    garment = square_garment()
    first = RerunLogger("save", path=tmp_path / "a.rrd")
    second = RerunLogger("save", path=tmp_path / "b.rrd")
    first.log_frame(1.0, [garment], timings_ms={"a_only": 1.0})
    second.log_frame(1.0, timings_ms={"b_only": 2.0})
    first.close()
    second.close()
    a, b = read_back(tmp_path / "a.rrd"), read_back(tmp_path / "b.rrd")
    assert ("/timings/a_only", "Scalars:scalars", False) in a and ("/timings/b_only", "Scalars:scalars", False) not in a
    assert ("/timings/b_only", "Scalars:scalars", False) in b and not any(k[0].startswith("/world/garments") for k in b)


def test_off_writes_nothing(tmp_path):
    logger = RerunLogger("off", path=tmp_path / "never.rrd")
    assert not logger.enabled
    logger.log_frame(0.0, [square_garment()], timings_ms={"integration": 1.0})
    logger.close()
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("kwargs, message", [
    ({"sink": "file"}, "unknown sink 'file'"),
    ({"sink": "save"}, "needs path="),
    ({"sink": "save", "path": "out/run.txt"}, "must end in .rrd"),
    ({"sink": "connect", "url": "http://127.0.0.1:9876"}, "not a Rerun gRPC address"),
    ({"sink": "serve", "port": 70000}, "port must be an integer"),
    ({"sink": "off", "application_id": ""}, "application_id"),
])
def test_bad_constructor_arguments_are_refused(kwargs, message):
    with pytest.raises(ValueError, match=message):
        RerunLogger(**kwargs)


@pytest.mark.parametrize("change, message", [
    (lambda g: ("bad name/with slash",) + g[1:], "garment name"),
    (lambda g: (g[0], g[1][:, :2]) + g[2:], r"positions must have shape \(N, 3\)"),
    (lambda g: (g[0], g[1] * np.nan) + g[2:], "non-finite"),
    (lambda g: g[:3] + (g[3] + 100,) + g[4:], "triangles index vertices"),
    (lambda g: g[:4] + (g[4].astype(float),), "colors must be uint8"),
])
def test_bad_frames_are_refused(tmp_path, change, message):
    with RerunLogger("save", path=tmp_path / "run.rrd") as logger:
        with pytest.raises(ValueError, match=message):
            logger.log_frame(0.0, [change(square_garment())])
        with pytest.raises(ValueError, match="finite number of ms"):
            logger.log_frame(0.0, timings_ms={"integration": float("nan")})
        with pytest.raises(ValueError, match="time_s"):
            logger.log_frame(float("inf"))


def test_volume_ellipsoids_follow_their_frames_and_kinds():
    skeleton = Skeleton(("root", "limb"), (-1, 0))
    turn = quat_from_axis_angle([1.0, 0.0, 0.0], np.pi / 2)  # limb's z axis becomes world -y
    pose = forward_kinematics(skeleton, np.array([[1.0, 2.0, 3.0], [0.0, 0.0, 0.5]]),
                              np.array([IDENTITY_QUAT, turn]))
    volumes = VolumeSet((
        Volume("ball", SPHERE, "root", (0.1, 0.1, 0.1)),
        Volume("bone", ELLIPSOID, "limb", (0.05, 0.06, 0.3), cut=(-0.1, 0.5), offset_position=(0.0, 0.0, 0.2)),
        Volume("pill", CAPSULE, "limb", (0.04, 0.03, 0.2)),
    ))
    centers, rotations, half_sizes = volume_ellipsoids(volumes, pose)
    assert np.allclose(half_sizes, [[0.1, 0.1, 0.1], [0.05, 0.06, 0.2], [0.04, 0.04, 0.24]])
    # kept z range [-0.1, 0.3] -> centre 0.1 further along local z: 0.2 + 0.1 = 0.3 along world -y
    assert np.allclose(centers[1], [1.0, 2.0 - 0.3, 3.5])
    assert np.allclose(centers[0], [1.0, 2.0, 3.0]) and np.allclose(rotations[1], turn)
    assert np.allclose(skeleton_segments(pose), [[[1.0, 2.0, 3.0], [1.0, 2.0, 3.5]]])


def test_quality_figures_are_logged_as_scalars_per_garment(tmp_path):
    path = tmp_path / "quality.rrd"
    with RerunLogger("save", path=path) as logger:
        for t, bones in ((0.5, 0), (0.75, 2)):
            logger.log_frame(t, quality={"pants": {"bones_through": bones, "structural_stretch_max": 1.25}})
        with pytest.raises(ValueError, match="quality figure 'depth_mm'"):
            logger.log_frame(1.0, quality={"pants": {"depth_mm": float("nan")}})
    rows = read_back(path)
    assert [v for _, v in rows[("/quality/pants/bones_through", "Scalars:scalars", False)]] == [[0.0], [2.0]]
    assert [v for _, v in rows[("/quality/pants/structural_stretch_max", "Scalars:scalars", False)]] == [[1.25]] * 2


def test_the_tf_input_is_logged_as_scalars(tmp_path):
    path = tmp_path / "input.rrd"
    with RerunLogger("save", path=path) as logger:
        logger.log_frame(0.5, inputs={"lag_ms": 7.5, "backlog": 3})
        with pytest.raises(ValueError, match="input figure 'lag_ms'"):
            logger.log_frame(1.0, inputs={"lag_ms": float("inf")})
    rows = read_back(path)
    assert [v for _, v in rows[("/input/lag_ms", "Scalars:scalars", False)]] == [[7.5]]
    assert [v for _, v in rows[("/input/backlog", "Scalars:scalars", False)]] == [[3.0]]


def test_every_nth_frame_logs_the_3d_data_and_every_frame_the_scalars_and_the_view_origin(tmp_path):
    path = tmp_path / "every.rrd"
    garment = square_garment()
    with RerunLogger("save", path=path, every_n=3) as logger:
        for k in range(7):
            logger.log_frame(0.1 * k, [garment], pelvis=np.array([0.5 * k, 0.2, 0.9]), frame={"fps": 60.0 + k})
        logger.every_n = 1  # changeable at run time (the node's rerun_every_n parameter)
        logger.log_frame(0.8, [garment])
        with pytest.raises(ValueError, match="every_n"):
            logger.every_n = 0
    rows = read_back(path)
    meshes = rows[("/world/garments/square", "Mesh3D:vertex_positions", False)]
    assert [round(t.timestamp(), 6) for t, _ in meshes] == [0.0, 0.3, 0.6, 0.8]
    assert [v for _, v in rows[("/frame/fps", "Scalars:scalars", False)]] == [[60.0 + k] for k in range(7)]
    # the view's origin: on the floor under the pelvis, every frame
    origin = rows[("/world/character", "Transform3D:translation", False)]
    assert np.allclose([v for _, v in origin], [[[0.5 * k, 0.2, 0.0]] for k in range(7)])  # float32


def test_events_are_text_log_entries_on_the_timeline(tmp_path):
    path = tmp_path / "events.rrd"
    with RerunLogger("save", path=path) as logger:
        logger.log_event(2.0, "warning", "teleported", "the root jumped 3.1 m")
        logger.log_event(2.5, "info", "parameters", "air_damping=2.5")
        with pytest.raises(ValueError, match="level 'loud'"):
            logger.log_event(3.0, "loud", "x", "y")
    rows = read_back(path)
    texts = rows[("/events", "TextLog:text", False)]
    assert [(t.timestamp(), v) for t, v in texts] == [(2.0, ["teleported: the root jumped 3.1 m"]),
                                                     (2.5, ["parameters: air_damping=2.5"])]
    assert [v for _, v in rows[("/events", "TextLog:level", False)]] == [["WARN"], ["INFO"]]
