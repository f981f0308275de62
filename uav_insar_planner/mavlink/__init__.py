"""MAVLink side of the planner, free of ROS: track-frame <-> NED conversion (`frames`), one
transport per endpoint with counted, tolerant parsing (`link`), and the swarm bridge that
streams setpoints and watches the vehicles (`bridge`). The ROS node
`uav_insar_planner.ros.mavlink_bridge` is a thin adapter over `bridge.Bridge`."""
