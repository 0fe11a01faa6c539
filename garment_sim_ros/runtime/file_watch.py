"""Tells when files changed (ROS-free): the watched params file, the worn garments' spec and mesh files.

For timers, not the frame loop: a look is a ``stat`` per file.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Iterable


class FileWatch:
    """Tells when a file changed: its modification time or size differs from the last look."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self._seen: tuple[int, int] | None = None

    def changed(self) -> bool:
        """True on the first look, whenever the file changed since the last look, and when it has just
        disappeared (reading it then reports the missing file); False while nothing changed."""
        try:
            info = os.stat(self.path)
        except OSError:
            changed = self._seen != (-1, -1)
            self._seen = (-1, -1)
            return changed
        signature = (info.st_mtime_ns, info.st_size)
        if signature == self._seen:
            return False
        self._seen = signature
        return True


class FilesWatch:
    """Several files, each looked at when added: ``changed()`` when any changed (or went) since."""

    def __init__(self, paths: Iterable[str | Path] = ()):
        self._watches: list[FileWatch] = []
        self.add(paths)

    def add(self, paths: Iterable[str | Path]) -> None:
        for path in paths:
            watch = FileWatch(path)
            watch.changed()  # the first look
            self._watches.append(watch)

    def changed(self) -> bool:
        return any([watch.changed() for watch in self._watches])  # every file looked at: all up to date
