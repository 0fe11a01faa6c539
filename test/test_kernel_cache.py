"""The compiled kernels' cache is keyed by the package's sources (``garment_sim_ros.kernel_cache``): numba's
own check sees only a kernel's file, and a kernel calling another module's kept that module's old code."""

from __future__ import annotations

from pathlib import Path

import numba.core.config

import garment_sim_ros
from garment_sim_ros.kernel_cache import PACKAGE, cache_directory, sources_digest


def _package(tmp_path: Path) -> Path:
    root = tmp_path / "pkg"
    (root / "sub").mkdir(parents=True)
    (root / "a.py").write_text("x = 1\n")
    (root / "sub" / "b.py").write_text("y = 2\n")
    return root


def test_any_change_to_any_source_file_changes_the_digest(tmp_path):
    root = _package(tmp_path)
    before = sources_digest(root)
    assert sources_digest(root) == before  # the same sources, the same cache
    (root / "sub" / "b.py").write_text("y = 3\n")  # a callee's file: numba's own check would not see it
    edited = sources_digest(root)
    (root / "sub" / "b.py").rename(root / "sub" / "c.py")
    renamed = sources_digest(root)
    (root / "d.py").write_text("")
    assert len({before, edited, renamed, sources_digest(root)}) == 4


def test_the_directory_is_the_users_when_set_else_the_packages(tmp_path):
    assert cache_directory("abc", str(tmp_path)) == tmp_path / "garment_sim_ros-abc"
    assert cache_directory("abc", None, tmp_path) == tmp_path / "__pycache__" / "kernels-abc"


def test_importing_the_package_points_numba_at_the_directory_of_its_sources():
    assert garment_sim_ros.__name__ == "garment_sim_ros"
    assert Path(numba.core.config.CACHE_DIR).name.endswith(sources_digest(PACKAGE))
