"""The track model, free of ROS and MAVLink: where the formation flies and when.

- `frame`: the track frame `insar_track` (x across track, y along track, z up) <-> local NED.
- `speed_profile`: the along-track speed of a pass: the ramp up from a hover, the cruise at
  v_y, the braking at its end.
- `pass_clock`: `PassClock`, one pass's clock (its start instant, offset, speed and ramp),
  shared by the planner, the bridges and the agents; the same-start rule.
- `trajectory`: `PassTrajectory`, the formation on one pass clock: each UAV's target.
- `formation`: a formation's poses cleaned, and the planned separations checked.
- `capture`: whether a UAV is captured at its start point (the pass may start).
- `catch_up`: the gentle catch-up of a UAV that rejoins a running pass.
- `cross_track`: the setpoint moved against the autopilot's own across-track and height error.
- `passes`: the ordered passes of a mission and the transits between them.

`mavlink/` (the bridge), `ros/` (the planner's pass start), `mission_file/` and the agents in
`uav_insar_sim` use it; it imports none of them.
"""
