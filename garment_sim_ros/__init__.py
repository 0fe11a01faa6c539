"""garment_sim_ros: real-time garment simulation on a moving character (ROS 2 Jazzy).

The simulation core (``cloth``, ``collision``, ``body``) imports no ROS module; ``ros``
holds the thin node adapters. Units are SI, frames follow REP-103 (x forward, y left, z up).
"""

__version__ = "0.1.0"
