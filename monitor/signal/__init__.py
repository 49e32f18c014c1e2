"""Signal processing of recordings: pulses, angle maps, angle-domain resampling, order spectra.

- :mod:`monitor.signal.pulses`: edges with hysteresis and sub-sample timing (mid level or VR zero
  crossing); keyphasor pulses among glitches, and their repair.
- :mod:`monitor.signal.toothwheel`: tooth-wheel and encoder decoding (gap detection, tooth angles,
  sensor kind and polarity).
- :mod:`monitor.signal.pitch`: a wheel's own pitch errors, estimated and corrected.
- :mod:`monitor.signal.anglemap`: crank angle against time; the four-stroke cycle phase.
- :mod:`monitor.signal.tdc`: top dead centre from cylinder pressure.
- :mod:`monitor.signal.grid`: the crank-angle grid and the resampled channel.
- :mod:`monitor.signal.kernels`: the kernels that evaluate a channel at the grid's times.
- :mod:`monitor.signal.resample`: resampling a channel to the crank angle, block by block.
- :mod:`monitor.signal.impact`: the high-frequency (impact) power over the cycle.
- :mod:`monitor.signal.spectrum`: order spectra of angle-domain signals.
- :mod:`monitor.signal.crank_speed`: order spectra of the crank's speed.
- :mod:`monitor.signal.reference`: the angle reference of a recording; tooth-pitch errors learned.
- :mod:`monitor.signal.measure`: one recording to its spectra.
"""
