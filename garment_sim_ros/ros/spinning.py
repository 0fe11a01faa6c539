"""Spinning a node until SIGINT or SIGTERM, and shutting down without a traceback (both console scripts).

rclpy (Jazzy) handles both signals by shutting the context down from its own signal thread: ``spin``
then raises ``ExternalShutdownException`` (or ``KeyboardInterrupt``), and a callback that was running
at that moment can fail in a publish with ``RCLError: ... context is invalid``. Neither is an error
of the node: both end the spin quietly. Anything raised while the context is still valid is.
"""

from __future__ import annotations

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node


def spin_until_shutdown(node: Node) -> None:
    """Spin ``node`` until its context shuts down (a signal); destroy it and shut down in any case."""
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except Exception:
        if node.context.ok():
            raise  # a real failure, not a callback cut short by the shutdown
    finally:
        node.destroy_node()
        rclpy.try_shutdown(context=node.context)
