"""`uav-insar record` on a short real mission (three agent processes and the planner on a
private domain, the recorder a process of its own), read back with two readers that share no
code with ours: `mcap` + `mcap-ros2-support`'s decoder, and `rosbags`."""
from __future__ import annotations

import math
import sys
from collections import Counter
from pathlib import Path

import process_group
import pytest
import yaml
from conftest import MISSION_SLOTS as SLOTS
from conftest import REPO

# the `mission` fixture (conftest.py) records the mission these tests read
pytestmark = pytest.mark.timeout(120)
UAV_TOPICS = ("pose", "achieved_rate", "offload")
EXPECTED = ({"/formation", "/formation/power", "/formation/markers", "/formation/markers/flown",
             "/diagnostics"} | {f"/uav{k}/{t}" for k in range(3) for t in UAV_TOPICS})
LATCHED = {"/formation", "/formation/power", "/formation/markers"}


def _mcap_file(bag: Path) -> Path:
    meta = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    (name,) = meta["relative_file_paths"]
    return bag / name


def _positions(poses) -> list[tuple[float, float, float]]:
    return [(p.position.x, p.position.y, p.position.z) for p in poses]


def test_the_recorder_closes_the_bag_and_says_so(mission):
    assert mission.code == 0
    assert mission.line.startswith("recorded ") and str(mission.bag) in mission.line


def test_metadata_is_rosbag2_v9_mcap_with_every_topic_and_latched_qos(mission):
    meta = yaml.safe_load((mission.bag / "metadata.yaml").read_text())
    info = meta["rosbag2_bagfile_information"]
    assert info["version"] == 9 and info["storage_identifier"] == "mcap"
    topics = {t["topic_metadata"]["name"]: t for t in info["topics_with_message_count"]}
    assert EXPECTED <= set(topics), sorted(set(topics))
    assert info["message_count"] == sum(t["message_count"] for t in topics.values())
    for name in EXPECTED:
        (offered,) = topics[name]["topic_metadata"]["offered_qos_profiles"]
        assert offered["durability"] == ("transient_local" if name in LATCHED else "volatile")
        assert offered["reliability"] == "reliable"
        assert topics[name]["topic_metadata"]["type_description_hash"].startswith("RIHS01_")
    for k in range(3):
        assert topics[f"/uav{k}/achieved_rate"]["message_count"] == SLOTS


def test_every_topic_of_the_bag_is_on_the_generated_list_of_recording_md(mission):
    """docs/recording.md's list (docs/_hooks/reference_topics.recorded_names) holds every
    topic the recorder took; this mission has no bridge, whose topics the list has too."""
    sys.path.insert(0, str(REPO / "docs" / "_hooks"))
    import reference_topics

    meta = yaml.safe_load((mission.bag / "metadata.yaml").read_text())
    recorded = {t["topic_metadata"]["name"]
                for t in meta["rosbag2_bagfile_information"]["topics_with_message_count"]}
    listed = set(reference_topics.recorded_names())
    assert EXPECTED <= recorded <= listed, sorted(recorded - listed)


def test_mcap_and_its_ros2_decoder_read_every_message(mission):
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    counts: Counter[str] = Counter()
    decoded: dict[str, list] = {}
    in_flight: list[int] = []
    with _mcap_file(mission.bag).open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        assert reader.get_header().profile == "ros2"
        assert {s.encoding for s in summary.schemas.values()} == {"ros2msg"}
        by_topic = {c.topic: c for c in summary.channels.values()}
        qos = yaml.safe_load(by_topic["/formation"].metadata["offered_qos_profiles"])
        assert qos[0]["durability"] == "transient_local"
        for _, channel, message, msg in reader.iter_decoded_messages():
            # as rosbag2's recorder: log time the receive time, publish time the send time
            assert 0 < message.publish_time <= message.log_time, channel.topic
            in_flight.append(message.log_time - message.publish_time)
            counts[channel.topic] += 1
            decoded.setdefault(channel.topic, []).append(msg)
    assert max(in_flight) > 0  # the send times are the publishers', not the receive times
    meta = yaml.safe_load((mission.bag / "metadata.yaml").read_text())
    expected_counts = {t["topic_metadata"]["name"]: t["message_count"] for t in
                       meta["rosbag2_bagfile_information"]["topics_with_message_count"]}
    assert dict(counts) == {name: n for name, n in expected_counts.items() if n}
    (formation,) = decoded["/formation"]
    assert formation.header.frame_id == "insar_track"
    assert _positions(formation.poses) == _positions(mission.formation.poses)
    for k in range(3):
        assert [m.data for m in decoded[f"/uav{k}/achieved_rate"]] == mission.rates[k]
        assert [m.data[0] for m in decoded[f"/uav{k}/offload"]] == list(range(SLOTS))


