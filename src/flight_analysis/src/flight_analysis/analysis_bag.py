"""Reading a ROS 1 bag for the flight analysis, without ROS: rosbags, plus a recovery path for damaged bags.

``read_bag(path, topics)`` returns a :class:`BagContents` with the decoded messages of the wanted topics,
the message types found and a plain account of anything that could not be read. The message types are
registered from the definitions stored in the bag's own connections (so landing_msgs/Navdata and
landing_msgs/Touchdown need no installed package).

A bag whose index is missing or damaged (recording killed, file truncated, bytes garbled) is read a second
way: record by record from the start of the file, decompressing chunk by chunk (a truncated last chunk is
decompressed as far as it goes) and skipping past chunks that do not decode. What could not be read is
reported in ``BagContents.problems`` and ``BagContents.integrity``."""
import bz2
import os
import struct
from dataclasses import dataclass, field

MAGIC = b"#ROSBAG V2.0\n"
OP_MSGDATA, OP_BAGHEADER, OP_INDEXDATA, OP_CHUNK, OP_CHUNKINFO, OP_CONNECTION = 2, 3, 4, 5, 6, 7


class BagError(Exception):
    """Nothing usable could be read from the file; the message names the file and what is wrong."""


@dataclass
class BagContents:
    path: str
    messages: dict = field(default_factory=dict)      # topic -> list of (bag time [s], message)
    msgtypes: dict = field(default_factory=dict)      # topic -> msgtype ("pkg/msg/Name")
    counts: dict = field(default_factory=dict)        # topic -> messages in the bag (all topics)
    problems: list = field(default_factory=list)      # human-readable account of what was lost
    integrity: dict = field(default_factory=dict)     # machine-readable account (metrics.json)
    start_s: float = None
    end_s: float = None

    def get(self, topic):
        return self.messages.get(topic, [])


