"""Reading ``sensor_msgs/Imu`` topics of ROS bags into columns of a recording.

ROS 1 ``.bag`` files and ROS 2 bags (a bag folder with its ``metadata.yaml``, or a bare
``.db3`` / ``.mcap`` storage file) are read with the ``rosbags`` library; no ROS installation
is needed. One IMU topic becomes one table:

- ``time``: the message's ``header.stamp`` in seconds, counted from the first message's stamp
  (integer nanoseconds until then, so no resolution is lost to seconds since 1970);
- ``bag_time``: the time the recorder received the message, in seconds from the first one.
  A driver that leaves ``header.stamp`` empty gives every message the same stamp; the table
  then has no ``time`` column, and ``--time-column bag_time`` (or ``--rate``) says which
  clock to trust instead;
- ``gyro_x/y/z`` from ``angular_velocity`` and ``acc_x/y/z`` from ``linear_acceleration``, in
  the units the message definition fixes (REP 103 / ``sensor_msgs/msg/Imu``: rad/s and m/s^2),
  carried like units written in a CSV header.

Messages are decoded straight from their bytes when they have the standard layout (checked
against ``rosbags``' own decoding of the first and last message of every block); anything
else goes through ``rosbags``' deserializer, message by message, which is several times
slower. A corrupt or truncated bag is an input error (exit 2) that quotes ``rosbags``.
"""

import struct
from pathlib import Path

import numpy as np

from .._errors import InputError, MissingFileError

IMU_TYPE = "sensor_msgs/msg/Imu"
SUFFIXES = (".bag", ".db3", ".mcap")
_UNITS = {
    "time": "s",
    "bag_time": "s",
    **{f"gyro_{axis}": "rad/s" for axis in "xyz"},
    **{f"acc_{axis}": "m/s^2" for axis in "xyz"},
}
_BLOCK = 1 << 16  # messages decoded at a time
# After the header, an Imu message holds 37 float64: orientation (4), its covariance (9),
# angular_velocity (3), covariance (9), linear_acceleration (3), covariance (9).
_N_DOUBLES = 37
_GYRO_AT, _ACC_AT = 13, 25


def is_rosbag(path: Path) -> bool:
    """Whether ``path`` names a ROS bag: a .bag, .db3 or .mcap file, or a folder."""
    return path.suffix.lower() in SUFFIXES or path.is_dir()


def _one_line(error: Exception, limit: int = 200) -> str:
    """An error of the rosbags library as one short line (YAML errors span several)."""
    text = " ".join(str(error).split()).rstrip(".")
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _open(path: Path, source: str):
    from rosbags.highlevel import AnyReader, AnyReaderError
    from rosbags.typesys import Stores, get_typestore

    if path.is_dir() and not (path / "metadata.yaml").is_file():
        raise InputError(
            "a folder, but not a ROS 2 bag: it has no metadata.yaml",
            source=source,
            fix="pass the bag folder, a .db3 or .mcap file, a ROS 1 .bag or a table",
        )
    try:
        # Bags that carry no message definitions (old ROS 2 .db3) are read with the
        # standard types of the latest ROS 2 release; sensor_msgs/Imu has not changed.
        reader = AnyReader([path], default_typestore=get_typestore(Stores.LATEST))
        reader.open()
    except (AnyReaderError, OSError, ValueError, KeyError, struct.error) as error:
        raise InputError(
            f"cannot read it as a ROS bag: {_one_line(error)}",
            source=source,
            fix="check that it is a complete ROS 1 .bag or ROS 2 bag",
        ) from None
    return reader


def _choose_topic(reader, topic: str | None, source: str) -> str:
    topics = reader.topics
    imu = sorted(name for name, info in topics.items() if info.msgtype == IMU_TYPE)
    listing = ", ".join(f"{name} ({info.msgtype})" for name, info in sorted(topics.items()))
    if not imu:
        raise InputError(
            "the bag has no sensor_msgs/Imu topic",
            source=source,
            fix=f"its topics are: {listing or '(none)'}",
        )
    if topic is None:
        if len(imu) > 1:
            raise InputError(
                f"the bag has {len(imu)} sensor_msgs/Imu topics: {', '.join(imu)}",
                source=source,
                fix="choose one with topic=",
            )
        return imu[0]
    if topic not in imu:
        problem = (
            f"topic '{topic}' holds {topics[topic].msgtype}, not sensor_msgs/Imu"
            if topic in topics
            else f"no topic '{topic}'"
        )
        raise InputError(problem, source=source, fix=f"IMU topics: {', '.join(imu)}")
    if topics[topic].msgcount == 0:
        raise InputError(f"topic '{topic}' holds no messages", source=source)
    return topic


def _layout(raw: bytes, ros2: bool) -> tuple[int, int, str] | None:
    """(offset of the first float64, message length, byte order) of a standard Imu message,
    or None when it is not laid out as the standard message is."""
    if ros2:
        # CDR: 4-byte encapsulation header, then int32 sec, uint32 nanosec, a string with its
        # uint32 length and its NUL; float64 aligned to 8 from the end of the 4-byte header.
        if len(raw) < 16 or raw[0] != 0 or raw[1] not in (0, 1):
            return None
        order = "<" if raw[1] == 1 else ">"
        length = struct.unpack_from(f"{order}I", raw, 12)[0]
        first = 4 + (12 + length + 7) // 8 * 8
    else:
        # ROS 1: uint32 seq, sec, nsec, a string with its uint32 length, packed float64.
        if len(raw) < 16:
            return None
        order = "<"
        first = 16 + struct.unpack_from("<I", raw, 12)[0]
    size = first + 8 * _N_DOUBLES
    return (first, size, order) if size == len(raw) else None


