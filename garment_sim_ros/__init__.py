"""garment_sim_ros: real-time garment simulation on a moving character (ROS 2 Jazzy).

The simulation core (``cloth``, ``collision``, ``body``) imports no ROS module; ``ros``
holds the thin node adapters. Units are SI, frames follow REP-103 (x forward, y left, z up).
"""

from .kernel_cache import use_source_keyed_cache
from .thread_waiting import prefer_passive_waiting

__version__ = "0.1.0"

use_source_keyed_cache()  # before any kernel module is imported (``kernel_cache``)
prefer_passive_waiting()  # before numba's first parallel loop loads OpenMP (``thread_waiting``)
