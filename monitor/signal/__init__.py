"""Signal processing of recordings: pulses, angle maps, angle-domain resampling, order spectra.

- :mod:`monitor.signal.pulses`: edges with hysteresis and sub-sample timing; keyphasor repair.
- :mod:`monitor.signal.toothwheel`: tooth-wheel decoding (gap detection, tooth angles, spacing errors).
"""