def _values(message) -> tuple:
    stamp = message.header.stamp
    return (
        stamp.sec * 1_000_000_000 + stamp.nanosec,
        *(getattr(message.angular_velocity, axis) for axis in "xyz"),
        *(getattr(message.linear_acceleration, axis) for axis in "xyz"),
    )


def _decode_block(raws: list[bytes], ros2: bool, check) -> tuple[np.ndarray, np.ndarray] | None:
    """Stamps (ns) and the six readings of a block of messages that all have the standard
    layout, or None. ``check(index)`` decodes message ``index`` with rosbags, to verify."""
    layout = _layout(raws[0], ros2)
    if layout is None:
        return None
    first, size, order = layout
    # One length and one frame_id length: then every message has the same offsets.
    if any(len(raw) != size or raw[12:16] != raws[0][12:16] for raw in raws):
        return None
    block = np.frombuffer(b"".join(raws), np.uint8).reshape(len(raws), size)
    # The stamp follows the CDR encapsulation header (ROS 2) or the uint32 seq (ROS 1).
    seconds = block[:, 4:8].copy().view(f"{order}{'i4' if ros2 else 'u4'}")[:, 0]
    nanos = block[:, 8:12].copy().view(f"{order}u4")[:, 0]
    stamps = seconds.astype(np.int64) * 1_000_000_000 + nanos.astype(np.int64)
    doubles = block[:, first:].copy().view(f"{order}f8")
    values = np.concatenate(
        [doubles[:, _GYRO_AT : _GYRO_AT + 3], doubles[:, _ACC_AT : _ACC_AT + 3]], axis=1
    )
    for index in {0, len(raws) - 1}:
        if (stamps[index], *values[index]) != check(index):
            return None
    return stamps, values


def _decode_slow(reader, connections, raws) -> tuple[np.ndarray, np.ndarray]:
    stamps = np.empty(len(raws), np.int64)
    values = np.empty((len(raws), 6))
    for k, (connection, raw) in enumerate(zip(connections, raws, strict=True)):
        message = reader.deserialize(raw, connection.msgtype)
        row = _values(message)
        stamps[k], values[k] = row[0], row[1:]
    return stamps, values


def _read_topic(reader, topic: str, source: str):
    from rosbags.highlevel import AnyReaderError

    connections = [c for c in reader.connections if c.topic == topic]
    stamps, received, values = [], [], []

    def flush(block_connections, block_raws, block_received):
        def check(index):
            return _values(reader.deserialize(block_raws[index], block_connections[index].msgtype))

        decoded = _decode_block(block_raws, reader.is2, check)
        if decoded is None:
            decoded = _decode_slow(reader, block_connections, block_raws)
        stamps.append(decoded[0])
        values.append(decoded[1])
        received.append(np.asarray(block_received, np.int64))

    try:
        block_connections, block_raws, block_received = [], [], []
        for connection, timestamp, raw in reader.messages(connections=connections):
            block_connections.append(connection)
            block_raws.append(bytes(raw))
            block_received.append(timestamp)
            if len(block_raws) == _BLOCK:
                flush(block_connections, block_raws, block_received)
                block_connections, block_raws, block_received = [], [], []
        if block_raws:
            flush(block_connections, block_raws, block_received)
    except (AnyReaderError, struct.error, ValueError) as error:
        raise InputError(
            f"cannot decode topic '{topic}': {_one_line(error)}",
            source=source,
            fix="check that the bag is complete",
        ) from None
    if not stamps:
        raise InputError(f"topic '{topic}' holds no messages", source=source)
    return np.concatenate(stamps), np.concatenate(received), np.concatenate(values)


def read_rosbag(path: str | Path, topic: str | None = None) -> dict:
    """Read the ``sensor_msgs/Imu`` topic ``topic`` of a ROS bag (the only one when None):
    its columns, their units, the topic's name and the first message's ``header.stamp`` in
    nanoseconds since the epoch."""
    path = Path(path)
    source = str(path)
    if not path.exists():
        raise MissingFileError("no such file", source=source)
    reader = _open(path, source)
    try:
        chosen = _choose_topic(reader, topic, source)
        stamps, received, values = _read_topic(reader, chosen, source)
    finally:
        reader.close()
    columns = {}
    # A driver that leaves header.stamp empty gives every message one stamp: then there is no
    # 'time' column, and the loader asks for --time-column bag_time or --rate.
    if stamps.size < 2 or np.any(stamps != stamps[0]):
        columns["time"] = (stamps - stamps[0]) / 1e9
    columns["bag_time"] = (received - received[0]) / 1e9
    for k, name in enumerate(("gyro_x", "gyro_y", "gyro_z", "acc_x", "acc_y", "acc_z")):
        columns[name] = values[:, k].copy()
    return {
        "source": f"{path} [{chosen}]",
        "columns": columns,
        "header_units": {name: unit for name, unit in _UNITS.items() if name in columns},
        "topic": chosen,
        "start_stamp_ns": int(stamps[0]),
    }
