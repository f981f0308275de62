"""Mission files for autopilots that fly without a companion computer (no ROS, no MAVLink link).

- `geodesy`: track-frame offsets about a home <-> latitude, longitude (local tangent plane).
- `qgc_plan`: one QGroundControl `.plan` per UAV: take off, go to the pass start, wait for a
  common UTC time (ArduPilot: MAV_CMD_NAV_DELAY) or for MISSION_START (PX4), fly the pass at
  v_y, hold or return; heights AMSL or above each UAV's home.
- `folder`: the export folder: what is in the way, the files written all or nothing, stale
  plans of UAVs not flown removed.

`uav-insar export-mission` (cli/export_mission.py) writes them; `uav-insar start-missions`
(cli/start_missions.py) starts PX4's.
"""
