"""ROS bags with ``sensor_msgs/msg/Imu`` messages, read with the pure-Python ``rosbags``
library (no ROS installation): ROS 1 ``.bag`` files, ROS 2 bag directories (with
``metadata.yaml``) and single ``.mcap`` / ``.db3`` storage files.

Columns (REP 103 / REP 145 units, as the message definition states them):

* ``time``: ``header.stamp`` in integer nanoseconds (read as seconds from the first sample;
  a bag whose stamps are all zero falls back to the recording time, with a note);
* ``gx``, ``gy``, ``gz``: ``angular_velocity`` in rad/s (gyrotest converts to its units);
* ``ax``, ``ay``, ``az``: ``linear_acceleration`` in m/s² (kept as extra channels).

The Imu topic is found automatically when the bag has one; with several, ``--topic`` names it
(the error lists them). Messages are read one at a time into preallocated arrays, so memory is
the columns, not the bag. Requires ``rosbags`` (``pip install 'gyrotest[ros]'``).
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np

from ..core.errors import InputError
from .containerbase import Found, need

IMU_TYPES = ("sensor_msgs/msg/Imu", "sensor_msgs/Imu")
COLUMNS = ["time", "gx", "gy", "gz", "ax", "ay", "az"]
UNITS = {"time": "ns", "gx": "rad/s", "gy": "rad/s", "gz": "rad/s",
         "ax": "m/s^2", "ay": "m/s^2", "az": "m/s^2"}


def _open(p: Path, source: str):
    need("rosbags", "ros", source, "a ROS bag")
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    is2 = p.suffix.lower() != ".bag"
    store = get_typestore(Stores.ROS2_HUMBLE if is2 else Stores.ROS1_NOETIC)
    try:
        reader = AnyReader([p], default_typestore=store)
        reader.open()
    except Exception as e:  # rosbags raises its own reader errors, OSError, KeyError, ...
        raise InputError(f"{source}: not a readable ROS bag ({type(e).__name__}: "
                         f"{str(e).splitlines()[0][:120] if str(e) else 'damaged'}); the "
                         "recording may be truncated (ROS 1: rosbag reindex; ROS 2: "
                         "ros2 bag reindex)") from None
    return reader


def _imu_topic(reader, source: str, select: str | None) -> tuple[str, int]:
    topics = reader.topics
    imu = {t: i for t, i in topics.items() if i.msgtype in IMU_TYPES}
    if select:
        if select not in topics:
            raise InputError(f"{source}: no topic {select!r} in the bag; Imu topics: "
                             f"{', '.join(sorted(imu)) or 'none'}")
        if select not in imu:
            raise InputError(f"{source}: topic {select!r} carries {topics[select].msgtype}, not "
                             f"sensor_msgs/msg/Imu; Imu topics: {', '.join(sorted(imu)) or 'none'}")
        return select, imu[select].msgcount
    if not imu:
        listed = ", ".join(f"{t} ({i.msgtype})" for t, i in sorted(topics.items())[:8])
        raise InputError(f"{source}: no sensor_msgs/msg/Imu topic in the bag (topics: "
                         f"{listed or 'none'}); gyrotest reads IMU messages from bags")
    if len(imu) > 1:
        raise InputError(f"{source}: several Imu topics ({', '.join(sorted(imu))}); name one "
                         "with --topic")
    (topic, info), = imu.items()
    return topic, info.msgcount


def read_bag(p: Path, source: str, columns: list[str] | None, select: str | None, *,
             names_only: bool = False) -> Found:
    """Read the Imu messages of a bag (see the module docstring)."""
    reader = _open(p, source)
    try:
        topic, count = _imu_topic(reader, source, select)
        found = Found(f"Imu topic {topic!r}")
        found.names = list(COLUMNS)
        found.units = dict(UNITS)
        found.origin = {"ros_topic": topic}
        found.notes.append(f"ROS bag: topic {topic!r} (sensor_msgs/msg/Imu, {count:,} "
                           "messages); rates in rad/s, accelerations in m/s²")
        if names_only:
            return found
        if count == 0:
            raise InputError(f"{source}: the Imu topic {topic!r} holds no messages")
        _read_messages(reader, topic, count, found, source, p)
    finally:
        reader.close()
    wanted = columns if columns is not None else found.names
    found.arrays = {k: v for k, v in found.arrays.items() if k in wanted}
    return found


_U32 = struct.Struct("<I")
_STAMP1 = struct.Struct("<4xII")  # ROS 1 header: seq, stamp.sec, stamp.nsec
_STAMP2 = struct.Struct("<iI")  # ROS 2 (CDR, little endian): stamp.sec, stamp.nanosec
_SIX = struct.Struct("<3d72x3d")  # angular_velocity, its covariance, linear_acceleration
_TAIL = 8 * (4 + 9 + 3 + 9 + 3 + 9)  # bytes after the header of a standard Imu message


def fast_imu(raw: bytes | memoryview, ros1: bool) -> tuple | None:
    """(sec, nanosec, wx, wy, wz, ax, ay, az) straight from the bytes of a standard
    ``sensor_msgs/Imu`` (ROS 1 serialisation, or little-endian CDR), or None when the layout
    is not the standard one (then the library deserialises it)."""
    if ros1:
        sec, nsec = _STAMP1.unpack_from(raw, 0)
        pos = 16 + _U32.unpack_from(raw, 12)[0]
    else:
        if len(raw) < 16 or raw[1] != 1:  # encapsulation: CDR little endian
            return None
        sec, nsec = _STAMP2.unpack_from(raw, 4)
        pos = 16 + _U32.unpack_from(raw, 12)[0]
        pos = ((pos - 4 + 7) & ~7) + 4  # doubles are aligned to 8 from the CDR body start
    if pos + _TAIL != len(raw):
        return None
    return (sec, nsec, *_SIX.unpack_from(raw, pos + 8 * (4 + 9)))


def _size(p: Path) -> int:
    try:
        return sum(f.stat().st_size for f in p.iterdir()) if p.is_dir() else p.stat().st_size
    except OSError:
        return 0


#: bytes an Imu message takes in a bag at least (its payload alone is over 300 bytes): the
#: index's message count is trusted only up to the file size over this
MIN_MESSAGE_BYTES = 64


def _read_messages(reader, topic: str, count: int, found: Found, source: str,
                   p: Path | None = None) -> None:
    if p is not None:  # a damaged index may claim any count: never allocate past the file
        count = max(16, min(count, _size(p) // MIN_MESSAGE_BYTES))
    stamp = np.empty(count, dtype=np.int64)
    recv = np.empty(count, dtype=np.int64)
    vals = np.empty((6, count))
    conns = [c for c in reader.connections if c.topic == topic]
    n = 0
    frames: set[str] = set()
    ros1 = not reader.is2
    rows: list[tuple] = []  # (sec, nsec, 6 values) per message, into the arrays in blocks
    block = 65536

    def flush():
        nonlocal n, count, stamp, recv, vals
        if not rows:
            return
        k = len(rows)
        if n + k > count:  # more messages than the index says: grow
            count = max(int(count * 1.5), n + k) + 16
            stamp = np.resize(stamp, count)
            recv = np.resize(recv, count)
            vals = np.concatenate([vals, np.empty((6, count - vals.shape[1]))], axis=1)
        a = np.array(rows, dtype=np.float64)
        s = np.array([r[0] for r in rows], dtype=np.int64)
        ns = np.array([r[1] for r in rows], dtype=np.int64)
        stamp[n:n + k] = s * 1_000_000_000 + ns
        recv[n:n + k] = times
        vals[:, n:n + k] = a[:, 2:].T
        n += k
        rows.clear()
        times.clear()

    times: list[int] = []
    fast = True  # checked against the library's deserialisation on the first message
    try:
        for conn, t_ns, raw in reader.messages(connections=conns):
            row = fast_imu(raw, ros1) if fast else None
            if row is None or not frames:
                msg = reader.deserialize(raw, conn.msgtype)
                h, w, a = msg.header, msg.angular_velocity, msg.linear_acceleration
                frames.add(h.frame_id)
                full = (int(h.stamp.sec), int(h.stamp.nanosec), w.x, w.y, w.z, a.x, a.y, a.z)
                if row is not None and row != full:  # not the standard layout after all
                    fast = False
                row = full
            rows.append(row)
            times.append(t_ns)
            if len(rows) == block:
                flush()
        flush()
    except InputError:
        raise
    except Exception as e:  # a truncated chunk, a message that does not decode
        raise InputError(f"{source}: cannot read message {n + len(rows) + 1} of topic {topic!r} "
                         f"({type(e).__name__}: {str(e).splitlines()[0][:100] if str(e) else ''})"
                         "; the bag may be truncated or damaged") from None
    if n == 0:
        raise InputError(f"{source}: the Imu topic {topic!r} holds no messages")
    stamp, recv, vals = stamp[:n], recv[:n], vals[:, :n]
    if not stamp.any():
        found.notes.append("header stamps are all zero: the bag's recording time is used")
        stamp = recv
    if frames - {""}:
        found.notes.append(f"frame_id {', '.join(sorted(frames - {''}))}")
    found.arrays["time"] = stamp.copy()
    for i, k in enumerate(COLUMNS[1:]):
        found.arrays[k] = vals[i].copy()