def _typestore(connections):
    """Empty rosbags typestore with every type defined in ``connections`` [(msgtype, msgdef text)]."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore
    store = get_typestore(Stores.EMPTY)
    types, failed = {}, []
    for msgtype, msgdef in connections:
        if msgtype in types:
            continue
        try:
            types.update(get_types_from_msg(msgdef, msgtype))
        except Exception as err:  # a malformed definition only costs its own topic
            failed.append("%s (%s)" % (msgtype, err))
    try:
        store.register(types)
    except Exception:  # conflicting definitions: register one by one, keep what works
        for name, definition in types.items():
            try:
                store.register({name: definition})
            except Exception as err:
                failed.append("%s (%s)" % (name, err))
    return store, failed


def read_bag(path, topics=None, max_rate=None, unless=None):
    """Decoded messages of ``topics`` (all topics if None) from the ROS 1 bag at ``path``; topics in
    ``max_rate`` ({topic: Hz}) are decoded at most at that rate (for images); a topic A of ``unless``
    ({A: B}) is decoded only when the bag has no topic B (a fallback source).

    Frequent fixed-layout messages (PoseStamped, PointStamped, Odometry, landing_msgs/Navdata) come back
    as :class:`Flat` objects (numbers in ``values``, header stamp in ``stamp``), the others as rosbags
    messages; both allow attribute access such as ``m.pose.position.x``.

    Raises BagError when the file is missing, is not a ROS 1 bag, or nothing at all could be read."""
    if not os.path.exists(path):
        raise BagError("%s: no such file" % path)
    if os.path.isdir(path):
        raise BagError("%s: is a directory, expected a ROS 1 bag file (.bag)" % path)
    size = os.path.getsize(path)
    with open(path, "rb") as stream:
        magic = stream.read(len(MAGIC))
    if magic != MAGIC:
        if size == 0:
            raise BagError("%s: the file is empty (0 bytes)" % path)
        raise BagError("%s: not a ROS 1 bag (the file does not start with '#ROSBAG V2.0'; %d bytes)" % (path, size))
    wanted = None if topics is None else set(topics)
    try:
        contents = _read_indexed(path, wanted, max_rate or {}, unless or {})
        contents.integrity = {"status": "ok", "reader": "rosbags", "file_bytes": size}
    except (BagError, ImportError):
        raise
    except Exception as err:  # rosbags ReaderError, lz4/bz2 errors, struct errors, ...
        contents = _read_by_scanning(path, wanted, "%s: %s" % (type(err).__name__, err), max_rate or {},
                                      unless or {})
    if not any(contents.counts.values()):
        detail = "; ".join(contents.problems) or "the bag holds no messages"
        raise BagError("%s: nothing usable could be read (%s)" % (path, detail))
    return contents


class _Thinning:
    """Decides which messages of rate-limited topics to decode."""

    def __init__(self, max_rate):
        self.period = {topic: 1.0 / rate for topic, rate in max_rate.items() if rate > 0}
        self.last = {}

    def skip(self, topic, t):
        period = self.period.get(topic)
        if period is None:
            return False
        if t - self.last.get(topic, -1e18) < period:
            return True
        self.last[topic] = t
        return False


def _read_indexed(path, wanted, max_rate, unless):
    from rosbags.rosbag1 import Reader
    contents = BagContents(path=path)
    with Reader(path) as reader:
        store, failed = _typestore((c.msgtype, c.msgdef.data) for c in reader.connections)
        for topic, info in reader.topics.items():
            contents.counts[topic] = contents.counts.get(topic, 0) + info.msgcount
            contents.msgtypes[topic] = info.msgtype
        if failed:
            contents.problems.append("message definitions that could not be parsed: %s" % ", ".join(failed))
        present = {c.topic for c in reader.connections}
        connections = [c for c in reader.connections if (wanted is None or c.topic in wanted)
                       and unless.get(c.topic) not in present]
        if reader.message_count:
            contents.start_s, contents.end_s = reader.start_time * 1e-9, reader.end_time * 1e-9
        undecodable, thinning, decode = {}, _Thinning(max_rate), _Decoder(store)
        for connection, stamp, raw in (reader.messages(connections=connections) if connections else ()):
            if thinning.skip(connection.topic, stamp * 1e-9):
                continue
            try:
                message = decode(connection.topic, connection.msgtype, raw)
            except Exception:
                undecodable[connection.topic] = undecodable.get(connection.topic, 0) + 1
                continue
            contents.messages.setdefault(connection.topic, []).append((stamp * 1e-9, message))
        for topic, count in undecodable.items():
            contents.problems.append("%s: %d message(s) could not be decoded" % (topic, count))
    return contents


# ----------------------------------------------------------------------------------------------------
# Recovery: walk the records of the file without its index.

def _parse_header(buf):
    """Fields of a record header (bytes); raises ValueError when it is not a well-formed header."""
    fields, pos, end = {}, 0, len(buf)
    while pos < end:
        if pos + 4 > end:
            raise ValueError("header field length cut")
        (length,) = struct.unpack_from("<I", buf, pos)
        pos += 4
        if length == 0 or pos + length > end:
            raise ValueError("bad header field length")
        item = bytes(buf[pos:pos + length])
        pos += length
        name, sep, value = item.partition(b"=")
        if not sep:
            raise ValueError("header field without '='")
        fields[name.decode("ascii", "replace")] = value
    if "op" not in fields or len(fields["op"]) != 1:
        raise ValueError("header without op")
    return fields


def _records(buf, pos=0):
    """(header fields, data memoryview, offset after the record) of the records in ``buf`` from ``pos``;
    stops silently at a record cut by the end of ``buf``, raises ValueError at a malformed one."""
    view, end = memoryview(buf), len(buf)
    while pos + 4 <= end:
        (hlen,) = struct.unpack_from("<I", buf, pos)
        if hlen > 1 << 24:
            raise ValueError("implausible header length %d at byte %d" % (hlen, pos))
        if pos + 4 + hlen + 4 > end:
            return
        header = _parse_header(view[pos + 4:pos + 4 + hlen])
        (dlen,) = struct.unpack_from("<I", buf, pos + 4 + hlen)
        start = pos + 8 + hlen
        if start + dlen > end:
            return
        yield header, view[start:start + dlen], start + dlen
        pos = start + dlen


def _decompress(compression, data):
    """(decompressed bytes, complete?) of a chunk's data; a cut chunk yields what decodes."""
    if compression == b"none":
        return bytes(data), True
    if compression == b"lz4":
        import lz4.frame
        decompressor = lz4.frame.LZ4FrameDecompressor()
        out = decompressor.decompress(bytes(data))
        return out, decompressor.eof
    if compression == b"bz2":
        decompressor = bz2.BZ2Decompressor()
        out = decompressor.decompress(bytes(data))
        return out, decompressor.eof
    raise ValueError("unknown chunk compression %r" % compression)


