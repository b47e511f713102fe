"""Random draws keyed by what they belong to — (seed, stream, frame time, star) — not by how many came before.

A counter-based generator: each uniform is a hash of its key (the
splitmix64 finaliser, applied in turn to the seed, the stream, and each
key), so the same frame time gives the same draws whatever frames came
before it — a tracker started late, or restarted, draws what one running
since the start draws (physics.md §6 item 9; the key is the frame's time
in whole nanoseconds, so it does not depend on the frame period either).
Vectorised over arrays of keys; integers are wrapped to 64 bits.
"""

from __future__ import annotations

import numpy as np
from scipy.special import ndtri, pdtrik

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_S30, _S27, _S31, _S11 = np.uint64(30), np.uint64(27), np.uint64(31), np.uint64(11)


def _mix(x: np.ndarray) -> np.ndarray:
    """The splitmix64 finaliser of uint64 arrays (a bijection that spreads every input bit)."""
    x = x ^ (x >> _S30)
    x = x * _M1
    x = x ^ (x >> _S27)
    x = x * _M2
    return x ^ (x >> _S31)


def frame_key(frame_s) -> np.ndarray:
    """The key of frames at times ``frame_s`` (s): whole nanoseconds, int64 ``(N,)``."""
    return np.round(np.atleast_1d(np.asarray(frame_s, float)) * 1e9).astype(np.int64)


class Draws:
    """Uniforms and the laws built on them, keyed by (seed, stream, keys…).

    Args:
        seed: the tracker's seed (≥ 0).
    """

    def __init__(self, seed: int):
        self._seed = _mix(np.array([int(seed) & 0xFFFFFFFFFFFFFFFF], np.uint64) + _GOLDEN)

    def uniform(self, stream, *keys) -> np.ndarray:
        """Uniforms in (0, 1), one per element of the broadcast ``stream`` and ``keys`` (integer arrays: several
        streams in one call broadcast a column of keys against a row of streams)."""
        x = _mix(self._seed ^ (np.asarray(stream, np.uint64) * _GOLDEN))
        for key in keys:
            x = _mix(x + np.asarray(key).astype(np.uint64) * _GOLDEN)
        return ((x >> _S11).astype(np.float64) + 0.5) * 2.0 ** -53

    def normal(self, stream, *keys) -> np.ndarray:
        """Standard normals (the inverse normal CDF of :meth:`uniform`)."""
        return ndtri(self.uniform(stream, *keys))

    def poisson(self, mean, stream, *keys) -> np.ndarray:
        """Poisson counts of the given means (the inverse Poisson CDF of :meth:`uniform`), int64."""
        return poisson_quantile(mean, self.uniform(stream, *keys))


def poisson_quantile(mean, u) -> np.ndarray:
    """The smallest count whose Poisson CDF of ``mean`` reaches ``u`` (int64; 0 where the mean is not positive)."""
    mean = np.asarray(mean, float)
    positive = mean > 0.0
    # pdtrik(p, m): the real k with gammaincc(k + 1, m) = p; the smallest integer with CDF ≥ u is its ceiling.
    with np.errstate(invalid="ignore"):
        k = np.ceil(pdtrik(u, np.where(positive, mean, 1.0)))
    return np.where(positive & np.isfinite(k), np.maximum(k, 0.0), 0.0).astype(np.int64)
