"""What the node runtimes share: parameter specs and presets (:mod:`.parameters`, :mod:`.assembly`),
input checks (:mod:`.validation`), which publisher an input listens to (:mod:`.source_lock`), refused requests
counted and said (:mod:`.refusals`) and where a node's inputs come from (:mod:`.input_sources`), frames and the
mounting (:mod:`.frames`), health records (:mod:`.records`), the clock watch (:mod:`.clock_watch`), and the truth
and orbit buffers (:mod:`.truth_buffer`, :mod:`.orbit_buffer`).

Nothing here imports a node's runtime package.
"""
