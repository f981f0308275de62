"""The bag our writer leaves holds, field by field, what rosbag2 Jazzy's `ros2 bag record -s
mcap` writes. Each expected value cites where rosbag2 (branch jazzy, commit 64717ee8, the
0.26 series) sets it. The bag is the known mission of test_bag_report (serialized by rosbags'
own type store, not by us) copied message by message through bag.writer.McapBagWriter; it is
read back with `mcap` (+ `mcap-ros2-support`'s decoder), `rosbags` and PyYAML, which share no
code with the writer, and with `uav-insar report`."""
from __future__ import annotations

import sys
from collections import Counter
from pathlib import Path

import process_group
import pytest
import yaml
from conftest import REPO
from test_bag_report import write_known_bag

from uav_insar_planner.bag.definitions import full_definition
from uav_insar_planner.bag.metadata import qos_profile
from uav_insar_planner.bag.writer import McapBagWriter

SENT_BEFORE_NS = 1_500  # each message's publisher "sent" it this long before it was received
LATCHED = {"/formation", "/formation/power"}
# rmw's RMW_DURATION_INFINITE, rmw/include/rmw/time.h:54 (ros2/rmw, jazzy)
INFINITE = {"sec": 9223372036, "nsec": 854775807}
QOS_KEYS = ["history", "depth", "reliability", "durability", "deadline", "lifespan",
            "liveliness", "liveliness_lease_duration", "avoid_ros_namespace_conventions"]


def _offered(topic: str) -> list[dict]:
    """What rclpy's graph reports of the publishers (bag_recorder.qos_dict); /uav0/pose has
    two publishers."""
    one = {"history": "keep_last", "depth": 1 if topic in LATCHED else 10,
           "reliability": "reliable",
           "durability": "transient_local" if topic in LATCHED else "volatile",
           "deadline": INFINITE, "lifespan": INFINITE, "liveliness": "automatic",
           "liveliness_lease_duration": INFINITE, "avoid_ros_namespace_conventions": False}
    two = dict(one, reliability="best_effort", deadline={"sec": 0, "nsec": 0})
    return [one, two] if topic == "/uav0/pose" else [one]


def _copy(source: Path, out: Path) -> dict[str, list[tuple[int, bytes]]]:
    """Every message of bag `source` into a new bag `out` by our writer; what was written."""
    from rosbags.highlevel import AnyReader

    written: dict[str, list[tuple[int, bytes]]] = {}
    bag = McapBagWriter(out)
    with AnyReader([source]) as reader:
        for conn in reader.connections:
            bag.add_topic(conn.topic, conn.msgtype, _offered(conn.topic))
        for conn, t_ns, raw in reader.messages():
            bag.write(conn.topic, t_ns, raw, t_ns - SENT_BEFORE_NS)
            written.setdefault(conn.topic, []).append((t_ns, bytes(raw)))
    bag.close()
    return written


@pytest.fixture(scope="module")
def bags(tmp_path_factory):
    """(the rosbags-written known bag, ours: its copy, what was written), ROS_DISTRO unset."""
    root = tmp_path_factory.mktemp("fields")
    reference, ours = root / "reference", root / "mission"
    write_known_bag(reference)
    with pytest.MonkeyPatch.context() as mp:
        mp.delenv("ROS_DISTRO", raising=False)
        written = _copy(reference, ours)
    return reference, ours, written


def _info(bag: Path) -> dict:
    return yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]


def _times(written: dict) -> list[int]:
    return sorted(t for msgs in written.values() for t, _ in msgs)


def test_the_folder_holds_metadata_yaml_and_name_0_mcap(bags):
    _, ours, _ = bags
    # SequentialWriter::format_storage_uri: <folder>_<n> (rosbag2_cpp/src/rosbag2_cpp/writers/
    # sequential_writer.cpp:303-312, n = 0 at open, :132) + ".mcap" (rosbag2_storage_mcap/src/
    # mcap_storage.cpp:161, :385)
    assert sorted(p.name for p in ours.iterdir()) == ["metadata.yaml", "mission_0.mcap"]
    # metadata_io.cpp:35: the whole map under rosbag2_bagfile_information
    assert list(yaml.safe_load((ours / "metadata.yaml").read_text())) == [
        "rosbag2_bagfile_information"]


