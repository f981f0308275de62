"""Survey an area with the swarm: the speed to fly it at (speed.py)."""
