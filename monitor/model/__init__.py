"""The engine model: its description, the exact slider-crank kinematics, gas and inertia forces, the
crankshaft's bearing loads and torque, the order table the physics predicts at an operating point, the
engine's inertias about the crankshaft and the torque orders that excite its shaft line (the torsion
models build on these; the model never imports them)."""
