"""Where numba keeps the compiled kernels: a directory named by a digest of the package's sources.

numba's on-disk cache (``cache=True``) checks only the source file of the function it loads, so a kernel
that calls kernels of other modules keeps their old code, compiled into it, after those files change: the
fused frame (``cloth.fused``) ran the contact planes' previous rule while the reference loop ran the new
one, until the cache was deleted by hand. Naming the cache directory by a digest of every source file of
the package makes any change compile afresh, and an unchanged package loads its kernels as before (the
first frame after a restart as fast as the next). Directories of older sources are left in place (a
process of the older version may still be reading them); ``git clean -X`` or deleting them is safe.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent


def sources_digest(root: Path = PACKAGE) -> str:
    """A digest of the names and contents of every ``.py`` file under ``root``."""
    digest = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        digest.update(str(path.relative_to(root)).encode())
        digest.update(b"\0")
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def cache_directory(digest: str, user_directory: str | None = None, package: Path = PACKAGE) -> Path:
    """The cache directory for sources of ``digest``: under ``user_directory`` (``NUMBA_CACHE_DIR``, when the
    user set one), else under the package's ``__pycache__`` where it is writable, else the user's cache."""
    if user_directory:
        return Path(user_directory) / f"garment_sim_ros-{digest}"
    if os.access(package, os.W_OK):
        return package / "__pycache__" / f"kernels-{digest}"
    return Path.home() / ".cache" / "garment_sim_ros" / f"kernels-{digest}"


def use_source_keyed_cache() -> Path:
    """Point numba's cache at ``cache_directory`` for the sources as they are now (before any kernel is
    compiled: numba reads ``config.CACHE_DIR`` when a ``cache=True`` function is first compiled or loaded)."""
    from numba.core import config

    directory = cache_directory(sources_digest(), os.environ.get("NUMBA_CACHE_DIR"))
    config.CACHE_DIR = str(directory)
    return directory
