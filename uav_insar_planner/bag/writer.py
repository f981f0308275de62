"""A rosbag2 bag folder with MCAP storage, as rosbag2 Jazzy's `ros2 bag record -s mcap` leaves
it, field by field (no ROS import).

    bag = McapBagWriter(Path("mission_bag"))        # refuses a path that exists
    bag.add_topic("/formation", "geometry_msgs/msg/PoseArray", [qos_dict, ...])
    bag.write("/formation", receive_time_ns, serialized_cdr_bytes, publish_time_ns)
    bag.close()                                     # writes the MCAP summary and metadata.yaml

The folder holds `<name>_0.mcap` and `metadata.yaml` (bag.metadata: rosbag2 format version 9,
`ros_distro` jazzy). The MCAP file is what rosbag2_storage_mcap writes (its
src/mcap_storage.cpp, jazzy branch, file:line): header profile `ros2` (:97), chunked, not
compressed (:391); per type a schema named `pkg/msg/Type`, encoding `ros2msg`, the full
definition (bag.definitions.full_definition) (:915-919); per topic a channel, encoding `cdr`
(:933), whose metadata is `offered_qos_profiles` (the publishers' QoS as YAML text, so
`ros2 bag play` offers them again: a transient-local topic is latched on playback) and
`topic_type_hash` (the RIHS01 hash) (:935-938); chunk CRC 0, the summary CRC written
(rosbag2's `noChunkCRC = true` (:390), libmcap's noSummaryCRC and enableDataCRC left false, so
the data section's CRC is 0 too); each message at its receive time (log time),
its publisher's send time (publish time) and sequence 0 (:871-876); and a metadata record
`rosbag2` whose `serialized_metadata` is the BagMetadata as YAML (:964-968), once when the bag
opens and once more when it closes (rosbag2_cpp's sequential_writer.cpp:168 and :187).

One deliberate difference: the header's `library` names this writer (MCAP_LIBRARY) where
rosbag2 leaves the C++ library's own `libmcap 1.3.0`: the field says who wrote the file.

The `mcap` package ties the chunk and summary CRCs to one switch (`enable_crcs`), where
libmcap has one each: it runs with both off, and `close` writes the summary CRC into the
footer afterwards (`_write_summary_crc`, as the MCAP spec defines it).

A QoS dictionary has the keys of rosbag2's metadata (bag.metadata.qos_profile): history,
depth, reliability, durability (names as in rclpy's policies, lower case), deadline, lifespan,
liveliness_lease_duration as {sec, nsec}, liveliness and avoid_ros_namespace_conventions.
"""
from __future__ import annotations

import struct
import zlib
from collections.abc import Mapping, Sequence
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import IO, Any

import mcap
from mcap.writer import MCAP0_MAGIC, CompressionType
from mcap.writer import Writer as _McapWriter

from uav_insar_planner.bag import metadata as rosbag2
from uav_insar_planner.bag.definitions import canonical_type, full_definition, type_hash


def _own_version() -> str:
    try:
        return version("uav_insar_planner")
    except PackageNotFoundError:  # run from a source tree that was never installed
        return "(source)"


MCAP_PROFILE = "ros2"
MCAP_LIBRARY = f"uav_insar_planner {_own_version()}, python mcap {mcap.__version__}"
SCHEMA_ENCODING = "ros2msg"
CHUNK_SIZE = 768 * 1024  # libmcap's DefaultChunkSize, which rosbag2 keeps
CUSTOM_DATA = {"recorded_by": "uav_insar_planner"}  # as `ros2 bag record --custom-data` adds
# The MCAP footer record: opcode, record length, summary_start, summary_offset_start (all but
# the opcode u64), summary_crc (u32); then the closing magic.
_FOOTER_HEAD = struct.Struct("<BQQQ")
_FOOTER_CRC = struct.Struct("<I")


