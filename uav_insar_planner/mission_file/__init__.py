"""Mission files for autopilots that fly without a companion computer (no ROS, no MAVLink link).

- `geodesy`: track-frame offsets about a home <-> latitude, longitude (local tangent plane).
- `qgc_plan`: one QGroundControl `.plan` per UAV: take off, go to the pass start, wait for a
  common UTC time (MAV_CMD_NAV_DELAY), fly the pass at v_y, hold or return.

`uav-insar export-mission` (cli/export_mission.py) writes them.
"""
