"""The measured camera as the wavefront-sensor detector of AO simulators.

Each adapter lives in its own module and imports its simulator only when imported itself.
Every adapter reads its frames through a `detnoise.Readout`: any readout model of the
registry, a camera model folder (`Readout.from_camera`) or a per-pixel noise map.

- ``detnoise.ao.hcipy.DetnoiseDetector``: a ``hcipy.Detector`` (docs/ao-hcipy.md).
- ``detnoise.ao.oopao``: ``DetnoiseDetector`` (OOPAO's ``Detector`` subclass),
  ``attach(wfs, camera)``, ``reference_slopes(wfs, frames)`` (docs/ao-oopao.md).
- ``detnoise.ao.specula.DetnoiseCCD``: SPECULA's ``CCD`` whose noise step is one read of a
  Readout; in a parameter file ``add_modules: ['detnoise.ao.specula']`` and
  ``class: 'DetnoiseCCD'`` (docs/ao-specula.md).
"""
