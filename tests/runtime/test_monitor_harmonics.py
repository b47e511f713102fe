"""The monitor's harmonics on the star tracker's real gaps (physics.md §5.1, §6; statistics.fit_harmonics).

The gap pattern is the tracker's own: a Kondor orbit at its flight session (the Sun near the zenith boresight once
an orbit, ≈ 57° of it; star-poor fields; the SAA), flown through the campaign core at 0.25 Hz.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from pmv_ros.analysis.statistics import MAX_NOISE_GAIN, ORBIT_HARMONICS, OrbitRing, fit_harmonics
from pmv_ros.physics.constants import ARCMIN_RAD
from pmv_ros.runtime.flight import flight_values, fly

REPO = Path(__file__).resolve().parents[2]
KONDOR_PERIOD_S = 5677.0


@pytest.fixture(scope="module")
def kondor_orbit():
    """One Kondor orbit (and a bit) at 0.25 Hz, oblateness kept: the flight and the samples the monitor used."""
    document = yaml.safe_load((REPO / "config" / "kondor.yaml").read_text())
    values = flight_values(document, {"sensor.rate_hz": 0.25, "remove_oblateness": False, "seed": 1})
    flight = fly(values, int(1.05 * KONDOR_PERIOD_S * 0.25))
    return flight, flight.outcome == 0


def test_the_tracker_leaves_a_gap_the_old_rule_refused(kondor_orbit):
    # The old rule refused any orbit with a hole above 10 %: the Sun alone takes ≈ 16 % at β ≈ 0.
    _, used = kondor_orbit
    fit = fit_harmonics(2.0 * np.pi * kondor_orbit[0].t_s[used] / KONDOR_PERIOD_S, np.zeros(int(used.sum())))
    assert fit.largest_hole_rad > 0.1 * 2.0 * math.pi
    assert 0.1 < 1.0 - used.mean() < 0.35


def test_a_known_signal_on_the_trackers_gaps_is_recovered(kondor_orbit):
    """k = 1, 2 at 5′, 9′, 1′ at every k = 15…25, 0.5′ of white noise on the used samples, through the monitor's ring.

    Nothing at the harmonics not fitted, so nothing leaks through the gap: what is left is the noise, σ(a_k) =
    0.5′·√(2/n)·gain ≈ 0.05′ with n ≈ 1000 samples and gains ≤ 2.2 here; 0.2′ is four of those. (With power at
    the other harmonics too, design/harmonic_gaps.py measures up to 0.85′ at k = 15…25 on these gaps.)
    """
    flight, used = kondor_orbit
    t = flight.t_s[used]
    rng = np.random.default_rng(7)
    truth = {1: 5.0, 2: 9.0, **{k: 1.0 for k in range(15, 26)}}
    signal = sum(a * np.cos(2.0 * np.pi * k * t / KONDOR_PERIOD_S + rng.uniform(0, 2 * np.pi))
                 for k, a in truth.items()) + rng.normal(0.0, 0.5, t.size)
    ring = OrbitRing(KONDOR_PERIOD_S, 1)
    ring.add_many(t, signal[:, None])
    [fit] = ring.fits_later()()
    assert fit.pending_note == ""
    assert max(fit.noise_gain) < MAX_NOISE_GAIN
    for k, amplitude in zip(ORBIT_HARMONICS, fit.amplitude):
        assert amplitude == pytest.approx(truth[k], abs=0.2), k


def test_the_monitor_reports_the_oblateness_harmonics_across_the_gaps(kondor_orbit):
    # Kondor's oblateness, physics.md §2.1: roll k = 1 ≈ 5′, pitch k = 2 ≈ 9′ (the residual keeps it here).
    flight, _ = kondor_orbit
    roll, pitch = flight.summary.channel("roll"), flight.summary.channel("pitch")
    assert flight.summary.harmonics_full_orbit
    assert 3.0 < roll.harmonics_rad[1] / ARCMIN_RAD < 8.0 and 6.0 < pitch.harmonics_rad[2] / ARCMIN_RAD < 12.0
    assert all(math.isfinite(a) for a in pitch.harmonics_rad.values()) and pitch.harmonics_pending == ""


def test_an_orbit_the_gaps_leave_undetermined_is_pending_with_the_reason():
    t = np.arange(0.0, KONDOR_PERIOD_S, 4.0)
    half = t < 0.55 * KONDOR_PERIOD_S  # 45 % of the orbit without samples
    fit = fit_harmonics(2.0 * np.pi * t[half] / KONDOR_PERIOD_S, np.cos(2.0 * np.pi * 2 * t[half] / KONDOR_PERIOD_S))
    pending = dict(zip(ORBIT_HARMONICS, fit.pending))
    assert all(math.isnan(a) for k, a in zip(ORBIT_HARMONICS, fit.amplitude) if pending[k])
    assert "undetermined" in pending[20] and "largest hole 162°" in pending[20]
    assert fit.pending_note.startswith("k = 1–2, 15–25: the gaps leave it undetermined")
    # Too few orbital angles for a harmonic: the Nyquist limit names itself.
    sparse = fit_harmonics(np.radians(np.arange(0.0, 360.0, 22.5)), np.zeros(16))
    assert "Nyquist" in dict(zip(ORBIT_HARMONICS, sparse.pending))[15]
