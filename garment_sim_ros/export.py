"""A simulated run as one ``.npz`` file, for inspection, downstream rendering and independent checks (ROS-free).

``RunRecorder`` collects a ``DressedCharacter``'s frames (the skeleton, the garments, the body
volumes, all in the world frame) and ``save`` writes them with ``numpy.savez_compressed``;
``read_run`` reads a file back into a ``Run`` and checks that the shapes agree. Every array is
a plain numpy array (strings as unicode arrays), so ``numpy.load(path)`` reads the file without
pickle and without this package. The keys, shapes, units and frames are tabulated in the README
("Exporting a run").

Frame ``k`` is the state at ``times[k]``; frame 0 is the first frame after dressing. Per-frame
geometry is float32 (1 um at 10 m from the origin), times and static geometry float64.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .body.aiming import volume_poses
from .collision.volumes import KIND_NAMES

FORMAT_VERSION = 2  # 2: joint_aims, joint_aim_directions
_KIND_TEXT = {code: name for name, code in KIND_NAMES.items()}


@dataclass(frozen=True)
class GarmentTrack:
    """One garment of a run: its mesh as cut and its points over the frames."""

    name: str
    triangles: np.ndarray  # (T, 3) int64
    rest_positions: np.ndarray  # (N, 3) m, root frame of the rest pose (as cut)
    positions: np.ndarray  # (F, N, 3) m, world
    attached: np.ndarray  # (N,) bool: carried by a joint, not simulated
    attachment_joint: np.ndarray  # (N,) int64: index into joint_names of the carrying joint, -1 for free points
    # (N,) int64 and (N,) float: a second carrying joint and its weight (a skirt's waistband rides on the
    # pelvis and the spine segment: the weighted mean of where each puts it); -1 and 0 where none
    attachment_joint2: np.ndarray
    attachment_weight2: np.ndarray


@dataclass(frozen=True)
class Run:
    """A run read back by ``read_run``; array shapes as in the README's table."""

    source: str
    fps: float
    speed: float
    times: np.ndarray
    joint_names: np.ndarray
    joint_parents: np.ndarray
    joint_positions: np.ndarray
    joint_rotations: np.ndarray
    # (J,) index into joint_names of the joint each joint's frame is aimed at (``body.aiming``), -1 for none, and
    # (J, 3) the unit direction, in the joint's axes, kept pointing at it
    joint_aims: np.ndarray
    joint_aim_directions: np.ndarray
    joint_map: dict[str, str]
    garments: dict[str, GarmentTrack]
    volume_names: np.ndarray
    volume_kinds: np.ndarray
    volume_joints: np.ndarray
    volume_radii: np.ndarray
    volume_cuts: np.ndarray
    volume_positions: np.ndarray
    volume_rotations: np.ndarray

    @property
    def frames(self) -> int:
        return len(self.times)


class RunRecorder:
    """Collects a dressed character's frames; ``add`` after ``dress`` and after every ``step``."""

    def __init__(self, character, source, fps: float, speed: float = 1.0):
        names = character.garment_names
        if len(set(names)) != len(names):  # the keys are named after the garments
            raise ValueError(f"export: garment names must be distinct, got {names}")
        self.character = character
        self.skeleton = source.skeleton
        self.static = {
            "format_version": np.int64(FORMAT_VERSION),
            "source": np.str_(source.name),
            "fps": np.float64(fps),
            "speed": np.float64(speed),
            "joint_names": np.array(self.skeleton.names, dtype=str),
            "joint_parents": np.array(self.skeleton.parents, dtype=np.int64),
            **_aims(self.skeleton, character.body.volumes.aims),
            "joint_map_roles": np.array(list(character.joint_map), dtype=str),
            "joint_map_joints": np.array(list(character.joint_map.values()), dtype=str),
            "garment_names": np.array(names, dtype=str),
        }
        for solver in character.solvers:
            model = solver.model
            attached = np.zeros(model.num_points, dtype=bool)
            attached[model.attached] = True
            carriers = np.array([self.skeleton.index(character.joint_map[role]) for role in model.attachment_frames],
                                dtype=np.int64)
            joint, joint2 = np.full(model.num_points, -1, dtype=np.int64), np.full(model.num_points, -1, dtype=np.int64)
            weight2 = np.zeros(model.num_points)
            joint[model.attached] = carriers[model.attachment_frame_index]
            shared = model.attachment_weight2 > 0.0
            joint2[model.attached[shared]] = carriers[model.attachment_frame_index2[shared]]
            weight2[model.attached] = model.attachment_weight2
            self.static.update({
                f"garment_{model.name}_triangles": np.asarray(model.triangles, dtype=np.int64),
                f"garment_{model.name}_rest_positions": np.asarray(model.rest_positions, dtype=np.float64),
                f"garment_{model.name}_attached": attached,
                f"garment_{model.name}_attachment_joint": joint,
                f"garment_{model.name}_attachment_joint2": joint2,
                f"garment_{model.name}_attachment_weight2": weight2,
            })
        volumes = character.body.volumes
        self.static.update({
            "volume_names": np.array(volumes.names(), dtype=str),
            "volume_kinds": np.array([_KIND_TEXT[int(k)] for k in volumes.kinds], dtype=str),
            "volume_joints": np.array([v.frame for v in volumes.volumes], dtype=str),
            "volume_radii": np.asarray(volumes.radii, dtype=np.float64),
            "volume_cuts": np.asarray(volumes.cuts, dtype=np.float64),
        })
        self._frames: dict[str, list[np.ndarray]] = {"times": [], "joint_positions": [], "joint_rotations": [],
                                                     "volume_positions": [], "volume_rotations": []}
        for name in names:
            self._frames[f"garment_{name}_positions"] = []

    def add(self, time_s: float, pose) -> None:
        """Record the character's state at ``time_s``, posed at ``pose`` (the pose it was dressed on or stepped to)."""
        if pose.skeleton != self.skeleton:
            raise ValueError("export: the pose's skeleton is not the recorded one")
        centers, rotations = volume_poses(self.character.body.volumes, pose)
        frame = {"times": time_s, "joint_positions": pose.positions, "joint_rotations": pose.rotations,
                 "volume_positions": centers, "volume_rotations": rotations}
        for name, positions in zip(self.character.garment_names, self.character.world_positions()):
            frame[f"garment_{name}_positions"] = positions
        for key, value in frame.items():
            self._frames[key].append(np.array(value, dtype=np.float64 if key == "times" else np.float32))

    @property
    def frames(self) -> int:
        return len(self._frames["times"])

    def save(self, path: str | Path) -> Path:
        """Write the ``.npz`` (its folder is created); returns the path."""
        path = Path(path)
        if path.suffix != ".npz":
            raise ValueError(f"export: {str(path)!r} must end in .npz")
        if not self.frames:
            raise ValueError("export: no frame recorded")
        path.parent.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(path, **self.static, **{k: np.stack(v) for k, v in self._frames.items()})
        return path


