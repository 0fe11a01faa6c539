"""Body measurements that garment templates are cut from.

All lengths in metres, expressed in the *root frame* of the rest pose: origin at the pelvis
(hips) joint, x forward, y left, z up (REP-103). Heights are z offsets from the pelvis joint
(negative below it). ``fit_body`` in ``body.fitting`` derives them from a skeleton's own bone
lengths; ``STANDARD_BODY`` is a 1.75 m adult used when no skeleton is given.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields


@dataclass(frozen=True)
class BodyMeasurements:
    height: float  # standing height, m
    waist_z: float  # waistband height above the pelvis joint, m
    waist_rx: float  # waist half depth (x), m
    waist_ry: float  # waist half width (y), m
    hip_z: float  # height of the widest part of the hips, m
    hip_rx: float  # hip half depth, m
    hip_ry: float  # hip half width, m
    crotch_z: float  # crotch height, m (negative)
    leg_y: float  # lateral offset of each leg axis at the hip joint, m
    thigh_radius: float  # thigh radius just below the crotch, m
    knee_z: float  # knee joint height, m
    knee_radius: float  # m
    ankle_z: float  # ankle joint height, m
    ankle_radius: float  # m
    chest_z: float  # height of the chest just under the armpits, m
    chest_rx: float  # chest half depth, m
    chest_ry: float  # chest half width, m
    shoulder_z: float  # shoulder joint height, m
    shoulder_y: float  # lateral offset of each shoulder joint, m
    neck_z: float  # the neck's base: where the trunk (the chest volume) ends below the neck, m
    neck_radius: float  # m
    # Forward offsets (x) of the trunk's cross-sections' centres and of the leg axes, m. Rigs differ in
    # where the root joint sits: CMU's hip joints are 4-6 cm in front of it, the spine above it.
    waist_x: float = 0.0
    hip_x: float = 0.0
    chest_x: float = 0.0
    leg_x: float = 0.0
    # height of the spine segment's joint (the lumbar pivot), m; inf when the skeleton has none
    spine_z: float = float("inf")
    # lateral offset of the inner side of an upper arm hanging straight down from its shoulder joint (the
    # joint's offset less the arm volume's radius; the nearer arm's), m
    underarm_y: float = 0.141

    def __post_init__(self):
        for f in fields(self):
            value = getattr(self, f.name)
            if not isinstance(value, (int, float)) or value != value:
                raise ValueError(f"BodyMeasurements.{f.name} must be a finite number, got {value!r}")
        positive = [f.name for f in fields(self)
                    if f.name.endswith(("_rx", "_ry", "radius", "_y")) or f.name == "height"]
        bad = [n for n in positive if getattr(self, n) <= 0.0]
        if bad:
            raise ValueError(f"BodyMeasurements: {', '.join(bad)} must be > 0")
        order = [("ankle_z", "knee_z"), ("knee_z", "crotch_z"), ("crotch_z", "hip_z"), ("hip_z", "waist_z"),
                 ("waist_z", "chest_z"), ("chest_z", "shoulder_z"), ("chest_z", "neck_z")]
        for low, high in order:
            if not getattr(self, low) < getattr(self, high):
                raise ValueError(f"BodyMeasurements: {low} ({getattr(self, low):.3f} m) must be below {high} "
                                 f"({getattr(self, high):.3f} m)")

    def scaled(self, factor: float) -> "BodyMeasurements":
        return BodyMeasurements(**{k: v * factor for k, v in asdict(self).items()})


STANDARD_BODY = BodyMeasurements(
    height=1.75,
    waist_z=0.10, waist_rx=0.11, waist_ry=0.15,
    hip_z=-0.02, hip_rx=0.13, hip_ry=0.18,
    crotch_z=-0.10, leg_y=0.09,
    thigh_radius=0.085, knee_z=-0.46, knee_radius=0.055, ankle_z=-0.88, ankle_radius=0.04,
    chest_z=0.36, chest_rx=0.12, chest_ry=0.16,
    shoulder_z=0.48, shoulder_y=0.19, neck_z=0.52, neck_radius=0.06,
)
