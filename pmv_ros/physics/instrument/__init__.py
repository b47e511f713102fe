"""The instrument: the 4-chord sensor model (:mod:`.sensor`) — what does not depend on the attitude on fixed grids
(the orbit and the Sun and Moon along the track, :mod:`.track`; the environment's fields along the horizon,
:mod:`.horizon_fields`) and each sample's compiled pass (:mod:`.sensing`) —, the stored brightness correction
(:mod:`.correction`), the oblateness error from ray geometry and its closed form (:mod:`.oblateness`),
the Sun and the Moon in a chord (:mod:`.bright_body`), and the laboratory radiance scenarios A–D
(:mod:`.scenarios`). Built on :mod:`pmv_ros.physics.chain` (the signal chain),
:mod:`pmv_ros.physics.environment` (the radiance environment) and :mod:`pmv_ros.physics.orbit`."""
