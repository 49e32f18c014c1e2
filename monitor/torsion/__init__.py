"""Torsional dynamics of the crank train and shaft line.

- :mod:`monitor.torsion.shaft_line`: the lumped shaft line: modes, forced
  response, Campbell data, the receptance at the tooth wheel.
- :mod:`monitor.torsion.axial_coupling`: the coupled torsional-axial crankshaft (paper 001).
- :mod:`monitor.torsion.variable_inertia`: one crank with reciprocating parts
  whose inertia varies twice per revolution (paper 002): its equations and excitation;
  :mod:`monitor.torsion.floquet` (monodromy), :mod:`monitor.torsion.stability`
  (instability ranges, stability chart) and :mod:`monitor.torsion.time_response`
  (time simulation, harmonic content) analyse it.

The excitation (the cylinders' torque orders) and the engine's inertias come from the model
(:mod:`monitor.model.excitation`, :mod:`monitor.model.inertia`); the model never imports torsion.
"""
