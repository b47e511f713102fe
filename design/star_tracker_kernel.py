"""What the star tracker's compiled frame kernel costs at its first call: compiled fresh, and loaded from its cache.

    python design/star_tracker_kernel.py

The kernel (pmv_ros/physics/star_tracker/kernel.py, numba, ``cache=True``) is compiled the first time a process of
a fresh install measures a frame, and written to its cache (``__pycache__`` beside the module, or NUMBA_CACHE_DIR);
every later process loads it. Two fresh interpreters measure one Kondor frame each, the first with an empty cache
directory (the compile a fresh clone's first test pays), the second with that directory filled; each prints the
time to import the model, to build the tracker (the tables read; the stars' biases drawn) and the first frame.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]

PROBE = r"""
import json, time
began = time.perf_counter()
import numpy as np
from pmv_ros.runtime.flight import flight_values
from pmv_ros.runtime.tracker.runtime import TrackerRuntime
from pmv_ros.storage.files import read_yaml_file
imported = time.perf_counter()
values = flight_values(read_yaml_file("config/kondor.yaml", "preset")).star_tracker
runtime = TrackerRuntime(values, 0.0)
built = time.perf_counter()
runtime.tracker.measure(np.array([100.0]), np.array([[0.0], [0.0], [0.0], [1.0]]), np.zeros((3, 1)))
measured = time.perf_counter()
print(json.dumps({"import_s": imported - began, "build_s": built - imported, "first_frame_s": measured - built}))
"""


def main() -> int:
    print(f"load {os.getloadavg()[0]:.1f}")
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache, "OPENBLAS_NUM_THREADS": "1"}
        for label in ("empty cache (compiled)", "filled cache (loaded)"):
            out = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, env=env, cwd=HERE,
                                 check=True)
            r = json.loads(out.stdout.strip().splitlines()[-1])
            print(f"{label:24s}: import {r['import_s']:.2f} s, tracker built {r['build_s']:.2f} s, "
                  f"first frame {r['first_frame_s']:.3f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
