"""`uav-insar echo` on real rclpy against real publisher processes; msg_yaml's exact text."""
from __future__ import annotations

import array
import math
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest
import yaml
from process_group import kill_group

from uav_insar_planner.ros.tools.msg_yaml import message_to_yaml

REPO = Path(__file__).resolve().parent.parent
TALKER = str(Path(__file__).resolve().parent / "echo_talker.py")
ECHO = ("-m", "uav_insar_planner.cli", "echo")


class Child:
    """A Python child process on the test's domain; stdout collected by a reader thread."""

    def __init__(self, args: tuple[str, ...], pythonpath: str) -> None:
        env = dict(os.environ, PYTHONPATH=pythonpath, PYTHONUNBUFFERED="1")
        self.proc = subprocess.Popen([sys.executable, *args], env=env, cwd=REPO, text=True,
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                     start_new_session=True)
        self.out = self.err = ""
        self._changed = threading.Condition()
        self._readers = [threading.Thread(target=self._read, args=(name,), daemon=True)
                         for name in ("out", "err")]
        for reader in self._readers:
            reader.start()

    def _read(self, name: str) -> None:
        for line in getattr(self.proc, f"std{name}"):
            with self._changed:
                setattr(self, name, getattr(self, name) + line)
                self._changed.notify_all()

    def wait_for(self, text: str, timeout: float = 30) -> None:
        """Wait until stdout contains `text`."""
        with self._changed:
            if not self._changed.wait_for(lambda: text in self.out, timeout):
                raise AssertionError(f"no {text!r} on stdout within {timeout} s: {self.out!r}")

    def finish(self, timeout: float = 40) -> tuple[int, str, str]:
        """Wait for the exit; (exit code, stdout, stderr)."""
        self.proc.wait(timeout)
        for reader in self._readers:
            reader.join(10)
        return self.proc.returncode, self.out, self.err

    def close(self) -> None:
        """Kill its process group, and release its pipes."""
        kill_group(self.proc)
        self.finish(10)
        self.proc.stdout.close()
        self.proc.stderr.close()


@pytest.fixture
def spawn(ros_domain: int) -> Iterator[Callable[..., Child]]:
    """spawn(*python_args, pythonpath=REPO) starts a child; all are killed after the test."""
    kids: list[Child] = []

    def start(*args: str, pythonpath: str = str(REPO)) -> Child:
        kids.append(Child(args, pythonpath))
        return kids[-1]

    yield start
    for kid in kids:
        kid.close()


def talker(spawn: Callable[..., Child], *args: str) -> Child:
    child = spawn(TALKER, *args)
    child.wait_for("published\n")
    return child


def test_late_echo_gets_latched_formation(spawn: Callable[..., Child]) -> None:
    from echo_talker import formation

    talker(spawn, "formation")  # published once, before the echo exists
    code, out, err = spawn("-m", "uav_insar_planner.cli", "echo", "formation", "--once",
                           "--timeout", "30").finish()
    assert (code, err) == (0, "")
    text, sep, rest = out.partition("---\n")
    assert sep and rest == ""
    doc = yaml.safe_load(text)
    assert doc["header"] == {"stamp": {"sec": 12, "nanosec": 345}, "frame_id": "insar_track"}
    assert [p["position"] for p in doc["poses"]] == [
        {"x": x, "y": -5.5, "z": 120.25} for x in (0.0, 10.0, 20.0)]
    assert all(p["orientation"] == {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}
               for p in doc["poses"])
    assert text == message_to_yaml(formation())


@pytest.mark.parametrize("mode", ["chatter", "sensor"])  # reliable / best-effort publisher
def test_volatile_stream_count_two(spawn: Callable[..., Child], mode: str) -> None:
    talker(spawn, mode)
    code, out, err = spawn(*ECHO, "/chatter", "--count", "2", "--timeout", "30").finish()
    assert (code, err) == (0, "")
    docs = out.split("---\n")
    assert len(docs) == 3 and docs[2] == ""
    numbers = [int(yaml.safe_load(d)["data"].removeprefix("hello ")) for d in docs[:2]]
    assert numbers[1] == numbers[0] + 1 if mode == "chatter" else numbers[1] > numbers[0]


def test_ros_args_namespace_resolves_relative_name(spawn: Callable[..., Child]) -> None:
    talker(spawn, "chatter", "/uav1/chatter")
    code, out, err = spawn(*ECHO, "chatter", "--once", "--timeout", "30",
                           "--ros-args", "-r", "__ns:=/uav1").finish()
    assert (code, err) == (0, "")
    assert out.startswith("data: hello ") and out.endswith("\n---\n") and out.count("---") == 1


def test_timeout_after_messages_exits_zero(spawn: Callable[..., Child]) -> None:
    talker(spawn, "chatter")
    echo = spawn(*ECHO, "/chatter", "--timeout", "5")
    echo.wait_for("---\n")
    code, out, err = echo.finish()
    assert (code, err) == (0, "")
    assert out.count("---\n") > 1 and out.endswith("---\n")