def test_metadata_yaml_has_rosbag2s_fields_in_order_with_its_values(bags):
    _, ours, written = bags
    info = _info(ours)
    # rosbag2_storage/include/rosbag2_storage/yaml.hpp:260-273 (convert<BagMetadata>::encode)
    assert list(info) == ["version", "storage_identifier", "duration", "starting_time",
                          "message_count", "topics_with_message_count", "compression_format",
                          "compression_mode", "relative_file_paths", "files", "custom_data",
                          "ros_distro"]
    times, total = _times(written), sum(len(m) for m in written.values())
    assert info["version"] == 9  # rosbag2_storage/bag_metadata.hpp:45
    assert info["storage_identifier"] == "mcap"  # mcap_storage.cpp get_storage_identifier
    # sequential_writer.cpp:408-422: first receive time, latest minus first; yaml.hpp:224, :241
    assert info["starting_time"] == {"nanoseconds_since_epoch": times[0]}
    assert info["duration"] == {"nanoseconds": times[-1] - times[0]}
    assert info["message_count"] == total  # sequential_writer.cpp:516-520
    # no compression: rosbag2's default, both empty strings (yaml.hpp:267-268)
    assert info["compression_format"] == "" and info["compression_mode"] == ""
    assert info["relative_file_paths"] == ["mission_0.mcap"]  # sequential_writer.cpp:81
    # yaml.hpp:200-203 (FileInformation), values sequential_writer.cpp:414-430
    assert info["files"] == [{"path": "mission_0.mcap",
                              "starting_time": {"nanoseconds_since_epoch": times[0]},
                              "duration": {"nanoseconds": times[-1] - times[0]},
                              "message_count": total}]
    assert info["custom_data"] == {"recorded_by": "uav_insar_planner"}  # --custom-data's map
    # sequential_writer.cpp:89: ROS_DISTRO (unset here: the writer's default, Jazzy)
    assert info["ros_distro"] == "jazzy"
    text = (ours / "metadata.yaml").read_text()
    assert '  compression_format: ""\n' in text  # yaml-cpp's empty string, not PyYAML's ''


def test_each_topics_metadata_is_rosbag2s(bags):
    from rosbags.typesys import Stores, get_typestore

    _, ours, written = bags
    ts = get_typestore(Stores.ROS2_JAZZY)  # its own hashes, independent of bag.definitions
    topics = _info(ours)["topics_with_message_count"]
    assert sorted(t["topic_metadata"]["name"] for t in topics) == sorted(written)
    for t in topics:
        # yaml.hpp:152-154 (TopicInformation), :111-121 (TopicMetadata)
        assert list(t) == ["topic_metadata", "message_count"]
        meta = t["topic_metadata"]
        assert list(meta) == ["name", "type", "serialization_format", "offered_qos_profiles",
                              "type_description_hash"]
        assert t["message_count"] == len(written[meta["name"]])
        assert meta["serialization_format"] == "cdr"
        assert meta["type_description_hash"] == ts.hash_rihs01(meta["type"])
        assert meta["offered_qos_profiles"] == [
            qos_profile(q) for q in _offered(meta["name"])]


def test_qos_profiles_are_dumped_as_rosbag2_jazzy_dumps_them(bags):
    _, ours, _ = bags
    topics = {t["topic_metadata"]["name"]: t["topic_metadata"]
              for t in _info(ours)["topics_with_message_count"]}
    (latched,) = topics["/formation"]["offered_qos_profiles"]
    # rosbag2_storage/src/rosbag2_storage/qos.cpp:151-165 (convert<rclcpp::QoS>::encode, v9):
    # the keys in this order, policies as rmw's names (rmw/src/qos_string_conversions.c)
    assert list(latched) == QOS_KEYS
    assert latched == {"history": "keep_last", "depth": 1, "reliability": "reliable",
                       "durability": "transient_local", "deadline": INFINITE,
                       "lifespan": INFINITE, "liveliness": "automatic",
                       "liveliness_lease_duration": INFINITE,
                       "avoid_ros_namespace_conventions": False}
    first, second = topics["/uav0/pose"]["offered_qos_profiles"]  # one per publisher
    assert (first["reliability"], second["reliability"]) == ("reliable", "best_effort")
    assert second["deadline"] == {"sec": 0, "nsec": 0}


