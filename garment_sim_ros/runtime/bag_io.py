"""rosbag2 files in and out, without ROS: ``rosbags`` (pure Python) reads and writes both storage
formats, MCAP and SQLite3 (ROS-free: messages stay CDR bytes, the project decodes /tf itself).

- ``read_transforms(path)``: the ``/tf`` and ``/tf_static`` messages of a bag (a rosbag2 folder, or
  one ``.mcap`` / ``.db3`` file), in the order they were recorded, as ``(time_ns, static, cdr)``;
- ``decode_tf(cdr)``: a ``tf2_msgs/TFMessage`` object (rosbags' classes, the field names of
  rclpy's) for ``tf_input.ingest``;
- ``BagWriter``: a new bag of raw CDR messages, topic by topic (``storage`` ``mcap`` or ``sqlite3``).
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path
from typing import Iterator

TF_TYPE = "tf2_msgs/msg/TFMessage"
MARKER_ARRAY_TYPE = "visualization_msgs/msg/MarkerArray"
TF_TOPICS = {"/tf": False, "/tf_static": True}  # topic -> static
STORAGES = ("mcap", "sqlite3")
_SUFFIX_STORAGE = {".mcap": "mcap", ".db3": "sqlite3"}


class BagError(ValueError):
    """A bag that cannot be read or written; the message names the path and what is wrong."""


@lru_cache(maxsize=1)
def typestore():
    """rosbags' message definitions of ROS 2 Jazzy (tf2_msgs and visualization_msgs among them)."""
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_JAZZY)


def storage_of(path: str | Path) -> str:
    """``mcap`` or ``sqlite3``: the storage of a rosbag2 folder or file; ``BagError`` for anything else."""
    path = Path(path)
    if not path.exists():
        raise BagError(f"no such bag {str(path)!r}")
    if path.is_file() and path.suffix in _SUFFIX_STORAGE:
        return _SUFFIX_STORAGE[path.suffix]
    if path.is_dir():
        found = {_SUFFIX_STORAGE[p.suffix] for p in path.iterdir() if p.suffix in _SUFFIX_STORAGE}
        if len(found) == 1:
            return found.pop()
    raise BagError(f"{str(path)!r} is no rosbag2 (a folder with metadata.yaml and .mcap or .db3 files, "
                   "or one .mcap / .db3 file)")


def read_transforms(path: str | Path) -> Iterator[tuple[int, bool, bytes]]:
    """``(time_ns, static, cdr)`` of every /tf and /tf_static message of the bag at ``path``, in
    recorded order (``time_ns``: when it was recorded, the bag's clock). ``BagError`` when the bag
    cannot be opened, holds neither topic, or carries them with another message type."""
    from rosbags.rosbag2 import Reader

    storage_of(path)
    try:
        reader = Reader(path)
        reader.open()
    except Exception as err:  # rosbags raises its own errors, YAML and SQLite ones for broken files
        raise BagError(f"cannot open the bag {str(path)!r}: {err}") from None
    try:
        connections = [c for c in reader.connections if c.topic in TF_TOPICS]
        wrong = [f"{c.topic} ({c.msgtype})" for c in connections if c.msgtype != TF_TYPE]
        if wrong:
            raise BagError(f"{str(path)!r}: {', '.join(wrong)} is not {TF_TYPE}")
        if not connections:
            topics = ", ".join(sorted({c.topic for c in reader.connections})) or "none"
            raise BagError(f"{str(path)!r} holds no /tf or /tf_static messages (its topics: {topics})")
        for connection, time_ns, data in reader.messages(connections=connections):
            yield time_ns, TF_TOPICS[connection.topic], bytes(data)
    finally:
        reader.close()


def decode_tf(cdr: bytes):
    """A CDR ``tf2_msgs/TFMessage`` as an object with rclpy's field names (``transforms[i].header.stamp``...)."""
    return typestore().deserialize_cdr(cdr, TF_TYPE)


class BagWriter:
    """A new rosbag2 folder at ``path`` (``BagError`` if it exists) in ``storage`` (``mcap`` or
    ``sqlite3``), written with raw CDR messages: ``write(topic, time_ns, cdr)`` after ``add_topic``."""

    def __init__(self, path: str | Path, storage: str = "mcap"):
        from rosbags.rosbag2 import StoragePlugin, Writer

        if storage not in STORAGES:
            raise BagError(f"bag storage {storage!r}: allowed: {', '.join(STORAGES)}")
        self.path = Path(path)
        if self.path.exists():
            raise BagError(f"{str(self.path)!r} exists already; give a new folder for the bag")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
        self._writer = Writer(self.path, version=9, storage_plugin=plugin)
        self._writer.open()
        self._connections: dict[str, object] = {}

    def add_topic(self, topic: str, msgtype: str) -> None:
        self._connections[topic] = self._writer.add_connection(topic, msgtype, typestore=typestore())

    def write(self, topic: str, time_ns: int, cdr: bytes) -> None:
        self._writer.write(self._connections[topic], int(time_ns), cdr)

    def close(self) -> None:
        """Finish the bag (its metadata.yaml is written here); a second call does nothing."""
        if self._writer is not None:
            self._writer.close()
            self._writer = None

    def __enter__(self) -> "BagWriter":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