def _resync(buf, pos):
    """Offset of the next plausible chunk record at or after ``pos``, or None."""
    lowest = pos
    while True:
        hit = buf.find(b"op=\x05", pos)
        if hit < 0:
            return None
        for start in range(max(lowest, hit - 200), hit):
            (hlen,) = struct.unpack_from("<I", buf, start)
            if hit < start + 4 + 4 or hlen > 400 or start + 4 + hlen > len(buf) or start + 4 + hlen < hit + 4:
                continue
            try:
                fields = _parse_header(memoryview(buf)[start + 4:start + 4 + hlen])
            except ValueError:
                continue
            if fields.get("op") == b"\x05" and "compression" in fields:
                return start
        pos = hit + 1


def _read_by_scanning(path, wanted, reason, max_rate, unless):
    with open(path, "rb") as stream:
        buf = stream.read()
    contents = BagContents(path=path)
    connections = {}        # conn id -> (topic, msgtype, msgdef)
    raw = []                # (conn id, time ns, bytes), in file order
    tally = {"whole": 0, "partial": 0}
    lost_regions = []       # (from byte, to byte, why)
    expected_chunks, index_pos, index_found = None, None, False

    def decode_chunk(header, data, complete_record):
        inner, complete = _decompress(header.get("compression", b"none"), data)
        got = 0
        for sub, subdata, _ in _records(inner):
            subop = sub["op"][0]
            if subop == OP_CONNECTION:
                _add_connection(connections, sub, subdata)
            elif subop == OP_MSGDATA:
                conn = struct.unpack("<I", sub["conn"])[0]
                sec, nsec = struct.unpack("<II", sub["time"])
                raw.append((conn, sec * 1000000000 + nsec, bytes(subdata)))
                got += 1
        if complete and complete_record:
            tally["whole"] += 1
        elif got:
            tally["partial"] += 1
        return got

    pos = len(MAGIC)
    while pos < len(buf):
        try:
            record = next(_records(buf, pos), None)
        except ValueError as err:
            nxt = _resync(buf, pos + 1)
            lost_regions.append((pos, nxt if nxt is not None else len(buf), "malformed record: %s" % err))
            if nxt is None:
                break
            pos = nxt
            continue
        if record is None:
            # The record runs past the end of the file: truncation, or a damaged length field.
            cut = _cut_chunk(buf, pos)
            if cut is not None:
                try:
                    decode_chunk(cut[0], cut[1], False)
                except Exception:
                    pass
            nxt = _resync(buf, pos + 1)
            lost_regions.append((pos, nxt if nxt is not None else len(buf),
                                 "record cut short by the end of the file" if nxt is None else
                                 "record cut short (damaged length)"))
            if nxt is None:
                break
            pos = nxt
            continue
        header, data, after = record
        op = header["op"][0]
        if op == OP_BAGHEADER:
            try:
                index_pos = struct.unpack("<Q", header["index_pos"])[0]
                expected_chunks = struct.unpack("<I", header["chunk_count"])[0]
            except (KeyError, struct.error):
                pass
        elif op == OP_CHUNK:
            try:
                decode_chunk(header, data, True)
            except Exception as err:  # corrupt chunk: skip it, keep going
                lost_regions.append((pos, after, "chunk does not decode: %s" % err))
        elif op == OP_CONNECTION:
            index_found = True
            _add_connection(connections, header, data)
        pos = after

    store, failed = _typestore((c[1], c[2]) for c in connections.values())
    undecodable, unknown_conn, times, thinning, decode = {}, 0, [], _Thinning(max_rate), _Decoder(store)
    raw.sort(key=lambda item: item[1])
    present = {info[0] for info in connections.values()}
    skip = {topic for topic, other in unless.items() if other in present}
    for conn, stamp, data in raw:
        info = connections.get(conn)
        if info is None:
            unknown_conn += 1
            continue
        topic, msgtype, _ = info
        times.append(stamp)
        contents.counts[topic] = contents.counts.get(topic, 0) + 1
        contents.msgtypes[topic] = msgtype
        if (wanted is not None and topic not in wanted) or topic in skip or thinning.skip(topic, stamp * 1e-9):
            continue
        try:
            message = decode(topic, msgtype, data)
        except Exception:
            undecodable[topic] = undecodable.get(topic, 0) + 1
            continue
        contents.messages.setdefault(topic, []).append((stamp * 1e-9, message))
    if times:
        contents.start_s, contents.end_s = min(times) * 1e-9, max(times) * 1e-9

    truncated = bool(index_pos) and len(buf) < index_pos
    problems = ["the bag's index could not be used (%s); read it again chunk by chunk" % reason]
    if truncated:
        problems.append("the file is truncated: it ends at byte %d, before its index at byte %d (%.0f %% of the "
                        "data present); everything recorded after the last readable message is lost"
                        % (len(buf), index_pos, 100.0 * len(buf) / index_pos))
    elif not index_found:
        problems.append("the bag has no index (recording not closed properly): its end may be missing")
    if tally["partial"]:
        problems.append("%d chunk(s) cut short and read only in part" % tally["partial"])
    if lost_regions:
        problems.append("%d unreadable region(s) skipped (%s)" % (
            len(lost_regions), "; ".join("bytes %d-%d: %s" % region for region in lost_regions[:5])))
    if expected_chunks:
        problems.append("%d of %d chunk(s) read whole" % (tally["whole"], expected_chunks))
    if times:
        problems.append("%d message(s) recovered, bag time %.2f-%.2f s" % (len(times), contents.start_s,
                                                                           contents.end_s))
    if unknown_conn:
        problems.append("%d message(s) dropped: their connection record was lost" % unknown_conn)
    if failed:
        problems.append("message definitions that could not be parsed: %s" % ", ".join(failed))
    for topic, count in undecodable.items():
        problems.append("%s: %d message(s) could not be decoded" % (topic, count))
    contents.problems.extend(problems)
    contents.integrity = {
        "status": "recovered" if times else "unreadable",
        "reader": "chunk scan (index unusable)",
        "reason": reason,
        "file_bytes": len(buf),
        "index_pos": index_pos,
        "truncated": truncated,
        "chunks_expected": expected_chunks,
        "chunks_read_whole": tally["whole"],
        "chunks_read_in_part": tally["partial"],
        "unreadable_regions": [{"from_byte": a, "to_byte": b, "why": why} for a, b, why in lost_regions],
        "messages_recovered": len(times),
        "messages_dropped_no_connection": unknown_conn,
        "time_range_recovered_s": [contents.start_s, contents.end_s] if times else None,
    }
    return contents


