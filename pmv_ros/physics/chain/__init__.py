"""The sensor's signal chain: one scan chord turns a horizon radiance profile into Gam and Del.

physics.md §4 as named, ordered, pure stages — scan, IFOV, detector lag,
comparators, Gam and Del, brightness correction, pair angles — each usable and
testable alone. The package, bottom up:

* :mod:`.parameters` — :class:`ChainParameters` (the instrument, with the
  fitted detector time constant) and the reason codes :class:`DetectionStatus`;
* :mod:`.chord_geometry` — a chord near its horizon as an equivalent sphere:
  tangent height, ground distance, the scan start;
* :mod:`.stages` — the seven stages, and :func:`sense_sampled_chords`, which
  runs them on any radiance profile by sampling it (the general, slow path);
* :mod:`.fast` — the hot path, :func:`sense_horizon_chords`: the same readings
  from tabulated responses to a few elementary profile shapes.

Reason codes (:class:`DetectionStatus`, like python-sgp4's error table): a chord
that cannot be sensed gives NaN and a non-zero code; array code never raises
for bad samples.
"""

from .chord_geometry import (
    chord_ground_distance,
    chord_nadir_of_ground_distance,
    chord_nadir_of_height,
    chord_tangent_height,
    scan_start_nadir_angle,
    sphere_chord,
    tangent_height_rate_from_layer,
)
from .fast import (
    COARSE_POINTS,
    COARSE_STRIDE,
    DISC_SAMPLE_INWARD_RAD,
    DISC_SAMPLE_POWERS,
    GROUND_DISTANCE_FIT_RAD,
    GROUND_DISTANCE_POWERS,
    TABLE_OVERSAMPLING,
    ChainArrays,
    ChainKit,
    ResponseTables,
    chain_kit,
    disc_sample_profile,
    prepare,
    response_tables,
    sense_chord,
    sense_horizon_chords,
    unpack,
)
from .parameters import DEFAULT_CHAIN_PARAMETERS, ChainParameters, DetectionStatus
from .stages import (
    ChordReadings,
    brightness_correction,
    comparator_times,
    detector_lag,
    gam_del,
    ifov_edge_response,
    ifov_energy,
    ifov_line_spread,
    pair_angles,
    scan_nadir_angles,
    sense_sampled_chords,
)

__all__ = [
    "DEFAULT_CHAIN_PARAMETERS", "ChainParameters", "DetectionStatus",
    "chord_ground_distance", "chord_nadir_of_ground_distance", "chord_nadir_of_height", "chord_tangent_height",
    "scan_start_nadir_angle", "sphere_chord", "tangent_height_rate_from_layer",
    "ChordReadings", "brightness_correction", "comparator_times", "detector_lag", "gam_del", "ifov_edge_response",
    "ifov_energy", "ifov_line_spread", "pair_angles", "scan_nadir_angles", "sense_sampled_chords",
    "COARSE_POINTS", "COARSE_STRIDE", "DISC_SAMPLE_INWARD_RAD", "DISC_SAMPLE_POWERS",
    "GROUND_DISTANCE_FIT_RAD", "GROUND_DISTANCE_POWERS", "TABLE_OVERSAMPLING", "ChainArrays", "ChainKit",
    "ResponseTables", "chain_kit",
    "disc_sample_profile", "prepare", "response_tables", "sense_chord", "sense_horizon_chords", "unpack",
]
