"""Survey an area: strips, sorties and speed (no ROS, no MAVLink)."""