def _cut_chunk(buf, pos):
    """(header, data prefix) of a chunk record at ``pos`` whose data runs past the end of the file."""
    try:
        (hlen,) = struct.unpack_from("<I", buf, pos)
        if pos + 8 + hlen > len(buf):
            return None
        header = _parse_header(memoryview(buf)[pos + 4:pos + 4 + hlen])
    except (ValueError, struct.error):
        return None
    if header["op"][0] != OP_CHUNK:
        return None
    return header, memoryview(buf)[pos + 8 + hlen:]


def _add_connection(connections, header, data):
    try:
        conn = struct.unpack("<I", header["conn"])[0]
        topic = header["topic"].decode("utf-8", "replace")
        fields = _parse_fields(data)
    except (KeyError, struct.error):
        return
    msgtype = fields.get("type", b"").decode("utf-8", "replace")
    if not msgtype:
        return
    if "/msg/" not in msgtype and "/" in msgtype:
        package, name = msgtype.split("/", 1)
        msgtype = "%s/msg/%s" % (package, name)
    connections[conn] = (topic if topic.startswith("/") else "/" + topic, msgtype,
                         fields.get("message_definition", b"").decode("utf-8", "replace"))


def _parse_fields(buf):
    fields, pos, end = {}, 0, len(buf)
    while pos + 4 <= end:
        (length,) = struct.unpack_from("<I", buf, pos)
        pos += 4
        if pos + length > end:
            break
        name, _, value = bytes(buf[pos:pos + length]).partition(b"=")
        fields[name.decode("ascii", "replace")] = value
        pos += length
    return fields


