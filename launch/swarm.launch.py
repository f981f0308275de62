"""`ros2 launch uav_insar_planner swarm.launch.py`: the planner, N agents, the all-in-one
bridge and, with vehicles:=true, N simulated vehicles.

Its arguments: `ros2 launch uav_insar_planner swarm.launch.py --show-args`, or the documentation's
launch page (docs/ros/launch.md). The logic is in uav_insar_planner/ros/launch_files.py, tested
with the package; this file only hands launch its own path.
"""
from launch import LaunchDescription

from uav_insar_planner.ros.launch_files import launch_description


def generate_launch_description() -> LaunchDescription:
    return launch_description(__file__)