def test_unknown_topic_times_out(spawn: Callable[..., Child]) -> None:
    start = time.monotonic()
    code, out, err = spawn(*ECHO, "no_such_topic", "--timeout", "0.5").finish()
    assert (code, out) == (1, "")
    assert err == "uav-insar echo: error: no publisher on /no_such_topic within 0.5 s\n"
    assert time.monotonic() - start < 15


def test_publisher_without_message_times_out(spawn: Callable[..., Child]) -> None:
    talker(spawn, "silent", "/silent")
    code, out, err = spawn(*ECHO, "/silent", "--timeout", "6").finish()
    assert (code, out) == (1, "")
    assert err == "uav-insar echo: error: no message on /silent within 6 s\n"


@pytest.mark.parametrize("args, says", [
    (["bad name!"], "Invalid topic name: topic name must not contain characters"),
    (["1abc"], "Invalid topic name: topic name token must not start with a number"),
    (["/a//b"], "must not contain repeated '/'"),
    (["x", "--count", "0"], "argument --count: expected a positive whole number, got '0'"),
    (["x", "--count", "-1"], "argument --count: expected a positive whole number, got '-1'"),
    (["x", "--count=-1"], "argument --count: expected a positive whole number, got '-1'"),
    (["x", "--count", "9" * 4000], "argument --count: expected a positive whole number, got "
     "'99999"),
    (["x", "--timeout", "soon"], "argument --timeout: expected a positive, finite number"),
    (["x", "--timeout", "inf"], "argument --timeout: expected a positive, finite number"),
    (["x", "--timeout", "nan"], "argument --timeout: expected a positive, finite number"),
    (["/" + "x" * 100_000], "argument 1 ('/xxxxxxxx"),  # rcl would log all of it
    (["x", "--ros-args", "-r", "__ns:=/" + "x" * 100_000 + "-"], "argument 4 ('__ns:=/xxx"),
    (["x", "--" + "x" * 100_000], "characters long; expected at most 4096"),
    (["/x\udcff"], "argument 1 ('/x\\udcff') is not UTF-8 text"),  # bytes 0xff from a shell
    (["x", "--once", "--count", "2"], "not allowed with argument --once"),
    (["x", "--bogus"], "unrecognized arguments: --bogus"),
    (["x", "--ros-args", "--bogus"], "bad ROS arguments"),
])
def test_bad_usage_exits_two(spawn: Callable[..., Child], args: list[str], says: str) -> None:
    code, out, err = spawn(*ECHO, *args).finish()
    assert (code, out) == (2, "")
    assert err.startswith("uav-insar echo: error: ") and err.count("\n") == 1 and says in err
    assert len(err) < 400, f"{len(err)} characters: what was given must be cut short"


def test_second_signal_during_clean_up_is_ignored(spawn: Callable[..., Child],
                                                  graph: object) -> None:
    """SIGTERM, then SIGTERM again while the echo shuts rclpy down: still exit 0, silently
    (the second once killed it with 143 after the handlers were restored)."""
    echo = spawn(*ECHO, "/nothing")
    end = time.monotonic() + 30
    while f"_uav_insar_echo_{echo.proc.pid}" not in graph.get_node_names():
        assert time.monotonic() < end and echo.proc.poll() is None, "echo node never seen"
        time.sleep(0.05)
    echo.proc.send_signal(signal.SIGTERM)
    for _ in range(10):
        time.sleep(0.01)
        if echo.proc.poll() is not None:
            break
        echo.proc.send_signal(signal.SIGTERM)
    code, out, err = echo.finish(timeout=15)
    assert (code, out, err) == (0, "", "")


def test_type_that_cannot_be_imported(spawn: Callable[..., Child], tmp_path: Path) -> None:
    (tmp_path / "diagnostic_msgs").mkdir()  # an empty package shadows the real one
    (tmp_path / "diagnostic_msgs" / "__init__.py").write_text("")
    talker(spawn, "diagnostics")
    code, out, err = spawn(*ECHO, "/diagnostics", "--timeout", "30",
                           pythonpath=f"{tmp_path}{os.pathsep}{REPO}").finish()
    assert (code, out) == (1, "")
    assert err.startswith("uav-insar echo: error: cannot import message type "
                          "diagnostic_msgs/msg/DiagnosticArray of /diagnostics: ")
    assert err.count("\n") == 1


@pytest.fixture
def graph(ros_domain: int) -> Iterator[object]:
    """An rclpy node of this process on the test's domain, to watch the ROS graph."""
    import rclpy

    context = rclpy.Context()
    rclpy.init(args=["test_echo"], context=context, domain_id=ros_domain)
    node = rclpy.create_node("test_echo_watcher", context=context,
                             start_parameter_services=False, enable_rosout=False)
    yield node
    node.destroy_node()
    context.try_shutdown()


