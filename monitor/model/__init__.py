"""The engine model: its description, the exact slider-crank kinematics, gas and inertia forces, the
crankshaft's bearing loads and torque, and the order table the physics predicts at an operating point."""
