"""The package's layers, as an import-graph check (issue 14): every module's imports, parsed with ``ast``
(those inside functions and ``TYPE_CHECKING`` blocks included), against the rule the README draws:

    core (body, cloth, collision)  <-  dressing, quality, export, ...  <-  runtime (ROS-free frame loop)
                                                                        <-  ros (rclpy)  and  commands (CLI)

- the core and ``runtime/`` import no rclpy or ROS message module, and nothing from ``ros/`` or
  ``commands/``; the core imports, of the package, only itself and the shared tables and math
  (``params``, ``transforms``, ``config_files``): nothing of the layers above it;
- no library module (anything outside ``ros/``, ``commands/`` and ``cli.py``) imports ``ros/`` or
  ``commands/``;
- the library between the core and the runtime (the top-level modules but the tools that drive the
  runtime, ``ABOVE_RUNTIME``) imports nothing of ``runtime/``, and the runtime none of those tools;
- only ``ros/`` imports rclpy or a ROS message package.

Each rule is also run on planted violations, so a checker that stopped seeing imports would fail here.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = "garment_sim_ros"
ROOT = Path(__file__).resolve().parents[1] / PACKAGE

CORE = ("body", "cloth", "collision")
SHARED = ("params", "transforms", "quat_kernels", "config_files")  # top-level modules the core may use
ABOVE_RUNTIME = ("benchmarking", "warmup", "docs", "cli")  # top-level modules that use runtime/
ROS_FREE = CORE + ("runtime",)
# ROS client libraries and interface packages; ``rosbags`` (pure Python, no ROS install) is not one of them
ROS_PREFIXES = ("rclpy", "rcl_interfaces", "builtin_interfaces", "rosidl", "tf2_ros", "rosbag2_py", "ament_index")
ROS_SUFFIXES = ("_msgs", "_srvs")


def module_name(path: Path) -> str:
    parts = path.relative_to(ROOT.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports(source: str, module: str, is_package: bool = False) -> set[str]:
    """Absolute names of every module ``source`` (the text of ``module``) imports, relative ones resolved;
    ``from a import b`` gives both ``a`` and ``a.b`` (``b`` may be a submodule)."""
    base = module.split(".") if is_package else module.split(".")[:-1]
    found: set[str] = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                parent = base[:len(base) - (node.level - 1)]
                origin = ".".join(parent + ([node.module] if node.module else []))
            else:
                origin = node.module or ""
            found.add(origin)
            found.update(f"{origin}.{alias.name}" for alias in node.names if alias.name != "*")
    return found


def is_ros(name: str) -> bool:
    top = name.split(".")[0]
    return top.startswith(ROS_PREFIXES) or top.endswith(ROS_SUFFIXES)


def layer(module: str) -> str:
    """The module's sub-package (``cloth``, ``ros``, ...), or ``""`` for a top-level module."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 and (ROOT / parts[1]).is_dir() else ""


def within(name: str, subpackage: str) -> bool:
    return name == f"{PACKAGE}.{subpackage}" or name.startswith(f"{PACKAGE}.{subpackage}.")


def violations(module: str, imported: set[str]) -> list[str]:
    """What ``module``'s imports break of the rules above, one line each."""
    found, reported = [], []
    here = layer(module)
    for name in sorted(imported):
        if any(name.startswith(r + ".") for r in reported):
            continue  # ``from a import b``: ``a`` said it
        before = len(found)
        if is_ros(name) and here != "ros":
            found.append(f"{module} imports {name}: only ros/ imports rclpy and ROS messages")
        for upper in ("ros", "commands"):
            if within(name, upper) and here not in ("ros", "commands") and module != f"{PACKAGE}.cli":
                found.append(f"{module} imports {name}: only ros/, commands/ and cli.py import {upper}/")
        top_level = module.split(".")[1] if here == "" and module != PACKAGE else None
        if within(name, "runtime") and top_level is not None and top_level not in ABOVE_RUNTIME:
            found.append(f"{module} imports {name}: of the top-level modules only {', '.join(ABOVE_RUNTIME)} "
                         "import runtime/")
        if here == "runtime" and any(within(name, tool) for tool in ABOVE_RUNTIME):
            found.append(f"{module} imports {name}: runtime/ imports none of {', '.join(ABOVE_RUNTIME)}")
        if here in CORE and name.startswith(PACKAGE + ".") and len(found) == before:
            if not any(within(name, allowed) for allowed in CORE + SHARED):
                found.append(f"{module} imports {name}: the core imports only itself and {', '.join(SHARED)}")
        if len(found) > before:
            reported.append(name)
    return found