@pytest.mark.parametrize("phase", ["waiting", "streaming"])
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_signal_exits_cleanly(spawn: Callable[..., Child], graph: object,
                              sig: signal.Signals, phase: str) -> None:
    if phase == "streaming":
        talker(spawn, "chatter")
    echo = spawn(*ECHO, "/chatter")
    if phase == "streaming":
        echo.wait_for("---\n")
    else:  # its node exists: the signal handlers are in place, it waits for a publisher
        end = time.monotonic() + 30
        while f"_uav_insar_echo_{echo.proc.pid}" not in graph.get_node_names():
            assert time.monotonic() < end and echo.proc.poll() is None, "echo node never seen"
            time.sleep(0.05)
    echo.proc.send_signal(sig)
    code, out, err = echo.finish(timeout=15)
    assert (code, err) == (0, "")
    assert out.endswith("---\n") if phase == "streaming" else out == ""


# message_to_yaml: the exact text of ros2 topic echo (rosidl_runtime_py.convert.message_to_yaml)


def test_yaml_multiarray_layout_and_data() -> None:
    from std_msgs.msg import Float64MultiArray, MultiArrayDimension

    msg = Float64MultiArray(data=[1.0, -2.5, 0.0, 1e-05, 3e20])
    msg.layout.dim = [MultiArrayDimension(label="uav", size=2, stride=6),
                      MultiArrayDimension(label="axis", size=3, stride=3)]
    msg.layout.data_offset = 1
    assert isinstance(msg.data, array.array)
    assert message_to_yaml(msg) == (
        "layout:\n"
        "  dim:\n"
        "  - label: uav\n"
        "    size: 2\n"
        "    stride: 6\n"
        "  - label: axis\n"
        "    size: 3\n"
        "    stride: 3\n"
        "  data_offset: 1\n"
        "data:\n"
        "- 1.0\n"
        "- -2.5\n"
        "- 0.0\n"
        "- 1.0e-05\n"
        "- 3.0e+20\n")


def test_yaml_diagnostics_with_key_values() -> None:
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

    msg = DiagnosticArray()
    msg.header.stamp.sec = 7
    msg.header.frame_id = "uav1"
    msg.status = [DiagnosticStatus(level=DiagnosticStatus.WARN, name="link: uav1",
                                   message="weak", hardware_id="",
                                   values=[KeyValue(key="snr_db", value="3.5"),
                                           KeyValue(key="ok", value="true")])]
    assert message_to_yaml(msg) == (
        "header:\n"
        "  stamp:\n"
        "    sec: 7\n"
        "    nanosec: 0\n"
        "  frame_id: uav1\n"
        "status:\n"
        '- level: "\\x01"\n'  # a byte field prints as the string of its character
        "  name: 'link: uav1'\n"
        "  message: weak\n"
        "  hardware_id: ''\n"
        "  values:\n"
        "  - key: snr_db\n"
        "    value: '3.5'\n"
        "  - key: ok\n"
        "    value: 'true'\n")


def test_yaml_special_floats_and_zero() -> None:
    from geometry_msgs.msg import Vector3
    from std_msgs.msg import Float64

    assert message_to_yaml(Float64(data=math.nan)) == "data: .nan\n"
    assert message_to_yaml(Vector3(x=math.inf, y=-math.inf)) == "x: .inf\ny: -.inf\nz: 0.0\n"
    assert yaml.safe_load(message_to_yaml(Float64(data=math.nan)))["data"] != 0.0


def test_yaml_octets_numpy_and_uint8_arrays() -> None:
    from geometry_msgs.msg import PoseWithCovariance
    from std_msgs.msg import ByteMultiArray, Empty, UInt8MultiArray

    octets = ByteMultiArray(data=[b"a", b"\x00"])
    assert message_to_yaml(octets).endswith('data:\n- a\n- "\\0"\n')
    uint8 = UInt8MultiArray(data=[0, 255])
    assert message_to_yaml(uint8).endswith("data:\n- 0\n- 255\n")
    pose = PoseWithCovariance(covariance=np.arange(36.0))
    assert isinstance(pose.covariance, np.ndarray)
    assert message_to_yaml(pose).endswith(
        "covariance:\n" + "".join(f"- {i}.0\n" for i in range(36)))
    assert message_to_yaml(Empty()) == "{}\n"


def test_yaml_truncates_like_ros2_topic_echo() -> None:
    from sensor_msgs.msg import JointState
    from std_msgs.msg import String

    assert message_to_yaml(String(data="x" * 129)) == f"data: {'x' * 128}...\n"
    assert message_to_yaml(String(data="x" * 128)) == f"data: {'x' * 128}\n"
    assert message_to_yaml(String(data="x" * 129), truncate_length=None) == f"data: {'x' * 129}\n"
    joints = JointState(position=[float(i) for i in range(130)])
    assert "- 127.0\n- '...'\nvelocity: []\n" in message_to_yaml(joints)
    assert "- 129.0\nvelocity: []\n" in message_to_yaml(joints, truncate_length=None)
