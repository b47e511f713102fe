"""The compiled kernels of the sensing path: numba's ``njit``, cached on disk, with IEEE arithmetic.

The sensor's per-sample work — the chords' geometry, the field look-up at
their horizon points, the signal chain, the bright-body check, the pair
angles — runs as compiled loops over samples and chords (numba), one code
for a block of one sample and of thousands: at four chords a sample, numpy's
per-call overhead was the cost (benchmarks/bench_sensing.py). Each stage is
one ``@kernel`` function in the module of its physics; the numpy-facing
functions of those modules marshal arrays into the same kernels, so there is
one implementation of each stage.

* ``cache=True``: the machine code is kept on disk, so the sensing path is
  compiled once per source and CPU (≈ 11 s of CPU), and later processes load
  it (a process that senses starts ≈ 0.45 s of CPU later than without numba:
  its import, its start, the kernels loaded).
  The folder is the package's own — ``pmv_ros/physics/__pycache__/numba-<key>``
  — or, where the package is read-only, ``pmv_ros/numba-<key>`` in the user's
  cache folder (``$XDG_CACHE_HOME`` or ``~/.cache``), or inside a
  ``NUMBA_CACHE_DIR`` the user set. The key hashes every source file of
  :mod:`pmv_ros.physics` and numba's version: numba checks only the stamp of
  a kernel's own file, not of the kernels it calls in other files, so a
  change anywhere starts a fresh folder rather than loading stale code.
* ``error_model="numpy"``: a division by zero gives inf or NaN as in numpy
  (the chain's readings are NaN with a reason code, never an exception).
* No ``fastmath``: the arithmetic is IEEE, operation for operation, so a
  reading does not depend on how many samples a call holds.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numba


def _cache_key() -> str:
    """A hash of every source file of the physics package and of numba's version (16 hex digits)."""
    root = Path(__file__).resolve().parent
    digest = hashlib.sha256(numba.__version__.encode())
    for path in sorted(root.rglob("*.py")):
        digest.update(path.relative_to(root).as_posix().encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def _cache_folder() -> Path:
    """Where the kernels' machine code is kept (see the module docstring); the folder exists."""
    key = f"numba-{_cache_key()}"
    given = os.environ.get("NUMBA_CACHE_DIR")
    own = Path(__file__).resolve().parent / "__pycache__"
    user = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "pmv_ros"
    for base in ([Path(given) / "pmv_ros"] if given else [own, user]):
        try:
            (base / key).mkdir(parents=True, exist_ok=True)
            if os.access(base / key, os.W_OK):
                return base / key
        except OSError:
            continue
    raise OSError(f"no writable folder for the compiled kernels' cache (tried {own} and {user})")


#: The cache folder of this source tree's kernels (numba reads it when a kernel is defined).
CACHE_FOLDER = _cache_folder()
numba.config.CACHE_DIR = str(CACHE_FOLDER)


def kernel(function):
    """``function`` compiled by numba in nopython mode, cached on disk, with numpy's division semantics."""
    return numba.njit(cache=True, error_model="numpy")(function)


def elementwise(function):
    """A scalar function of floats compiled as a numpy ufunc (numba ``vectorize``, cached, compiled at its first
    call). Called with arrays it broadcasts like any ufunc (numpy's warnings and ``errstate`` apply); a kernel
    calls it on floats, so the numpy-facing formula and the kernels' are the same code."""
    return numba.vectorize(cache=True)(function)
