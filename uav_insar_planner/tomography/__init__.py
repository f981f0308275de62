"""Tomographic SAR with the swarm (no ROS, no MAVLink): the elevation array factor and its
figures (array_factor.py), a plan's figures (plan_figures.py), and the tomographic objective
(design.py: the layouts, the certified relaxation; realize.py: its formation)."""