# ----------------------------------------------------------------------------------------------------
# Fast decoding of the frequent fixed-layout messages (about 50x faster than the generic deserializer).
# Each is checked against rosbags on the first message of its topic and dropped if they disagree.

class Flat:
    """A fast-decoded message: ``kind`` (its msgtype), ``stamp`` (header stamp [s], 0 if unset), ``frame_id``
    and ``values`` (the numbers, in the order documented per kind in FAST_VALUES). Attribute access
    like a rosbags message works too (``m.pose.position.x``), built on demand."""

    __slots__ = ("kind", "stamp", "sec", "nsec", "frame_id", "values")

    def __init__(self, kind, head, values):
        self.kind, (self.sec, self.nsec, self.frame_id), self.values = kind, head, values
        self.stamp = self.sec + self.nsec * 1e-9

    def __getattr__(self, name):
        return getattr(_nested(self), name)


class _NS:
    def __init__(self, **fields):
        self.__dict__.update(fields)


def _nested(m):
    header = _NS(stamp=_NS(sec=m.sec, nanosec=m.nsec), frame_id=m.frame_id)
    v = m.values
    if m.kind == "geometry_msgs/msg/PointStamped":
        return _NS(header=header, point=_NS(x=v[0], y=v[1], z=v[2]))
    pose = _NS(position=_NS(x=v[0], y=v[1], z=v[2]), orientation=_NS(x=v[3], y=v[4], z=v[5], w=v[6]))
    if m.kind == "geometry_msgs/msg/PoseStamped":
        return _NS(header=header, pose=pose)
    if m.kind == "nav_msgs/msg/Path":
        return _NS(header=header, poses=[_NS(header=_NS(stamp=_NS(sec=p[0], nanosec=p[1]), frame_id=p[2]),
                                             pose=_NS(position=_NS(x=p[3], y=p[4], z=p[5]),
                                                      orientation=_NS(x=p[6], y=p[7], z=p[8], w=p[9])))
                                         for p in v])
    if m.kind == "nav_msgs/msg/Odometry":
        return _NS(header=header, pose=_NS(pose=pose), twist=_NS(twist=_NS(
            linear=_NS(x=v[7], y=v[8], z=v[9]), angular=_NS(x=v[10], y=v[11], z=v[12]))))
    out = _NS(header=header, state=int(v[0]))
    out.__dict__.update(zip(NAVDATA_FIELDS, v[1:]))
    return out


_HEAD = struct.Struct("<III")
_LEN = struct.Struct("<I")
_POSE = struct.Struct("<7d")
_POINT = struct.Struct("<3d")
_NAVDATA = struct.Struct("<B9f")
_TWIST = struct.Struct("<6d")
NAVDATA_FIELDS = ("battery_percent", "altitude", "vx", "vy", "vz", "rot_x", "rot_y", "rot_z", "motor_thrust")
FAST_VALUES = {"geometry_msgs/msg/PoseStamped": "x y z qx qy qz qw",
               "geometry_msgs/msg/PointStamped": "x y z",
               "nav_msgs/msg/Odometry": "x y z qx qy qz qw vx vy vz wx wy wz",
               "landing_msgs/msg/Navdata": "state " + " ".join(NAVDATA_FIELDS),
               "nav_msgs/msg/Path": "one tuple per pose: sec nsec frame_id x y z qx qy qz qw"}


def _header(raw):
    _, sec, nsec = _HEAD.unpack_from(raw, 0)
    (length,) = _LEN.unpack_from(raw, 12)
    return (sec, nsec, bytes(raw[16:16 + length]).decode("utf-8", "replace")), 16 + length