def read_run(path: str | Path) -> Run:
    """Read a run written by ``RunRecorder.save``; raises ``ValueError`` on a missing key or shapes that disagree."""
    with np.load(path, allow_pickle=False) as data:
        arrays = {key: data[key] for key in data.files}
    version = int(_get(arrays, path, "format_version"))
    if version != FORMAT_VERSION:
        raise ValueError(f"{path}: export format {version}, this reader reads {FORMAT_VERSION}")
    times = _get(arrays, path, "times")
    frames = len(times)
    joints, volumes = len(_get(arrays, path, "joint_names")), len(_get(arrays, path, "volume_names"))
    expected = {"times": (frames,), "joint_parents": (joints,), "joint_positions": (frames, joints, 3),
                "joint_rotations": (frames, joints, 4), "joint_aims": (joints,), "joint_aim_directions": (joints, 3),
                "volume_kinds": (volumes,), "volume_joints": (volumes,),
                "volume_radii": (volumes, 3), "volume_cuts": (volumes, 2), "volume_positions": (frames, volumes, 3),
                "volume_rotations": (frames, volumes, 4),
                "joint_map_joints": (len(_get(arrays, path, "joint_map_roles")),)}
    garments = {}
    for name in (str(n) for n in _get(arrays, path, "garment_names")):
        prefix = f"garment_{name}_"
        points = len(_get(arrays, path, prefix + "rest_positions"))
        expected.update({prefix + "positions": (frames, points, 3), prefix + "attached": (points,),
                         prefix + "attachment_joint": (points,), prefix + "attachment_joint2": (points,),
                         prefix + "attachment_weight2": (points,)})
        triangles = _get(arrays, path, prefix + "triangles")
        if triangles.ndim != 2 or triangles.shape[1] != 3:
            raise ValueError(f"{path}: {prefix}triangles has shape {triangles.shape}, expected (T, 3)")
        garments[name] = GarmentTrack(name, triangles, arrays[prefix + "rest_positions"],
                                      _get(arrays, path, prefix + "positions"), _get(arrays, path, prefix + "attached"),
                                      _get(arrays, path, prefix + "attachment_joint"),
                                      _get(arrays, path, prefix + "attachment_joint2"),
                                      _get(arrays, path, prefix + "attachment_weight2"))
    for key, shape in expected.items():
        if _get(arrays, path, key).shape != shape:
            raise ValueError(f"{path}: {key} has shape {arrays[key].shape}, expected {shape}")
    return Run(
        source=str(_get(arrays, path, "source")), fps=float(_get(arrays, path, "fps")),
        speed=float(_get(arrays, path, "speed")), times=times, joint_names=arrays["joint_names"],
        joint_parents=arrays["joint_parents"], joint_positions=arrays["joint_positions"],
        joint_rotations=arrays["joint_rotations"], joint_aims=arrays["joint_aims"],
        joint_aim_directions=arrays["joint_aim_directions"],
        joint_map=dict(zip(arrays["joint_map_roles"].tolist(), arrays["joint_map_joints"].tolist())),
        garments=garments, volume_names=arrays["volume_names"], volume_kinds=arrays["volume_kinds"],
        volume_joints=arrays["volume_joints"], volume_radii=arrays["volume_radii"], volume_cuts=arrays["volume_cuts"],
        volume_positions=arrays["volume_positions"], volume_rotations=arrays["volume_rotations"],
    )


def _aims(skeleton, aims) -> dict[str, np.ndarray]:
    """The frames turned onto a joint of the spine chain (``body.aiming.FrameAim``) as per-joint arrays."""
    targets, directions = np.full(len(skeleton.names), -1, dtype=np.int64), np.zeros((len(skeleton.names), 3))
    for aim in aims:
        targets[skeleton.index(aim.frame)] = skeleton.index(aim.target)
        directions[skeleton.index(aim.frame)] = aim.direction
    return {"joint_aims": targets, "joint_aim_directions": directions}


def _get(arrays: dict, path, key: str) -> np.ndarray:
    if key not in arrays:
        raise ValueError(f"{path}: not a garment-sim run export: no {key!r}")
    return arrays[key]
