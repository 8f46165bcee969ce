"""The measured camera as the wavefront-sensor detector of AO simulators.

Each adapter lives in its own module and imports its simulator only when imported itself:
``detnoise.ao.hcipy`` (HCIPy), ``detnoise.ao.oopao`` (OOPAO), ``detnoise.ao.specula``
(SPECULA). Every adapter reads its frames through a `detnoise.Readout`: any readout model of
the registry, a camera model folder (`Readout.from_camera`) or a per-pixel noise map.
"""