def test_rosbags_reads_the_same_bag_with_its_qos(mission):
    from rosbags.highlevel import AnyReader
    from rosbags.interfaces import QosDurability

    with AnyReader([mission.bag]) as reader:
        conns = {c.topic: c for c in reader.connections}
        assert EXPECTED <= set(conns)
        for name in EXPECTED:
            durability = conns[name].ext.offered_qos_profiles[0].durability
            assert (durability == QosDurability.TRANSIENT_LOCAL) == (name in LATCHED), name
        (item,) = list(reader.messages(connections=[conns["/formation"]]))
        formation = reader.deserialize(item[2], conns["/formation"].msgtype)
        assert _positions(formation.poses) == _positions(mission.formation.poses)
        power = [reader.deserialize(raw, c.msgtype) for c, _, raw in
                 reader.messages(connections=[conns["/formation/power"]])][0]
        assert [d.size for d in power.layout.dim] == [3, SLOTS, 1]


def _decoded(bag: Path, topic: str) -> list:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    with _mcap_file(bag).open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        return [m for _, _, _, m in reader.iter_decoded_messages(topics=[topic])]


def assert_both_readers_decode(bag: Path, mavlink: bool, slots: int) -> None:
    """Both independent readers decode every message of `bag`, which holds the suite's topics
    (with uavK/mavlink/pose when `mavlink`) and `slots` rates per UAV."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    from rosbags.highlevel import AnyReader

    wanted = EXPECTED | ({f"/uav{k}/mavlink/pose" for k in range(3)} if mavlink else set())
    with _mcap_file(bag).open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        seen = Counter(c.topic for _, c, _, _ in reader.iter_decoded_messages())
    assert wanted <= set(seen), sorted(wanted - set(seen))
    with AnyReader([bag]) as reader:
        again = Counter()
        for conn, _, raw in reader.messages():
            reader.deserialize(raw, conn.msgtype)
            again[conn.topic] += 1
    assert again == seen
    assert all(seen[f"/uav{k}/achieved_rate"] == slots for k in range(3)), seen


def test_markers_show_the_plan_in_the_track_frame(mission):
    from uav_insar_planner.params import default_params

    p = default_params()
    (array,) = _decoded(mission.bag, "/formation/markers")
    assert array.markers[0].action == 3  # DELETEALL: a new plan replaces the old markers
    shown = array.markers[1:]
    assert {m.header.frame_id for m in array.markers} == {"insar_track"}
    per_ns = Counter(m.ns for m in shown)
    assert {ns: per_ns[ns] for ns in ("planned", "labels", "beam", "swath")} == dict.fromkeys(
        ("planned", "labels", "beam", "swath"), 3)
    assert per_ns["target_line"] == 1 and per_ns["ground_station"] == 1
    assert 0 <= per_ns["comm_disk"] <= 3
    assert len({(m.ns, m.id) for m in shown}) == len(shown)  # each one addressable
    planned = {m.id: (m.pose.position.x, m.pose.position.y, m.pose.position.z)
               for m in shown if m.ns == "planned"}
    assert [planned[k] for k in range(3)] == _positions(mission.formation.poses)
    track_end = SLOTS * p.speed * p.slot_duration_s
    for m in shown:
        if m.ns == "swath":  # ground between the beam's -3 dB edges, along the whole track
            x, _, z = planned[m.id]
            theta = p.theta0 if m.id == 0 else math.atan((p.x_t - x) / z)
            lo, hi = (x + z * math.tan(theta + s * p.beamwidth / 2) for s in (-1, 1))
            assert m.pose.position.x == pytest.approx((lo + hi) / 2)
            assert m.scale.x == pytest.approx(hi - lo)
            assert m.scale.y == pytest.approx(track_end)
        if m.ns == "beam":
            assert (m.points[0].x, m.points[0].y, m.points[0].z) == planned[m.id]
        if m.ns == "target_line":
            assert {pt.x for pt in m.points} == {p.x_t}
        if m.ns == "ground_station":
            assert (m.pose.position.x, m.pose.position.y, m.pose.position.z) == \
                pytest.approx(p.ground_station)


def test_flown_markers_follow_the_agents_poses(mission):
    flown = _decoded(mission.bag, "/formation/markers/flown")
    assert flown
    last = {m.id: m for m in flown[-1].markers if m.ns == "actual"}
    assert sorted(last) == [0, 1, 2]
    for k in range(3):
        pose = _decoded(mission.bag, f"/uav{k}/pose")[-1].pose.position
        where = last[k].pose.position
        assert last[k].header.frame_id == "insar_track"
        # published at most every 0.2 s: within that much flight of the last pose
        assert math.dist((where.x, where.y, where.z), (pose.x, pose.y, pose.z)) < 3.0


def test_record_refuses_an_existing_out_and_a_bad_duration(tmp_path):
    for args, field in ([str(tmp_path)], "OUT"), ([str(tmp_path / "b"), "--duration", "0"],
                                                  "--duration"):
        proc = process_group.run([sys.executable, "-m", "uav_insar_planner.cli", "record", *args],
                              capture_output=True, text=True, timeout=30, cwd=REPO)
        assert proc.returncode == 2, proc.stderr
        assert len(proc.stderr.strip().splitlines()) == 1 and field in proc.stderr
    assert not (tmp_path / "b").exists()


def test_record_stops_after_duration_with_an_empty_bag(ros_domain, tmp_path):
    proc = process_group.run([sys.executable, "-m", "uav_insar_planner.cli", "record",
                           str(tmp_path / "empty"), "--duration", "0.5"],
                          capture_output=True, text=True, timeout=30, cwd=REPO)
    assert proc.returncode == 0, proc.stderr
    assert "recorded 0 messages on 0 topics" in proc.stdout
    assert (tmp_path / "empty" / "metadata.yaml").is_file()


def test_demo_refuses_an_existing_bag(tmp_path):
    proc = process_group.run([sys.executable, "-m", "uav_insar_planner.demo", "--bag",
                           str(tmp_path)], capture_output=True, text=True, timeout=30, cwd=REPO)
    assert proc.returncode == 2 and "--bag" in proc.stderr and "exists" in proc.stderr



def test_a_stop_signal_amid_a_write_leaves_every_message_readable(tmp_path, monkeypatch):
    """SIGINT while the recorder's writer is half-way through a message record (between the
    record's start and its length): its handler once raised KeyboardInterrupt right there, and
    the bag closed with that record begun and never finished, its last chunk unreadable (seen
    in test_sitl_px4_hosts.py's busy recording). Now the handler only asks the loop to stop."""
    import os
    import signal

    from mcap.data_stream import RecordBuilder
    from mcap.reader import make_reader

    from uav_insar_planner.bag.writer import McapBagWriter
    from uav_insar_planner.ros.tools import bag_recorder

    finish = RecordBuilder.finish_record

    def signalled(self: RecordBuilder) -> None:
        os.kill(os.getpid(), signal.SIGINT)  # delivered here, in the main thread
        finish(self)

    bag = McapBagWriter(tmp_path / "bag")
    bag.add_topic("/t", "std_msgs/msg/String")
    previous = signal.signal(signal.SIGINT, bag_recorder._stop)
    try:
        monkeypatch.setattr(RecordBuilder, "finish_record", signalled)
        bag.write("/t", 1, bytes(12))
    finally:
        monkeypatch.undo()
        signal.signal(signal.SIGINT, previous)
    bag.close()
    with bag.mcap_path.open("rb") as f:
        assert sum(1 for _ in make_reader(f).iter_messages()) == 1
