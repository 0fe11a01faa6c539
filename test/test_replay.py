"""``garment-sim replay`` on a bag recorded by ``skeleton_player``, and the Rerun recording it writes.

One recording of a real clip (the Character Creator walk, 2.6 s, played at 60 Hz for 3.4 s, so it
loops once: a teleport and a re-dress) in SQLite3, the same messages copied into MCAP, both replayed.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import local_ros_context

from garment_sim_ros.body.sources import bvh_source
from garment_sim_ros.commands.replay import MARKERS_TOPIC, Replay, configuration
from garment_sim_ros.runtime.bag_io import TF_TYPE, BagError, BagWriter, read_transforms

CLIP = Path(__file__).parent / "data" / "cc_cmu_07_01_walk.bvh"
RECORD_S = 3.4
RATE_HZ = 60.0


def record(path: Path, storage: str) -> None:
    """Play CLIP with ``skeleton_player`` for RECORD_S of wall time, recording /tf to a bag at ``path``."""
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.parameter import Parameter

    from garment_sim_ros.ros.skeleton_player import SkeletonPlayer

    with local_ros_context() as context:
        overrides = {"bvh": str(CLIP), "rate_hz": RATE_HZ, "record": str(path), "record_storage": storage}
        player = SkeletonPlayer(context=context, parameter_overrides=[Parameter(k, value=v)
                                                                      for k, v in overrides.items()])
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(player)
        try:
            start = time.monotonic()
            while time.monotonic() - start < RECORD_S:
                executor.spin_once(timeout_sec=0.01)
        finally:
            executor.shutdown()
            player.destroy_node()  # closes the bag


def copy_bag(source: Path, target: Path, storage: str) -> None:
    with BagWriter(target, storage) as writer:
        writer.add_topic("/tf", TF_TYPE)
        for time_ns, _static, data in read_transforms(source):
            writer.write("/tf", time_ns, data)


def marker_messages(bag: Path) -> list[tuple[int, bytes]]:
    from rosbags.rosbag2 import Reader

    with Reader(bag) as reader:
        assert [c.topic for c in reader.connections] == [MARKERS_TOPIC]
        assert reader.connections[0].msgtype == "visualization_msgs/msg/MarkerArray"
        return [(t, bytes(data)) for _, t, data in reader.messages()]


@pytest.fixture(scope="module")
def replays(tmp_path_factory):
    """The recorded bag in both storages, each replayed with a markers bag: {storage: (bag, summary)}."""
    folder = tmp_path_factory.mktemp("replay")
    record(folder / "walk_sqlite3", "sqlite3")
    copy_bag(folder / "walk_sqlite3", folder / "walk_mcap", "mcap")
    values = configuration(garments=["one_piece"], rate_hz=RATE_HZ)
    results = {}
    for storage in ("sqlite3", "mcap"):
        bag = folder / f"walk_{storage}"
        replay = Replay(bag, values, folder / f"walk_{storage}.rrd", folder / f"walk_{storage}_markers")
        results[storage] = bag, replay.run()
    return results


def test_a_recorded_bag_replays_to_the_same_garments_from_either_storage(replays):
    from rclpy.serialization import deserialize_message
    from visualization_msgs.msg import Marker, MarkerArray

    (sqlite_bag, sqlite), (mcap_bag, mcap) = replays["sqlite3"], replays["mcap"]
    assert any(p.suffix == ".db3" for p in sqlite_bag.iterdir())
    assert any(p.suffix == ".mcap" for p in mcap_bag.iterdir())
    # the player recorded at its rate for the whole time
    stamps = [t for t, _, _ in read_transforms(sqlite_bag)]
    assert (stamps[-1] - stamps[0]) * 1e-9 > RECORD_S - 0.3 and len(stamps) > 0.8 * RECORD_S * RATE_HZ
    # dressed, simulated nearly every frame, the clip's loop seen as a teleport and dressed again
    assert sqlite["garments"] == ["one_piece"] and sqlite["simulated_frames"] > 0.8 * sqlite["frames"]
    assert sqlite["loop_counts"].get("teleported") == 1 and sqlite["max_penetration_m"] < 0.005
    # deterministic: the same messages give the same markers, bit for bit, from SQLite3 and from MCAP
    sqlite_markers, mcap_markers = marker_messages(sqlite["markers_bag"]), marker_messages(mcap["markers_bag"])
    assert len(sqlite_markers) == sqlite["simulated_frames"] == sqlite["marker_messages"]
    assert sqlite_markers == mcap_markers
    assert Path(sqlite["markers_bag"]).parent == sqlite_bag.parent  # next to the input
    # the markers are the garment on the character: around the clip's pelvis at the marker's stamp
    source = bvh_source(str(CLIP), loop=True)
    pelvis = source.joint_map["pelvis"]
    for _, data in sqlite_markers[5::40]:
        message = deserialize_message(data, MarkerArray)
        (garment,) = [m for m in message.markers if m.type == Marker.TRIANGLE_LIST]
        stamp = garment.header.stamp.sec * 1_000_000_000 + garment.header.stamp.nanosec
        at = source.pose((stamp - stamps[0]) * 1e-9).frame(pelvis)[0]  # the player's playback time
        points = np.array([(p.x, p.y, p.z) for p in garment.points])
        assert np.linalg.norm(points.mean(axis=0)[:2] - at[:2]) < 0.25


def test_the_rerun_recording_keeps_the_character_in_view_and_logs_figures_and_events(replays):
    from rerun.chunk import RrdReader

    rrd = Path(replays["mcap"][1]["rrd"])
    assert rrd.parent == replays["mcap"][0].parent  # next to the input
    reader = RrdReader(str(rrd))
    # the default blueprint: its 3D view, whose origin is where the view is centred
    views = {}
    for chunk in reader.stream(store=reader.blueprints()[0]):
        batch = chunk.to_record_batch()
        if "ViewBlueprint:space_origin" in batch.schema.names:
            views[chunk.entity_path] = (batch.column("ViewBlueprint:class_identifier").to_pylist()[-1][0],
                                        batch.column("ViewBlueprint:space_origin").to_pylist()[-1][0])
    contents = {}
    for chunk in reader.stream(store=reader.blueprints()[0]):
        if chunk.entity_path.endswith("/ViewContents"):
            query = chunk.to_record_batch().column("ViewContents:query")
            contents[chunk.entity_path.rsplit("/", 1)[0]] = query.to_pylist()[-1]
    ((view, (_, origin)),) = [(path, v) for path, v in views.items() if v[0] == "3D"]
    assert "/world/**" in contents[view]  # it shows the garments, the body, the skeleton

    data: dict = {}
    statics: dict = {}
    for chunk in reader.stream():
        batch = chunk.to_record_batch()
        for name in batch.schema.names:
            if ":" not in name:
                continue
            if chunk.is_static:
                statics.setdefault((chunk.entity_path, name), []).extend(batch.column(name).to_pylist())
                continue
            assert str(batch.schema.field("sim_time").type) == "timestamp[ns]"  # times are timestamps
            times = [t.value for t in batch.column("sim_time")]
            data.setdefault((chunk.entity_path, name), []).extend(zip(times, batch.column(name).to_pylist()))
    origin_track = dict(data[(f"/{origin}", "Transform3D:translation")])
    meshes = sorted(data[("/world/garments/one_piece", "Mesh3D:vertex_positions")])
    # The character is in the default view at the first, middle and last frame: the garment is
    # centred (horizontally) on the view's origin, which walks with it, metres from the world's.
    travelled = []
    for t, positions in (meshes[0], meshes[len(meshes) // 2], meshes[-1]):
        centre = np.asarray(origin_track[t][0])
        offset = np.asarray(positions)[:, :2] - centre[:2]
        assert np.linalg.norm(offset.mean(axis=0)) < 0.15 and np.abs(offset).max() < 1.0
        travelled.append(np.linalg.norm(centre[:2]))
    assert max(travelled) > 2.0  # a fixed view on the world's origin would have lost it

    # scalars: penetration, bones through the cloth, stretch p99 / max, fps, lag, substeps
    for entity in ("/frame/penetration_mm", "/frame/fps", "/frame/lag_ms", "/frame/substeps",
                   "/quality/one_piece/bones_through", "/quality/one_piece/structural_stretch_p99",
                   "/quality/one_piece/structural_stretch_max"):
        values = [v[0] for _, v in data[(entity, "Scalars:scalars")]]
        assert len(values) > 100 and all(np.isfinite(values)), entity
    assert max(v[0] for _, v in data[("/frame/substeps", "Scalars:scalars")]) >= 1
    # events: dressed, the teleport at the loop, dressed again, on the timeline
    texts = [text[0] for _, text in sorted(data[("/events", "TextLog:text")])]
    kinds = [text.split(":")[0] for text in texts]
    assert kinds.count("dressed") == 2 and kinds.count("teleported") == 1
    assert kinds.index("dressed") < kinds.index("teleported") < len(kinds) - 1 - kinds[::-1].index("dressed")
    # static data once: the triangles and the colour of the garment (dressed twice, the same mesh)
    assert len(statics[("/world/garments/one_piece", "Mesh3D:triangle_indices")]) == 1
    assert len(statics[("/world/garments/one_piece", "Mesh3D:albedo_factor")]) == 1
    assert ("/world/garments/one_piece", "Mesh3D:triangle_indices") not in data


def test_replay_command_line_and_bad_bags(tmp_path, replays):
    bag = replays["mcap"][0]
    rrd = tmp_path / "again.rrd"
    result = subprocess.run([sys.executable, "-m", "garment_sim_ros.cli", "replay", str(bag), "--garments", "one_piece",
                             "--rate", str(RATE_HZ), "--rrd", str(rrd), "--json"], capture_output=True, text=True,
                            timeout=300)
    assert result.returncode == 0, result.stderr
    summary = json.loads(result.stdout)
    assert summary["simulated_frames"] == replays["mcap"][1]["simulated_frames"] and rrd.stat().st_size > 100_000
    assert summary["markers_bag"] is None

    missing = subprocess.run([sys.executable, "-m", "garment_sim_ros.cli", "replay", str(tmp_path / "nope")],
                             capture_output=True, text=True, timeout=60)
    assert missing.returncode == 2 and "no such bag" in missing.stderr
    with BagWriter(tmp_path / "other", "mcap") as writer:
        writer.add_topic("/markers", "visualization_msgs/msg/MarkerArray")
    with pytest.raises(BagError, match=r"no /tf or /tf_static messages \(its topics: /markers\)"):
        list(read_transforms(tmp_path / "other"))
    with pytest.raises(BagError, match="exists already"):
        BagWriter(bag, "mcap")
