"""MAVLink side of the planner, free of ROS, one concern per module:

- `frames`: track frame <-> local NED.
- `link`: one transport per endpoint with counted, tolerant parsing.
- `guard`: values representable going out, finite coming in; counted, rate-limited drops.
- `signing`: MAVLink 2 message signing with the key from a file.
- `autopilots`: ArduPilot / PX4 names and mode numbers.
- `config`: `BridgeConfig` and its validation.
- `trajectory`: the pass each UAV flies and when it starts.
- `setpoints`: SET_POSITION_TARGET_LOCAL_NED and its type masks.
- `supervision`: heartbeats, lost and found vehicles, positions read back.
- `report`: the bridge's events and per-UAV snapshots.
- `sequencer`: the optional arm-and-take-off sequence with ACK retries.
- `bridge`: the I/O loop that ties them together (`Bridge`).
- `mission_start`: MAV_CMD_MISSION_START to every vehicle at one instant (`uav-insar
  start-missions`: PX4's common start of the mission files).

The ROS node `uav_insar_planner.ros.mavlink_bridge` is a thin adapter over `bridge.Bridge`.
"""
