"""The simulator's physics, shared by the self-flown agent and the MAVLink vehicle (vehicle/):
the point-mass integrator (`kinematics`) and the slowly wandering disturbance (`gauss_markov`)."""
