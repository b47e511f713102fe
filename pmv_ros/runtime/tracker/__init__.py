"""star_tracker_node's runtime: :class:`TrackerRuntime` (the frame grid and latency queue it drives
are the star tracker's measurement model, :mod:`pmv_ros.physics.star_tracker`)."""

from .runtime import TrackerRuntime

__all__ = ["TrackerRuntime"]
