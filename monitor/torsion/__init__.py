"""Torsional dynamics of the crank train and shaft line.

- :mod:`monitor.torsion.variable_inertia`: one crank with reciprocating parts
  whose inertia varies twice per revolution (paper 002): equations of motion,
  time simulation, Floquet stability, harmonic content.
"""
