"""MAVLink side of the planner, free of ROS, one concern per module (what differs per
autopilot flavour is `uav_insar_planner.autopilots.profiles`; the track frame, the pass and
its clock are `uav_insar_planner.track`):

- `link`: one transport per endpoint with counted, tolerant parsing.
- `guard`: values representable going out, finite coming in; counted, rate-limited drops.
- `signing`: MAVLink 2 message signing with the key from a file.
- `config`: `BridgeConfig` and its validation.
- `setpoints`: SET_POSITION_TARGET_LOCAL_NED and its type masks.
- `supervision`: heartbeats, lost and found vehicles, positions read back.
- `report`: the bridge's events and per-UAV snapshots.
- `sequencer`: the optional arm-and-take-off sequence with ACK retries.
- `mode_orders`: DO_SET_MODE into the hold mode or back into the flight mode, resent until
  the heartbeat shows it.
- `holds`: who holds and why (the planner's mission stop, the ground station's silence), and
  how a held UAV rejoins; `hold_states`: its states and transitions as plain values.
- `start_gate`: when the pass starts (capture gate or the planner's instant), where it resumes.
- `flight_state`: the formation and hold state the bridge serves (`FlightState`).
- `io_thread`: one I/O loop in a daemon thread (`IoThread`: the bridge's, the simulated
  vehicle's).
- `bridge`: the I/O loop that ties them together (`Bridge`).
- `mission_start`: MAV_CMD_MISSION_START to every vehicle at one instant (`uav-insar
  start-missions`: PX4's common start of the mission files).

The ROS node `uav_insar_planner.ros.mavlink_bridge` is a thin adapter over `bridge.Bridge`.
"""