def package_modules() -> list[tuple[str, Path]]:
    return [(module_name(p), p) for p in sorted(ROOT.rglob("*.py"))]


def test_the_package_keeps_its_layers():
    modules = package_modules()
    assert len(modules) > 60 and any(layer(m) == "runtime" for m, _ in modules)
    broken = []
    for module, path in modules:
        broken += violations(module, imports(path.read_text(), module, path.name == "__init__.py"))
    assert not broken, "\n".join(broken)


def test_the_runtime_and_the_core_are_ros_free_and_ros_holds_the_rclpy_modules():
    """The split itself, not only the absence of violations: the runtime is used by ros/, and every
    module of ros/ but its package marker imports rclpy or a ROS message package."""
    seen = {m: imports(p.read_text(), m, p.name == "__init__.py") for m, p in package_modules()}
    ros_modules = [m for m in seen if layer(m) == "ros" and m != f"{PACKAGE}.ros"]
    assert ros_modules and all(any(is_ros(n) for n in seen[m]) for m in ros_modules), \
        [m for m in ros_modules if not any(is_ros(n) for n in seen[m])]
    assert any(within(n, "runtime") for m in ros_modules for n in seen[m])
    for module, names in seen.items():
        if layer(module) in ROS_FREE:
            assert not any(is_ros(n) for n in names), module


@pytest.mark.parametrize("module, source, expected", [
    # the core importing rclpy, a message package, the adapters, the commands (relative, in a function)
    ("garment_sim_ros.cloth.solver", "import rclpy\n", ["rclpy"]),
    ("garment_sim_ros.collision.collider", "from visualization_msgs.msg import Marker\n", ["visualization_msgs.msg"]),
    ("garment_sim_ros.body.fitting", "def f():\n    from ..ros.node import GarmentSimNode\n",
     ["garment_sim_ros.ros.node"]),
    ("garment_sim_ros.runtime.character_loop", "from ..commands.simulate import run\n",
     ["garment_sim_ros.commands.simulate"]),
    ("garment_sim_ros.runtime", "from .. import ros\n", ["garment_sim_ros.ros"]),
    # the core reaching up to the dressed character
    ("garment_sim_ros.cloth.solver", "from ..quality import GarmentMeter\n", ["garment_sim_ros.quality"]),
    ("garment_sim_ros.body.fitting", "from garment_sim_ros.runtime import settings\n", ["garment_sim_ros.runtime"]),
    # a library module importing the command layer, or a ROS-free module through an absolute name
    ("garment_sim_ros.benchmarking", "from .commands.simulate import make_character\n",
     ["garment_sim_ros.commands.simulate"]),
    ("garment_sim_ros.runtime.markers", "import garment_sim_ros.ros.marker_objects\n",
     ["garment_sim_ros.ros.marker_objects"]),
    # the library below the runtime reaching up into it, the runtime reaching up to the tools above it
    ("garment_sim_ros.dressing", "from .runtime.settings import solver_params\n", ["garment_sim_ros.runtime.settings"]),
    ("garment_sim_ros.runtime.crowd", "from ..benchmarking import progress\n", ["garment_sim_ros.benchmarking"]),
    # rclpy in a command: the commands go through ros/
    ("garment_sim_ros.commands.demo", "def run():\n    from rclpy.context import Context\n", ["rclpy.context"]),
])
def test_the_checker_catches_a_planted_violation(module, source, expected):
    found = violations(module, imports(source, module, module == "garment_sim_ros.runtime"))
    assert sorted(line.split(" imports ")[1].split(":")[0] for line in found) == sorted(expected), found


@pytest.mark.parametrize("module, source", [
    ("garment_sim_ros.ros.node", "import rclpy\nfrom ..runtime.settings import PARAMETER_ROWS\n"),
    ("garment_sim_ros.commands.demo", "from ..ros.in_process import node_and_player\n"),
    ("garment_sim_ros.cli", "from .commands import simulate\n"),
    ("garment_sim_ros.runtime.markers", "from .marker_cdr import MarkerData\nfrom ..shading import BODY_RGB\n"),
    ("garment_sim_ros.warmup", "from .runtime.markers import frame_markers\n"),
    ("garment_sim_ros.cloth.model", "from ..params import SolverParams\nfrom ..body.skeleton import Skeleton\n"),
    ("garment_sim_ros.runtime.bag_io", "from rosbags.rosbag2 import Reader\n"),  # rosbags is not ROS
])
def test_the_checker_allows_what_the_layers_allow(module, source):
    assert violations(module, imports(source, module)) == []
