"""`ros2 launch uav_insar_planner ground.launch.py`: the ground station: the planner and the
recorder.

Its arguments: `ros2 launch uav_insar_planner ground.launch.py --show-args`, or the documentation's
launch page (docs/ros/launch.md). The logic is in uav_insar_planner/ros/launch_files.py, tested
with the package; this file only hands launch its own path.
"""
from launch import LaunchDescription

from uav_insar_planner.ros.launch_files import launch_description


def generate_launch_description() -> LaunchDescription:
    return launch_description(__file__)
