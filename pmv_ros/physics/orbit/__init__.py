"""Where the spacecraft is and when: the circular and Keplerian orbits and the orbital frame
(:mod:`.two_body`), SGP4 from a two-line element set (:mod:`.tle`), and time scales, the sidereal
angle and the Sun's and the Moon's directions (:mod:`.ephemeris`)."""