class McapBagWriter:
    """See the module docstring. Not thread-safe: one thread adds and writes."""

    def __init__(self, path: Path) -> None:
        self.path = Path(path)
        self.path.mkdir(parents=True, exist_ok=False)
        self.distro = rosbag2.ros_distro()
        self._file = self.mcap_path.open("w+b")  # read back once: the summary CRC
        self._mcap = _McapWriter(self._file, chunk_size=CHUNK_SIZE,
                                 compression=CompressionType.NONE, enable_crcs=False)
        self._mcap.start(profile=MCAP_PROFILE, library=MCAP_LIBRARY)
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self._topics: dict[str, tuple[str, list[Mapping[str, Any]], str]] = {}
        self.counts: dict[str, int] = {}
        self._first_ns: int | None = None
        self._last_ns: int | None = None
        self._write_metadata_record()  # the opening one: no topics, no messages yet

    def __contains__(self, topic: str) -> bool:
        return topic in self._channels

    def add_topic(self, topic: str, msg_type: str,
                  offered_qos: Sequence[Mapping[str, Any]] = ()) -> None:
        """Register `topic` of `msg_type` ('pkg/msg/Type') with its publishers' QoS."""
        msg_type = canonical_type(msg_type)
        definition, rihs01 = full_definition(msg_type), type_hash(msg_type)
        if msg_type not in self._schemas:
            self._schemas[msg_type] = self._mcap.register_schema(
                msg_type, SCHEMA_ENCODING, definition.encode())
        offered = [rosbag2.qos_profile(q) for q in offered_qos]
        self._channels[topic] = self._mcap.register_channel(
            topic, rosbag2.SERIALIZATION_FORMAT, self._schemas[msg_type],
            {"offered_qos_profiles": rosbag2.dump(offered), "topic_type_hash": rihs01})
        self._topics[topic] = (msg_type, offered, rihs01)
        self.counts[topic] = 0

    def write(self, topic: str, time_ns: int, data: bytes,
              publish_time_ns: int | None = None) -> None:
        """One serialized (CDR) message of a registered topic, received at `time_ns`, sent at
        `publish_time_ns` (the publisher's source timestamp; None: `time_ns`)."""
        time_ns = int(time_ns)
        sent = time_ns if publish_time_ns is None else int(publish_time_ns)
        self._mcap.add_message(self._channels[topic], log_time=time_ns, data=bytes(data),
                               publish_time=sent, sequence=0)
        self.counts[topic] += 1
        self._first_ns = time_ns if self._first_ns is None else min(self._first_ns, time_ns)
        self._last_ns = time_ns if self._last_ns is None else max(self._last_ns, time_ns)

    def metadata(self) -> dict[str, Any]:
        """The bag's BagMetadata as it stands (bag.metadata.bag_metadata)."""
        topics = [rosbag2.topic_information(name, msg_type, offered, rihs01, self.counts[name])
                  for name, (msg_type, offered, rihs01) in self._topics.items()]
        start = rosbag2.NO_MESSAGE_YET_NS if self._first_ns is None else self._first_ns
        duration = 0 if self._first_ns is None else self._last_ns - self._first_ns
        return rosbag2.bag_metadata(self.mcap_path.name, topics, start, duration, CUSTOM_DATA,
                                    self.distro)

    def close(self) -> None:
        """Finish the MCAP file (the closing `rosbag2` record, summary) and write metadata.yaml."""
        if self._file.closed:
            return
        self._write_metadata_record()
        self._mcap.finish()
        _write_summary_crc(self._file)
        self._file.close()
        (self.path / "metadata.yaml").write_text(rosbag2.metadata_file(self.metadata()))

    def _write_metadata_record(self) -> None:
        self._mcap.add_metadata("rosbag2", {"serialized_metadata": rosbag2.dump(self.metadata())})

    @property
    def mcap_path(self) -> Path:
        """`<folder>/<folder>_0.mcap`: rosbag2's name for a bag's first (here only) file
        (sequential_writer.cpp:303-312 and mcap_storage.cpp:385)."""
        return self.path / f"{self.path.name}_0.mcap"


def _write_summary_crc(f: IO[bytes]) -> None:
    """Fill in the footer's summary_crc of the finished MCAP file `f`: the CRC-32 of the
    summary section and of the footer's fields before the CRC (MCAP spec, Footer)."""
    f.flush()
    footer = f.seek(0, 2) - len(MCAP0_MAGIC) - _FOOTER_HEAD.size - _FOOTER_CRC.size
    f.seek(footer)
    head = f.read(_FOOTER_HEAD.size)
    summary_start = _FOOTER_HEAD.unpack(head)[2]
    summary = b""
    if summary_start:
        f.seek(summary_start)
        summary = f.read(footer - summary_start)
    f.seek(footer + _FOOTER_HEAD.size)
    f.write(_FOOTER_CRC.pack(zlib.crc32(head, zlib.crc32(summary))))
    f.flush()
