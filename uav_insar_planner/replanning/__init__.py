"""Re-planning in mid-mission, no ROS: what calls for a re-plan (`triggers`: lost UAVs,
saturated closed loops, on a clock the caller passes) and the re-plans themselves (`plans`)."""