def test_rmw_numbers_and_unknown_policies_become_rmw_names():
    # rmw/include/rmw/types.h:373-513 (the enums' order); qos.cpp:51-52 writes "unknown"
    got = qos_profile({"history": 2, "reliability": 2, "durability": 1, "liveliness": 3,
                       "depth": 5})
    assert (got["history"], got["reliability"], got["durability"], got["liveliness"]) == (
        "keep_all", "best_effort", "transient_local", "manual_by_topic")
    assert qos_profile({"reliability": "sometimes"})["reliability"] == "unknown"


def _mcap(bag: Path):
    from mcap.reader import make_reader

    f = (bag / f"{bag.name}_0.mcap").open("rb")
    return f, make_reader(f)


def test_the_mcap_header_schemas_and_channels_are_rosbag2_storage_mcaps(bags):
    _, ours, _ = bags
    info = _info(ours)
    meta = {t["topic_metadata"]["name"]: t["topic_metadata"]
            for t in info["topics_with_message_count"]}
    f, reader = _mcap(ours)
    with f:
        header, summary = reader.get_header(), reader.get_summary()
    # mcap_storage.cpp:94-100: McapWriterOptions("ros2")
    assert header.profile == "ros2"
    # deliberately not libmcap's "libmcap 1.3.0": the field names the writer (bag/writer.py)
    assert header.library.startswith("uav_insar_planner ")
    # mcap_storage.cpp:391: no compression
    assert {c.compression for c in summary.chunk_indexes} == {""}
    assert summary.statistics.message_count == info["message_count"]
    # mcap_storage.cpp:914-919: one schema per type, named as the type, encoding from the
    # definition source (ros2msg), the full definition as its data
    assert sorted(s.name for s in summary.schemas.values()) == sorted(
        {m["type"] for m in meta.values()})
    for schema in summary.schemas.values():
        assert schema.encoding == "ros2msg"
        assert schema.data.decode() == full_definition(schema.name)
    assert sorted(c.topic for c in summary.channels.values()) == sorted(meta)
    for channel in summary.channels.values():
        m = meta[channel.topic]
        assert summary.schemas[channel.schema_id].name == m["type"]
        assert channel.message_encoding == "cdr"  # mcap_storage.cpp:933
        # mcap_storage.cpp:935-938: exactly these two, the QoS as YAML text
        # (qos.cpp:441-445 serialize_rclcpp_qos_vector) and the type hash
        assert sorted(channel.metadata) == ["offered_qos_profiles", "topic_type_hash"]
        assert yaml.safe_load(channel.metadata["offered_qos_profiles"]) == m[
            "offered_qos_profiles"]
        assert channel.metadata["topic_type_hash"] == m["type_description_hash"]


def test_chunk_crc_0_data_crc_0_and_a_summary_crc_as_rosbag2_writes_them(bags):
    """mcap_storage.cpp:389-391 sets `noChunkCRC = true` and leaves libmcap's `noSummaryCRC`
    and `enableDataCRC` false: every chunk's uncompressed_crc is 0, the data section's CRC is
    0, and the footer holds the summary section's CRC (MCAP spec, Footer: the summary section
    and the footer's fields before the CRC)."""
    import zlib

    from mcap.records import Chunk, DataEnd, Footer
    from mcap.stream_reader import StreamReader

    _, ours, _ = bags
    path = ours / f"{ours.name}_0.mcap"
    with path.open("rb") as f:
        records = list(StreamReader(f, emit_chunks=True, validate_crcs=True).records)
    chunks = [r for r in records if isinstance(r, Chunk)]
    (data_end,) = [r for r in records if isinstance(r, DataEnd)]
    (footer,) = [r for r in records if isinstance(r, Footer)]
    assert chunks and {c.uncompressed_crc for c in chunks} == {0}
    assert data_end.data_section_crc == 0
    raw = path.read_bytes()
    footer_at = len(raw) - 8 - 29  # the closing magic; opcode, length, 2 x u64 and the u32 CRC
    assert raw[footer_at] == 0x02 and footer.summary_start > 0
    expected = zlib.crc32(raw[footer.summary_start:footer_at + 25])
    assert footer.summary_crc == expected != 0


