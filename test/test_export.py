"""``garment-sim simulate --export``: the run read back agrees with the clip, the body and the cloth,
checked from the file's own arrays against independent computations."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from garment_sim_ros.body.bvh import load_bvh
from garment_sim_ros.body.fitting import fit_body
from garment_sim_ros.body.root import root_frame
from garment_sim_ros.body.sources import bvh_source
from garment_sim_ros.cli import main
from garment_sim_ros.export import read_run
from garment_sim_ros.transforms import quat_between, quat_conjugate, quat_multiply, quat_rotate, yaw_quat

CLIP = Path(__file__).parent / "data" / "cmu_131_01_walk_mjstyle.bvh"
SPEED, FPS = 8.0, 30.0  # the 8.3 s clip lasts ~1 s: a short run that ends with the clip


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    path = tmp_path_factory.mktemp("export") / "run.npz"
    # band_gives_way 0: the waistband exactly where its skinning puts it (on, a band point under a forearm leaves it)
    code = main(["simulate", "--bvh", str(CLIP), "--garments", "pants", "--speed", str(SPEED), "--fps", str(FPS),
                 "--duration", "5", "--export", str(path), "--json", "--param", "band_gives_way=0"])
    assert code == 0
    return read_run(path)


def test_the_run_stops_at_the_clip_end_and_frames_are_evenly_timed(run):
    clip = load_bvh(CLIP)
    frames = math.floor(clip.duration / SPEED * FPS) + 1  # frame 0 (dressed) to the clip's end
    assert run.times.dtype == np.float64 and run.times.shape == (frames,)
    assert np.allclose(run.times, np.arange(frames) / FPS) and run.fps == FPS and run.speed == SPEED
    assert run.joint_positions.shape == (frames, len(clip.skeleton.names), 3)
    assert list(run.joint_names) == list(clip.skeleton.names) and list(run.joint_parents) == list(clip.skeleton.parents)


def test_joints_are_the_clip_sampled_at_the_times(run):
    clip = load_bvh(CLIP)
    for k in (0, len(run.times) // 2, len(run.times) - 1):
        pose = clip.sample(run.times[k] * SPEED)
        assert np.allclose(run.joint_positions[k], pose.positions, atol=1e-5)
        assert np.allclose(run.joint_rotations[k], pose.rotations, atol=1e-6)
    assert run.joint_map["pelvis"] == "Hips" and run.joint_map["left_upper_leg"] == "LeftHip"
    assert set(run.joint_map.values()) <= set(run.joint_names)


def test_volumes_are_the_fitted_body_posed_on_the_joints(run):
    source = bvh_source(str(CLIP), loop=False, speed=SPEED)
    volumes = fit_body(source.rest_pose, source.joint_map, motion=source.fit_poses(),
                       forearms=True).volumes  # pants: the basic body and the forearms
    assert list(run.volume_names) == volumes.names()
    assert list(run.volume_kinds) == [{0: "sphere", 1: "ellipsoid", 2: "capsule"}[int(k)] for k in volumes.kinds]
    assert np.array_equal(run.volume_radii, volumes.radii) and np.array_equal(run.volume_cuts, volumes.cuts)
    assert run.volume_positions.dtype == np.float32 and run.volume_rotations.shape == (len(run.times), len(volumes), 4)
    clip = load_bvh(CLIP)
    rows = [clip.skeleton.index(f) for f in volumes.frames]
    for k in (0, len(run.times) - 1):
        pose = clip.sample(run.times[k] * SPEED)
        centers, rotations = volumes.world_poses(pose.positions[rows], pose.rotations[rows])
        assert np.allclose(run.volume_positions[k], centers, atol=1e-5)
        assert np.allclose(run.volume_rotations[k], rotations, atol=1e-6)
    assert list(run.volume_joints) == [v.frame for v in volumes.volumes]


def test_attached_points_ride_on_their_joints_from_the_cut(run):
    source = bvh_source(str(CLIP), loop=False, speed=SPEED)
    garment = run.garments["pants"]
    frames, points = len(run.times), len(garment.rest_positions)
    assert garment.positions.shape == (frames, points, 3) and np.all(np.isfinite(garment.positions))
    assert garment.triangles.shape[1] == 3 and garment.triangles.min() == 0 and garment.triangles.max() == points - 1
    assert garment.attached.dtype == bool and 0 < garment.attached.sum() < points
    assert np.all((garment.attachment_joint >= 0) == garment.attached)
    ids = np.flatnonzero(garment.attached)
    skinned = _skinned_from_the_cut(run, garment, ids, source)
    for k in range(frames):  # every frame, from the first after dressing: on its joints, where it was cut
        assert np.abs(garment.positions[k, ids] - skinned(k)).max() < 1e-4, f"frame {k}"
    free = ~garment.attached
    assert np.linalg.norm(garment.positions[-1, free] - garment.positions[0, free], axis=1).mean() > 0.1  # it walked


def test_a_file_that_is_not_a_run_is_refused(tmp_path):
    path = tmp_path / "other.npz"
    np.savez(path, times=np.zeros(3))
    with pytest.raises(ValueError, match="not a garment-sim run export"):
        read_run(path)


def test_a_skirt_waistband_rides_between_the_pelvis_and_the_spine_as_skinned(tmp_path):
    """The waistband is skinned to two joints: in every frame each of its points is the weighted mean of
    where the pelvis and the spine segment put its cut position (linear blend skinning), the spine's frame
    aimed at the chest joint as the export says (CC's Waist -> Spine01 -> Spine02)."""
    clip = Path(__file__).parent / "data" / "cc_cmu_07_01_walk.bvh"
    path = tmp_path / "skirt.npz"
    assert main(["simulate", "--bvh", str(clip), "--garments", "short_skirt", "--fps", "30", "--duration", "1",
                 "--export", str(path), "--json", "--param", "band_gives_way=0"]) == 0
    run = read_run(path)
    garment = run.garments["short_skirt"]
    ids = np.flatnonzero(garment.attached)
    weight = garment.attachment_weight2[ids]
    assert np.all(garment.attachment_joint2[ids] >= 0) and np.all((0.0 < weight) & (weight <= 1.0))
    names = list(run.joint_names)
    assert {names[j] for j in garment.attachment_joint[ids]} == {"CC_Base_Pelvis"}
    assert {names[j] for j in garment.attachment_joint2[ids]} == {"CC_Base_Waist"}
    aimed = {names[j]: names[t] for j, t in enumerate(run.joint_aims) if t >= 0}
    assert aimed == {"CC_Base_Waist": "CC_Base_Spine02"}
    skinned = _skinned_from_the_cut(run, garment, ids, bvh_source(str(clip), loop=False))
    for k in range(len(run.times)):
        assert np.abs(garment.positions[k, ids] - skinned(k)).max() < 1e-4, f"frame {k}"


def _skinned_from_the_cut(run, garment, ids, source):
    """Where the attached points ``ids`` belong in frame k (a function of k): the weighted mean of where their
    joint and their second joint (``attachment_joint2``, weight ``attachment_weight2``; none: weight 0) put
    their cut position (linear blend skinning), a joint aimed as the export says turned onto its target.
    The rest positions are in the rest pose's root frame: pelvis origin, heading yaw."""
    rest = source.rest_pose
    origin, yaw = root_frame(rest, source.joint_map)
    cut = origin + quat_rotate(yaw_quat(yaw), garment.rest_positions[ids])
    weight = garment.attachment_weight2[ids]
    first, second = garment.attachment_joint[ids], np.where(weight > 0.0, garment.attachment_joint2[ids], 0)

    def carried(joints):
        return quat_rotate(quat_conjugate(rest.rotations[joints]), cut - rest.positions[joints])

    local1, local2 = carried(first), carried(second)

    def placed(k, joints, local):
        p, q = run.joint_positions[k, joints].astype(float), run.joint_rotations[k, joints].astype(float)
        for row, joint in enumerate(joints):
            target = run.joint_aims[joint]
            if target >= 0:  # turned so that its aim direction points at the target joint again
                towards = run.joint_positions[k, target].astype(float) - p[row]
                q[row] = quat_multiply(quat_between(quat_rotate(q[row], run.joint_aim_directions[joint]), towards),
                                       q[row])
        return p + quat_rotate(q, local)

    return lambda k: ((1.0 - weight[:, None]) * placed(k, first, local1)
                      + weight[:, None] * placed(k, second, local2))
