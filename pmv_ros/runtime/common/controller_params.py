"""Parameters of attitude_controller_node: the rigid-body plant and the PD loop that closes on ``pmv/attitude``.

The runtime that uses them is :class:`pmv_ros.runtime.control.ControllerRuntime`; the physics
:mod:`pmv_ros.physics.rigid_body`. Units as written in YAML: Hz, kg·m², N·m, arcmin, km.
"""

from __future__ import annotations

from dataclasses import replace

from .frames import FRAME_PARAMS
from .parameters import ParamSpec

#: Principal moments of the default body, kg·m²: an assumed ≈ 1 t spacecraft (Kondor's are not published),
#: J_y > J_x > J_z so that gravity gradient alone holds it nadir-pointing (the Lagrange region). The loop's
#: response depends on the inertia only through disturbance / inertia: the gains scale with it.
DEFAULT_INERTIA_KG_M2 = [900.0, 1100.0, 600.0]

#: How yaw, which the PMV does not observe (physics.md §1), is held.
YAW_HANDLING = ("truth", "free")


def controller_params(input_params: tuple, orbit_altitude: ParamSpec, max_abs_angle: ParamSpec) -> tuple:
    """attitude_controller_node's specs, given the ones it shares with the other nodes (the input guards, the
    orbit altitude, the plausibility bound of ``pmv/attitude``: one spec each, in :mod:`.assembly`)."""
    return input_params + FRAME_PARAMS + (
        max_abs_angle,
        replace(orbit_altitude, description="circular orbit altitude: the plant's orbital frame turns at its "
                "mean motion (gyroscopic and gravity-gradient torques, the orbital-frequency disturbance, the "
                "period of the pointing harmonics)"),
        ParamSpec("control.rate_hz", 10.0, "control rate: the plant is integrated, the torque updated and "
                  "attitude/truth and /tf published at this rate", 0.1, 100.0, unit="Hz", read_only=True),
        ParamSpec("control.bandwidth_hz", 0.02, "natural frequency f_n of each axis's closed loop "
                  "(K_p = J (2 pi f_n)^2; the -3 dB bandwidth for damping 0.707), at most control.rate_hz / 20",
                  1e-4, 1.0, unit="Hz"),
        ParamSpec("control.damping_ratio", 0.7, "damping ratio of each axis's closed loop (K_d = 2 zeta J 2 pi f_n)",
                  0.1, 5.0),
        ParamSpec("control.yaw", "truth", "yaw, which the PMV does not observe: truth - closed on the true yaw "
                  "(a star tracker or gyrocompass gives it) with the same gains; free - no yaw torque",
                  choices=YAW_HANDLING),
        ParamSpec("control.measurement_timeout_s", 2.0, "a pmv/attitude axis not measured for this long is "
                  "stale: the loop keeps holding its last value and /diagnostics warns", 0.01, 3600.0, unit="s"),
        ParamSpec("body.inertia_kg_m2", list(DEFAULT_INERTIA_KG_M2), "principal moments of inertia about the "
                  "body X, Y, Z axes (three values; each at most the sum of the other two)", 0.001, 1e9,
                  unit="kg m2", max_length=3, read_only=True),
        ParamSpec("body.initial_attitude_arcmin", [0.0, 0.0, 0.0], "roll, pitch, yaw of the body at the start "
                  "(at rest in the orbital frame)", -2700.0, 2700.0, unit="arcmin", max_length=3, read_only=True),
        ParamSpec("disturbance.constant_torque_nm", [0.0, 0.0, 0.0], "constant disturbance torque about the body "
                  "X, Y, Z axes", -10.0, 10.0, unit="N m", max_length=3),
        ParamSpec("disturbance.orbital_torque_nm", [0.0, 0.0, 0.0], "amplitude of a disturbance torque at the "
                  "orbital frequency about the body X, Y, Z axes, a sin(n t) from the start", -10.0, 10.0,
                  unit="N m", max_length=3),
        ParamSpec("disturbance.gravity_gradient", True, "the gravity-gradient torque 3 n^2 (z x J z) acts on the body"),
        ParamSpec("future_tolerance_s", 1.0, "pmv/attitude stamps later than the node clock by more than this are "
                  "rejected", 0.001, 3600.0, unit="s"),
        ParamSpec("clock_jump_s", 1.0, "a node clock or a pmv/attitude stamp going back by more than this starts a "
                  "new timeline (the plant keeps its state)", 0.001, 3600.0, unit="s"),
        ParamSpec("diagnostics_period_s", 1.0, "period of /diagnostics health reports (plant time)", 0.1, 3600.0,
                  unit="s"),
    )
