"""/tf and /tf_static with the vendored tf2_msgs: eci → pmv_sensor composed from them is the sensor's attitude.

tf2_msgs is not on the package registries; ``../shared/vendor`` builds it
from a Jazzy snapshot into a venv copy (the ``ros_tools`` fixture). There the
sensor of ``tests/tf_scenario.py`` (namespace sat1, a mounting of +10′ roll,
−5′ pitch, 3′ yaw, an attitude that moves) runs as a child; ``eci →
sat1/pmv_sensor`` composed from what it put on /tf and /tf_static must equal
the rotation built from /orbit/odometry, /attitude/truth and the mounting
parameters to 1e-9 rad, and its other output must equal the same run's in
this venv, which has no tf2_msgs.
"""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest

from children import child_env, domain_id
from tf_scenario import TICKS, run

pytestmark = [pytest.mark.multi_process, pytest.mark.xdist_group("ros_workspace")]

HERE = Path(__file__).resolve().parent


def test_transforms_compose_to_the_sensor_attitude_and_change_nothing_else(ros_tools, tmp_path):
    # A fresh shell's environment: the venv copy sets up its own library path (tf2_msgs's type support is there).
    env = child_env(tmp_path / "log", domain_id(1), discovery="OFF", fresh_shell=True)
    result = subprocess.run([str(ros_tools / "bin/python"), str(HERE.parent / "tf_scenario.py")], env=env,
                            cwd=tmp_path, stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    with_tf = json.loads(result.stdout)
    assert with_tf["transforms"] == [["eci", "sat1/orbital"], ["sat1/base_link", "sat1/pmv_sensor"],
                                     ["sat1/orbital", "sat1/base_link"]]
    # One /tf message per sample; the static one reached a listener that subscribed after the run (transient local).
    assert with_tf["tf_messages"] == TICKS and with_tf["tf_static_messages"] == 1
    assert with_tf["compared"] == TICKS
    assert with_tf["max_angle_rad"] < 1e-9 and with_tf["max_translation_error_m"] == 0.0
    print(f"eci → sat1/pmv_sensor from /tf + /tf_static vs odometry ∘ truth ∘ mounting: "
          f"{with_tf['max_angle_rad']:.1e} rad at most over {TICKS} samples")
    without = run(publish_tf=False)  # this venv: no tf2_msgs
    assert with_tf["attitude"] == without["attitude"]
    assert set(with_tf["topics"]) - set(without["topics"]) == {"/tf", "/tf_static"}