def _fast_pose_stamped(raw):
    head, pos = _header(raw)
    if len(raw) != pos + _POSE.size:
        raise ValueError("size")
    return Flat("geometry_msgs/msg/PoseStamped", head, _POSE.unpack_from(raw, pos))


def _fast_point_stamped(raw):
    head, pos = _header(raw)
    if len(raw) != pos + _POINT.size:
        raise ValueError("size")
    return Flat("geometry_msgs/msg/PointStamped", head, _POINT.unpack_from(raw, pos))


def _fast_navdata(raw):
    head, pos = _header(raw)
    if len(raw) < pos + _NAVDATA.size:
        raise ValueError("size")
    return Flat("landing_msgs/msg/Navdata", head, _NAVDATA.unpack_from(raw, pos))


def _fast_odometry(raw):
    head, pos = _header(raw)
    (length,) = _LEN.unpack_from(raw, pos)
    pos += 4 + length
    if len(raw) != pos + 8 * (7 + 36 + 6 + 36):
        raise ValueError("size")
    return Flat("nav_msgs/msg/Odometry", head, _POSE.unpack_from(raw, pos) + _TWIST.unpack_from(raw, pos + 8 * 43))


def _fast_path(raw):
    head, pos = _header(raw)
    (count,) = _LEN.unpack_from(raw, pos)
    pos += 4
    poses = []
    for _ in range(count):
        pose_head, size = _header(memoryview(raw)[pos:])
        poses.append(pose_head + _POSE.unpack_from(raw, pos + size))
        pos += size + _POSE.size
    if pos != len(raw):
        raise ValueError("size")
    return Flat("nav_msgs/msg/Path", head, poses)


FAST = {"nav_msgs/msg/Path": (_fast_path, ("header.stamp.sec", "header.stamp.nanosec", "poses.count",
                                           "poses.-1.header.stamp.sec", "poses.-1.header.stamp.nanosec",
                                           "poses.-1.pose.position.x", "poses.-1.pose.position.y",
                                           "poses.0.pose.position.x")),
        "geometry_msgs/msg/PoseStamped": (_fast_pose_stamped, ("header.stamp.sec", "header.stamp.nanosec",
                                                               "pose.position.x", "pose.position.y",
                                                               "pose.position.z", "pose.orientation.w")),
        "geometry_msgs/msg/PointStamped": (_fast_point_stamped, ("header.stamp.sec", "header.stamp.nanosec",
                                                                 "point.x", "point.y", "point.z")),
        "landing_msgs/msg/Navdata": (_fast_navdata, ("header.stamp.sec", "header.stamp.nanosec", "state")
                                     + NAVDATA_FIELDS),
        "nav_msgs/msg/Odometry": (_fast_odometry, ("header.stamp.sec", "header.stamp.nanosec", "pose.pose.position.x",
                                                   "pose.pose.position.y", "pose.pose.orientation.z",
                                                   "twist.twist.linear.x", "twist.twist.angular.z"))}


def _get(obj, dotted):
    for name in dotted.split("."):
        if name == "count":
            obj = len(obj)
        elif name.lstrip("-").isdigit():
            obj = obj[int(name)] if len(obj) else 0.0
        else:
            obj = getattr(obj, name)
    return obj


class _Decoder:
    """deserialize(topic, msgtype, raw): fast path when it agrees with rosbags, rosbags otherwise."""

    def __init__(self, store):
        self.store, self.fast = store, {}

    def __call__(self, topic, msgtype, raw):
        fast = self.fast.get(topic)
        if fast is None:
            fast = self.fast[topic] = self._check(msgtype, raw)
        if fast:
            try:
                return fast(raw)
            except (ValueError, struct.error):
                self.fast[topic] = False
        return self.store.deserialize_ros1(raw, msgtype)

    def _check(self, msgtype, raw):
        entry = FAST.get(msgtype)
        if entry is None:
            return False
        function, fields = entry
        try:
            reference = self.store.deserialize_ros1(raw, msgtype)
            mine = function(raw)
            for f in fields:
                a, b = float(_get(mine, f)), float(_get(reference, f))
                if not (a == b or (a != a and b != b) or abs(a - b) <= 1e-9 * max(1.0, abs(b))):
                    return False
            return function
        except Exception:
            pass
        return False
