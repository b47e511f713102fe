"""The compiled kernels of the sensing path: numba's ``njit``, cached on disk, with IEEE arithmetic.

The sensor's per-sample work — the chords' geometry, the field look-up at
their horizon points, the signal chain, the bright-body check, the pair
angles — runs as compiled loops over samples and chords (numba), one code
for a block of one sample and of thousands: at four chords a sample, numpy's
per-call overhead was the cost (benchmarks/bench_sensing.py). Each stage is
one ``@kernel`` function in the module of its physics; the numpy-facing
functions of those modules marshal arrays into the same kernels, so there is
one implementation of each stage.

* numba is imported at a kernel's first call, not when the modules that hold
  kernels are imported: ``@kernel`` gives a stand-in that compiles (or loads)
  on first use and then puts numba's function in its place in every module of
  the package. A process that refuses its input, or never senses (the CLI's
  readers, a node refused at start), does without numba and llvmlite (≈ 70 MB
  resident and ≈ 0.3 s of CPU to import).
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
  Inside the folder a kernel's file is found by its path in the package, not
  on the disk: every copy of the same sources (the source tree, a colcon
  install, a wheel) given one ``NUMBA_CACHE_DIR`` shares one compile.
* ``error_model="numpy"``: a division by zero gives inf or NaN as in numpy
  (the chain's readings are NaN with a reason code, never an exception).
  A kernel may ask for other options of numba's ``njit`` (the star tracker's
  keep numba's default error model and inline the draws).
* No ``fastmath``: the arithmetic is IEEE, operation for operation, so a
  reading does not depend on how many samples a call holds.
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import os
import sys
from pathlib import Path

#: The package's root: the kernels' cache files are named by their path under it.
_PACKAGE = Path(__file__).resolve().parent.parent


def _cache_key(numba_version: str) -> str:
    """A hash of every source file of the physics package and of numba's version (16 hex digits)."""
    root = Path(__file__).resolve().parent
    digest = hashlib.sha256(numba_version.encode())
    for path in sorted(root.rglob("*.py")):
        digest.update(path.relative_to(root).as_posix().encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def _cache_folder(numba_version: str) -> Path:
    """Where the kernels' machine code is kept (see the module docstring); the folder exists."""
    key = f"numba-{_cache_key(numba_version)}"
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


#: numba once imported (:func:`_numba`), and the stand-ins of the kernels defined before.
_state = {"numba": None, "waiting": []}


def cache_folder() -> Path:
    """The cache folder of this source tree's kernels, made if missing (numba's version is read, numba is not
    imported)."""
    return _cache_folder(importlib.metadata.version("numba"))


def _numba():
    """numba, imported and set up once: the cache folder, the locator that names files by their path in the
    package; then every stand-in made so far is replaced by its compiled function in the package's modules."""
    if _state["numba"] is not None:
        return _state["numba"]
    import numba
    from numba.core import caching

    folder = cache_folder()
    numba.config.CACHE_DIR = str(folder)

    class PackageLocator(caching._CacheLocator):
        """A kernel of this package: its cache files in the folder, under the kernel file's path in the package;
        stamped with the file's content (as numba's own locators are)."""

        def __init__(self, py_func, py_file):
            self._py_file, self._lineno = py_file, py_func.__code__.co_firstlineno
            self._cache_path = str(folder / Path(py_file).resolve().parent.relative_to(_PACKAGE))

        def get_cache_path(self):
            return self._cache_path

        def get_source_stamp(self):
            return hashlib.sha256(Path(self._py_file).read_bytes()).hexdigest()

        def get_disambiguator(self):
            return str(self._lineno)

        @classmethod
        def from_function(cls, py_func, py_file):
            if not Path(py_file).resolve().is_relative_to(_PACKAGE):
                return None
            locator = cls(py_func, py_file)
            try:
                locator.ensure_cache_path()
            except OSError:
                return None
            return locator

    implementation = getattr(caching, "CacheImpl", None) or caching._CacheImpl
    implementation._locator_classes = [PackageLocator, *implementation._locator_classes]
    _state["numba"] = numba
    waiting, _state["waiting"] = _state["waiting"], []
    for stand_in in waiting:
        stand_in.compiled()
    # numba types the functions a kernel calls from its module's globals when it compiles: those must be numba's
    # own objects, not the stand-ins (which are left for Python callers that kept one).
    compiled = {id(stand_in): stand_in.compiled() for stand_in in waiting}
    for name, module in list(sys.modules.items()):
        if name == "pmv_ros" or name.startswith("pmv_ros."):
            namespace = getattr(module, "__dict__", {})
            for attribute, value in list(namespace.items()):
                if isinstance(value, _StandIn):
                    namespace[attribute] = compiled.get(id(value), value.compiled())
    return numba


class _StandIn:
    """A kernel before numba is imported: compiled (or loaded from the cache) at its first use, then numba's
    function in its place."""

    def __init__(self, function, make):
        self.py_func, self._make, self._compiled = function, make, None
        self.__name__, self.__qualname__ = function.__name__, function.__qualname__
        self.__doc__, self.__module__, self.__wrapped__ = function.__doc__, function.__module__, function

    def compiled(self):
        if self._compiled is None:
            self._compiled = self._make(_numba())(self.py_func)
        return self._compiled

    def __call__(self, *arguments, **keywords):
        return self.compiled()(*arguments, **keywords)

    def __getattr__(self, name):
        if name.startswith("__"):
            raise AttributeError(name)
        return getattr(self.compiled(), name)


def _deferred(function, make):
    if _state["numba"] is not None:
        return make(_state["numba"])(function)
    stand_in = _StandIn(function, make)
    _state["waiting"].append(stand_in)
    return stand_in


def kernel(function=None, /, **options):
    """``function`` compiled by numba in nopython mode, cached on disk, with numpy's division semantics; as
    ``@kernel(**options)``, with other options of numba's ``njit`` (they override these)."""
    settings = {"cache": True, "error_model": "numpy", **options}
    if function is None:
        return lambda function: kernel(function, **options)
    return _deferred(function, lambda numba: numba.njit(**settings))


def elementwise(function):
    """A scalar function of floats compiled as a numpy ufunc (numba ``vectorize``, cached, compiled at its first
    call). Called with arrays it broadcasts like any ufunc (numpy's warnings and ``errstate`` apply); a kernel
    calls it on floats, so the numpy-facing formula and the kernels' are the same code."""
    return _deferred(function, lambda numba: numba.vectorize(cache=True))
