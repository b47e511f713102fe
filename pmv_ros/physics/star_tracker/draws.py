"""Random draws keyed by what they belong to — (seed, stream, frame time, star) — not by how many came before.

A counter-based generator: each uniform is a hash of its key (the
splitmix64 finaliser, applied in turn to the seed, the stream, and each
key), so the same frame time gives the same draws whatever frames came
before it — a tracker started late, or restarted, draws what one running
since the start draws (physics.md §6 item 9; the key is the frame's time
in whole nanoseconds, so it does not depend on the frame period either).
Normals are the inverse normal CDF of a uniform (Wichura's AS 241, to 1e-16
relative), Poisson counts the smallest count whose CDF reaches a uniform.

The draws are compiled (numba): the frame kernel (:mod:`.kernel`) calls
:func:`uniform`, :func:`ndtri` and :func:`poisson_quantile` per draw;
:class:`Draws` gives them on arrays (analysis, tests). Integers are wrapped
to 64 bits.
"""

from __future__ import annotations

import math

import numpy as np
from ..compiled import kernel

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_S30, _S27, _S31, _S11 = np.uint64(30), np.uint64(27), np.uint64(31), np.uint64(11)
_TWO_M53 = 2.0 ** -53
_MASK = 0xFFFFFFFFFFFFFFFF


@kernel(error_model="python", inline="always")
def _mix(x):
    """The splitmix64 finaliser of a uint64 (a bijection that spreads every input bit)."""
    x = x ^ (x >> _S30)
    x = x * _M1
    x = x ^ (x >> _S27)
    x = x * _M2
    return x ^ (x >> _S31)


def seed_hash(seed: int) -> np.uint64:
    """The hashed seed every draw of a tracker starts from."""
    with np.errstate(over="ignore"):
        return _seed_hash(np.uint64(int(seed) & _MASK))


@kernel(error_model="python")
def _seed_hash(seed):
    return _mix(seed + _GOLDEN)


@kernel(error_model="python", inline="always")
def uniform(seed, stream, key1, key2, n_keys):
    """A uniform in (0, 1) keyed by (stream, key1[, key2]) — ``n_keys`` 1 or 2 — from the hashed ``seed``."""
    x = _mix(seed ^ (np.uint64(stream) * _GOLDEN))
    x = _mix(x + np.uint64(key1) * _GOLDEN)
    if n_keys == 2:
        x = _mix(x + np.uint64(key2) * _GOLDEN)
    return (float(x >> _S11) + 0.5) * _TWO_M53


@kernel(error_model="python")
def ndtri(p):
    """The standard normal quantile of p in (0, 1) (Wichura 1988, AS 241 PPND16)."""
    q = p - 0.5
    if abs(q) <= 0.425:
        r = 0.180625 - q * q
        return q * (((((((2509.0809287301226727 * r + 33430.575583588128105) * r + 67265.770927008700853) * r
                        + 45921.953931549871457) * r + 13731.693765509461125) * r + 1971.5909503065514427) * r
                     + 133.14166789178437745) * r + 3.387132872796366608) \
            / (((((((5226.495278852545925 * r + 28729.085735721942674) * r + 39307.89580009271061) * r
                   + 21213.794301586595867) * r + 5394.1960214247511077) * r + 687.1870074920579083) * r
                + 42.313330701600911252) * r + 1.0)
    r = p if q < 0.0 else 1.0 - p
    r = math.sqrt(-math.log(r))
    if r <= 5.0:
        r -= 1.6
        value = (((((((7.7454501427834140764e-4 * r + 0.0227238449892691845833) * r + 0.24178072517745061177) * r
                     + 1.27045825245236838258) * r + 3.64784832476320460504) * r + 5.7694972214606914055) * r
                  + 4.6303378461565452959) * r + 1.42343711074968357734) \
            / (((((((1.05075007164441684324e-9 * r + 5.475938084995344946e-4) * r + 0.0151986665636164571966) * r
                   + 0.14810397642748007459) * r + 0.68976733498510000455) * r + 1.6763848301838038494) * r
                + 2.05319162663775882187) * r + 1.0)
    else:
        r -= 5.0
        value = (((((((2.01033439929228813265e-7 * r + 2.71155556874348757815e-5) * r + 0.0012426609473880784386) * r
                     + 0.026532189526576123093) * r + 0.29656057182850489123) * r + 1.7848265399172913358) * r
                  + 5.4637849111641143699) * r + 6.6579046435011037772) \
            / (((((((2.04426310338993978564e-15 * r + 1.4215117583164458887e-7) * r + 1.8463183175100546818e-5) * r
                   + 7.868691311456132591e-4) * r + 0.0148753612908506148525) * r + 0.13692988092273580531) * r
                + 0.59983220655588793769) * r + 1.0)
    return -value if q < 0.0 else value


