"""Published reference numbers, transcribed once (physics.md): the targets of the calibration tools and
what the tests reproduce."""

#: physics.md §2.1 — oblateness error, Kondor (sensor 8201-V4), H = 500 km, i = 74.5°, a quarter orbit;
#: rows (u_deg, meridional′, pitch′, roll′), signs as published (the paper convention: compare with the
#: REP-103 core through pmv_ros.physics.conventions.convert).
KONDOR_OBLATENESS_TABLE = [
    (0, 0.0, 0.0, 0.0),
    (15, 4.7, 4.6, -1.3),
    (30, 8.3, 7.9, -2.4),
    (45, 9.7, 9.1, -3.4),
    (60, 8.9, 7.9, -4.2),
    (75, 6.9, 4.5, -4.7),
    (90, 4.9, 0.0, -4.9),
]
KONDOR_ALTITUDE_KM, KONDOR_INCLINATION_DEG = 500.0, 74.5

#: physics.md §4 — Model A at 500 km (the table that fixes T_p and the profile shape);
#: rows (B(1), B(2) in r.u.; β uncorrected, β′ corrected in arcmin).
MODEL_A_TABLE = [
    (1.0, 2.0, 22.7, 0.1),
    (1.0, 3.0, 32.0, 0.14),
    (1.0, 4.0, 37.4, 0.8),
    (2.0, 4.0, 14.7, 0.66),
]