def test_messages_keep_receive_and_send_time_and_sequence_0(bags):
    _, ours, written = bags
    f, reader = _mcap(ours)
    got: dict[str, list[tuple[int, bytes]]] = {}
    with f:
        for _, channel, message in reader.iter_messages(log_time_order=False):
            # mcap_storage.cpp:871-876: sequence 0, logTime the receive time, publishTime the
            # send time
            assert message.sequence == 0
            assert message.publish_time == message.log_time - SENT_BEFORE_NS
            got.setdefault(channel.topic, []).append((message.log_time, message.data))
    assert got == written


def test_the_rosbag2_metadata_records_at_open_and_at_close(bags):
    _, ours, _ = bags
    f, reader = _mcap(ours)
    with f:
        records = list(reader.iter_metadata())
    # mcap_storage.cpp:964-968 (update_metadata): name rosbag2, only serialized_metadata;
    # called at open (sequential_writer.cpp:168) and at close (:187)
    assert [r.name for r in records] == ["rosbag2", "rosbag2"]
    assert all(list(r.metadata) == ["serialized_metadata"] for r in records)
    opened, closed = (yaml.safe_load(r.metadata["serialized_metadata"]) for r in records)
    # the open one is init_metadata's (sequential_writer.cpp:75-94): no topics, no messages,
    # starting_time std::chrono::nanoseconds::max()
    assert opened["message_count"] == 0 and opened["topics_with_message_count"] == []
    assert opened["starting_time"] == {"nanoseconds_since_epoch": 2**63 - 1}
    assert opened["ros_distro"] == "jazzy" and opened["relative_file_paths"] == [
        "mission_0.mcap"]
    # the closing one is what metadata.yaml holds (sequential_writer.cpp:185-189)
    assert closed == _info(ours)


def test_ros_distro_comes_from_the_environment_when_set(tmp_path, monkeypatch):
    monkeypatch.setenv("ROS_DISTRO", "rolling")  # sequential_writer.cpp:89
    bag = McapBagWriter(tmp_path / "b")
    bag.close()
    info = _info(tmp_path / "b")
    assert info["ros_distro"] == "rolling"
    # a bag without messages keeps init_metadata's starting time (sequential_writer.cpp:79)
    assert info["starting_time"] == {"nanoseconds_since_epoch": 2**63 - 1}
    assert info["message_count"] == 0 and info["duration"] == {"nanoseconds": 0}


def test_both_independent_readers_decode_every_message(bags):
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    from rosbags.highlevel import AnyReader

    reference, ours, written = bags
    counts = {t: len(m) for t, m in written.items()}
    with (ours / "mission_0.mcap").open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        seen = Counter(c.topic for _, c, _, _ in reader.iter_decoded_messages())
    assert dict(seen) == counts
    with AnyReader([ours]) as mine, AnyReader([reference]) as theirs:
        assert {c.topic: c.msgcount for c in mine.connections} == counts
        decoded = [(c.topic, t, repr(mine.deserialize(raw, c.msgtype)))
                   for c, t, raw in mine.messages()]
        expected = [(c.topic, t, repr(theirs.deserialize(raw, c.msgtype)))
                    for c, t, raw in theirs.messages()]
    assert sorted(decoded) == sorted(expected)


def test_uav_insar_report_reads_our_bag_as_it_reads_rosbags_own(bags, tmp_path):
    reference, ours, _ = bags
    out = {}
    for bag in (reference, ours):
        plots = tmp_path / bag.name
        proc = process_group.run([sys.executable, "-m", "uav_insar_planner.cli", "report",
                               str(bag), "--out", str(plots), "--no-progress"],
                              capture_output=True, text=True, timeout=60, cwd=REPO)
        assert proc.returncode == 0, proc.stderr
        # the Foxglove line names the bag's own MCAP file, whose name differs by design
        storage = next(bag.glob("*.mcap"))
        out[bag] = (proc.stdout.replace(str(plots), "PLOTS").replace(str(storage), "BAG/MCAP")
                    .replace(str(bag), "BAG"))
    assert "uav1:" in out[ours] and "sigma_h" in out[ours]
    assert out[ours] == out[reference]
