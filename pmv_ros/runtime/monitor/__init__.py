"""error_monitor_node's runtime: :class:`MonitorRuntime`, in front of the monitor core
(:mod:`.core`, :class:`~pmv_ros.runtime.monitor.core.ErrorMonitor`), its event scan (:mod:`.scan`),
the alignment on arrays (:mod:`.alignment`) and its records (:mod:`.records`)."""

from .runtime import MonitorRuntime

__all__ = ["MonitorRuntime"]