@kernel(error_model="python")
def poisson_quantile(mean, u):
    """The smallest count whose Poisson CDF of ``mean`` reaches ``u`` (0 where the mean is not positive).

    The probabilities are summed in logs (no underflow of e^−mean for a large mean) from 12σ + 10 below the mean
    (what is left out is below 1e-30).
    """
    if not mean > 0.0:
        return 0
    start = max(0, int(math.floor(mean - 12.0 * math.sqrt(mean) - 10.0)))
    log_mean = math.log(mean)
    total = 0.0
    k = start
    while True:
        total += math.exp(k * log_mean - mean - math.lgamma(k + 1.0))
        if total >= u or k > mean + 40.0 * math.sqrt(mean) + 100.0:
            return k
        k += 1


def frame_key(frame_s) -> np.ndarray:
    """The key of frames at times ``frame_s`` (s): whole nanoseconds, int64 ``(N,)``."""
    return np.round(np.atleast_1d(np.asarray(frame_s, float)) * 1e9).astype(np.int64)


@kernel(error_model="python")
def _uniforms(seed, stream, key1, key2, n_keys):
    out = np.empty(stream.size)
    for i in range(stream.size):
        out[i] = uniform(seed, stream[i], key1[i], key2[i], n_keys)
    return out


@kernel(error_model="python")
def _normals(u):
    out = np.empty(u.size)
    for i in range(u.size):
        out[i] = ndtri(u[i])
    return out


@kernel(error_model="python")
def _poissons(mean, u):
    out = np.empty(u.size, np.int64)
    for i in range(u.size):
        out[i] = poisson_quantile(mean[i], u[i])
    return out


class Draws:
    """The keyed draws on arrays (analysis and tests; the frame kernel draws one at a time).

    Args:
        seed: the tracker's seed (≥ 0).
    """

    def __init__(self, seed: int):
        self.seed = seed_hash(seed)

    def uniform(self, stream, *keys) -> np.ndarray:
        """Uniforms in (0, 1), one per element of the broadcast ``stream`` and ``keys`` (one or two integer arrays)."""
        if not 1 <= len(keys) <= 2:
            raise ValueError(f"draws are keyed by one or two keys, not {len(keys)}")
        parts = np.broadcast_arrays(np.asarray(stream, np.int64), *(np.asarray(k, np.int64) for k in keys))
        shape = parts[0].shape
        flat = [np.ascontiguousarray(part).ravel() for part in parts]
        second = flat[2] if len(keys) == 2 else np.zeros_like(flat[0])
        return _uniforms(self.seed, flat[0], flat[1], second, len(keys)).reshape(shape)

    def normal(self, stream, *keys) -> np.ndarray:
        """Standard normals (the inverse normal CDF of :meth:`uniform`)."""
        return self.normals_of(self.uniform(stream, *keys))

    @staticmethod
    def normals_of(u) -> np.ndarray:
        """The standard normal quantiles of uniforms ``u`` (:func:`ndtri`)."""
        u = np.asarray(u, float)
        return _normals(np.ascontiguousarray(u).ravel()).reshape(u.shape)

    def poisson(self, mean, stream, *keys) -> np.ndarray:
        """Poisson counts of the given means (the inverse Poisson CDF of :meth:`uniform`), int64."""
        u = self.uniform(stream, *keys)
        mean = np.broadcast_to(np.asarray(mean, float), u.shape)
        return _poissons(np.ascontiguousarray(mean).ravel(), u.ravel()).reshape(u.shape)
