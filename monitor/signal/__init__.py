"""Signal processing of recordings: pulses, angle maps, angle-domain resampling, order spectra.

- :mod:`monitor.signal.pulses`: edges with hysteresis and sub-sample timing (mid level or VR zero
  crossing); keyphasor pulses among glitches, and their repair.
- :mod:`monitor.signal.toothwheel`: tooth-wheel and encoder decoding (gap detection, tooth angles,
  sensor kind and polarity).
- :mod:`monitor.signal.pitch`: a wheel's own pitch errors, estimated and corrected.
- :mod:`monitor.signal.anglemap`: crank angle against time; the four-stroke cycle phase.
- :mod:`monitor.signal.tdc`: top dead centre from cylinder pressure.
- :mod:`monitor.signal.angle_domain`: resampling to the crank angle; order spectra.
"""
