"""sensor_node's runtime: :class:`SensorRuntime`, on its sample stream (:mod:`.sample_stream`),
its health counters (:mod:`.health`) and the estimator's orientation output (:mod:`.estimator_output`)."""

from .runtime import SensorRuntime

__all__ = ["SensorRuntime"]
