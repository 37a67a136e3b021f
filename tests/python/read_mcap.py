"""Read an MCAP file with two readers advise did not write, for tests/bags.rs.

    read_mcap.py FILE

Prints JSON: the profile, and per topic the messages as mcap-ros2-support decodes them
(`/cmd_vel`: [log time ns, linear.x, angular.z]; `/odom`: [log time ns, x, y, yaw, frame,
child frame]; `/tf` and `/tf_static`: [log time ns, x, y, yaw, frame, child frame, stamp ns] of
each transform; strings: [log time ns, data]), the metadata records, the summary's statistics and
channels as `mcap info` shows them, and what rosbags reads (each topic's type and message count,
every message deserialized).
"""

import json
import math
import sys

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore


def main():
    path = sys.argv[1]
    out = {'topics': {}, 'rosbags': {}}
    with open(path, 'rb') as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        out['profile'] = reader.get_header().profile
        for schema, channel, message, m in reader.iter_decoded_messages():
            rows = out['topics'].setdefault(channel.topic, [])
            if channel.topic == '/cmd_vel':
                rows.append([message.log_time, m.linear.x, m.angular.z])
            elif channel.topic in ('/tf', '/tf_static'):
                for t in m.transforms:
                    q = t.transform.rotation
                    yaw = math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))
                    p = t.transform.translation
                    s = t.header.stamp
                    rows.append([message.log_time, p.x, p.y, yaw, t.header.frame_id,
                                 t.child_frame_id, s.sec * 1_000_000_000 + s.nanosec])
            elif channel.topic == '/odom':
                q = m.pose.pose.orientation
                yaw = math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))
                p = m.pose.pose.position
                rows.append([message.log_time, p.x, p.y, yaw, m.header.frame_id, m.child_frame_id])
            else:
                rows.append([message.log_time, m.data])
        out['metadata'] = {m.name: dict(m.metadata) for m in reader.iter_metadata()}
        summary = reader.get_summary()
        st = summary.statistics
        out['summary'] = {
            'start': st.message_start_time,
            'end': st.message_end_time,
            'messages': st.message_count,
            'channels': sorted(
                [c.topic, summary.schemas[c.schema_id].name, st.channel_message_counts.get(c.id, 0)]
                for c in summary.channels.values()
            ),
        }
    ts = get_typestore(Stores.ROS2_HUMBLE)
    with Reader(path) as bag:
        for conn, _, raw in bag.messages():
            ts.deserialize_cdr(raw, conn.msgtype)
            entry = out['rosbags'].setdefault(conn.topic, [conn.msgtype, 0])
            entry[1] += 1
    json.dump(out, sys.stdout)


if __name__ == '__main__':
    main()
