"""ament_python package; also installable with `pip install -e .` (see README)."""
from glob import glob

from setuptools import find_packages, setup

package_name = "uav_insar_planner"
# The Foxglove layout for the default swarm (report/foxglove_layout.py writes it): beside its
# module for pip users, and in share/ for colcon's.
FOXGLOVE_LAYOUT = "report/foxglove_layout.json"
# The planner and the uav-insar tools, beyond what the UAV's nodes need (install_requires).
PLANNER = [
    # the solvers: scipy for `global` and `evolution`, CVXPY + Clarabel for `paper-ao`
    "scipy>=1.10",
    "cvxpy>=1.4",
    "clarabel>=0.6",
    # the figures and the progress bars of uav-insar
    "matplotlib>=3.6",
    "tqdm>=4.60",
    # uav-insar record writes and uav-insar report reads rosbag2 bags with it; the report
    # runs without ROS, so this is no `ros` wheel (pure Python, no ROS packages pulled).
    "rosbags>=0.11",
    # uav-insar record writes the bag's MCAP file with it (bag/writer.py): rosbags' writer
    # cannot write what rosbag2 Jazzy writes (topic_type_hash, header, metadata records)
    "mcap>=1.1",
    # `--jobs 1` of sweep / map pins this process's BLAS / OpenMP threads to one, as the
    # workers' are, so that serial and parallel runs agree float for float (study/executors.py)
    "threadpoolctl>=3.1",
]
ROS_WHEELS = [
    "ros-jazzy-rclpy[fastrtps]>=7.1",
    "ros-jazzy-common-interfaces>=5.3",
    "ros-jazzy-std-srvs>=5.3",
    "ros-jazzy-rcl-interfaces>=2.0",
]

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test", "benchmarks"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
        ("share/" + package_name + "/config", glob("config/*.yaml")),
        # `ros2 launch uav_insar_planner FILE` finds them here through the ament index (the
        # marker above), on the colcon path and the pip path alike (docs/ros/launch.md)
        ("share/" + package_name + "/launch", glob("launch/*.launch.py")),
        ("share/" + package_name + "/foxglove", [package_name + "/" + FOXGLOVE_LAYOUT]),
    ],
    package_data={package_name: [FOXGLOVE_LAYOUT]},
    python_requires=">=3.10",
    # What the UAV's nodes (agent, mavlink_bridge) import, and no more: a companion computer
    # installs this (docs/hardware.md); pyserial for the autopilot on a serial port.
    install_requires=["numpy>=1.24", "pyyaml>=6", "pymavlink>=2.4.40", "pyserial>=3.5"],
    extras_require={
        # The planner node and the uav-insar tools: extras.py PLANNER_MODULES names them
        # all, for the one line a lean install gives instead of a traceback.
        "planner": PLANNER,
        # ROS 2 Jazzy from PyPI wheels (x86_64 Linux, CPython 3.10-3.13), with the planner's
        # libraries: the whole node suite. Not for a sourced Jazzy: colcon installs no
        # extras, so that rclpy stays the only one (see README).
        "ros": ROS_WHEELS + PLANNER,
        # One UAV's companion computer: agent and mavlink_bridge on the ROS wheels, without
        # the solver, plotting and bag libraries (docs/hardware.md).
        "uav": ROS_WHEELS,
        "test": PLANNER + [
            "pytest>=7", "pytest-timeout>=2", "ruff>=0.4", "mavsdk==3.17.4", "hypothesis>=6",
            # `make test` runs the suite on two workers (Makefile's TEST_WORKERS)
            "pytest-xdist>=3.5,<4",
            # independent reader of the recorded bags (test/test_bag_record.py)
            "mcap-ros2-support>=0.5",
            # `--scheduler` of sweep / map on a local Dask cluster (test/test_param_map.py)
            "dask[distributed]>=2024.1"],
        # `uav-insar sweep/map --scheduler ADDRESS`: the solves on a Dask cluster's workers
        "cluster": ["dask[distributed]>=2024.1"],
        # the documentation site (mkdocs.yml); its strict build is part of the tests
        "docs": ["mkdocs>=1.6,<2", "mkdocs-material>=9.5,<10"],
    },
    zip_safe=True,
    maintainer="uav_insar_planner developers",
    maintainer_email="dev@example.invalid",
    description="Plan and fly a multi-baseline InSAR swarm of 2 to 10 UAVs (ROS 2 Jazzy nodes)",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "planner = uav_insar_planner.ros.planner:main",
            "agent = uav_insar_sim.agent_node:main",
            "mavlink_bridge = uav_insar_planner.ros.mavlink_bridge:main",
            "uav-insar = uav_insar_planner.cli:main",
            "uav-insar-vehicle = uav_insar_sim.vehicle.cli:main",
        ],
    },
)
