"""Write ROS 2 bags with libraries advise did not write, for tests/bags.rs.

    bags.py WRITER SCENARIO OUT

WRITER is `rosbags` (a rosbag2 directory with MCAP storage, by the `rosbags` package),
`mcap-zstd` or `mcap-lz4` (one MCAP file, by `mcap-ros2-support`, chunks compressed so).
SCENARIO is `clean` (odometry at 50 Hz, commands at 20 Hz, 4 s), `messy` (the same, with
commands before the first odometry, a second without odometry, a duplicated command time and
messages written out of time order), `stamped` (commands as TwistStamped) or `idle` (TwistStamped
commands for 6 s: zero for the first second with the base standing still, driving until 4 s,
then zero with the base standing still where it stopped).

Besides the bag, OUT + ".expected.csv" is the log `time,x,y,theta,v,w` this script expects the
import to make: each kept command with the latest odometry at or before it, computed here on its
own, so the test compares advise's bag reader with an independent pairing.
"""

import math
import sys

from rosbags.typesys import Stores, get_typestore

TS = get_typestore(Stores.ROS2_HUMBLE)
T = TS.types
MAX_AGE_NS = 500_000_000


def pose_at(t):
    """The base's pose at t seconds: an arc."""
    if IDLE:
        t = min(max(t, 1.0), 4.0) - 1.0
    return 0.5 * t * math.cos(0.1 * t), 0.5 * t * math.sin(0.1 * t), 0.1 * t


IDLE = False


def twist(v, w):
    v3 = T['geometry_msgs/msg/Vector3']
    return T['geometry_msgs/msg/Twist'](linear=v3(x=v, y=0.0, z=0.0), angular=v3(x=0.0, y=0.0, z=w))


def header(t_ns, frame):
    time = T['builtin_interfaces/msg/Time'](sec=t_ns // 1_000_000_000, nanosec=t_ns % 1_000_000_000)
    return T['std_msgs/msg/Header'](stamp=time, frame_id=frame)


def odometry(t_ns):
    x, y, th = pose_at(t_ns * 1e-9)
    g = T
    pose = g['geometry_msgs/msg/Pose'](
        position=g['geometry_msgs/msg/Point'](x=x, y=y, z=0.0),
        orientation=g['geometry_msgs/msg/Quaternion'](x=0.0, y=0.0, z=math.sin(th / 2), w=math.cos(th / 2)),
    )
    import numpy as np

    cov = np.zeros(36, dtype=np.float64)
    return g['nav_msgs/msg/Odometry'](
        header=header(t_ns, 'odom'),
        child_frame_id='base_link',
        pose=g['geometry_msgs/msg/PoseWithCovariance'](pose=pose, covariance=cov),
        twist=g['geometry_msgs/msg/TwistWithCovariance'](twist=twist(0.5, 0.1), covariance=cov.copy()),
    )


def scenario(name):
    """The messages in the order they are written: (topic, t_ns, kind, payload)."""
    odom_times = [20_000_000 * k for k in range(0, 201)]
    cmd_times = [50_000_000 * k for k in range(0, 81)]
    if name == 'idle':
        odom_times = [20_000_000 * k for k in range(0, 301)]
        cmd_times = [50_000_000 * k for k in range(0, 121)]
    if name == 'messy':
        # Odometry starts late (commands before it are dropped) and stops for a second.
        odom_times = [t for t in odom_times if t >= 120_000_000 and not 2_000_000_000 <= t < 3_000_000_000]
        # A command repeated at the same time (the later one is kept: it says 0.25 m/s).
        cmd_times.insert(30, cmd_times[30])
    ns = ''
    if name == 'namespaced':
        # A robot's namespace, and a 2 s pause in the driving (odometry goes on).
        ns = '/robot1'
        cmd_times = [t for t in cmd_times if not 1_500_000_000 < t < 3_500_000_000]
    msgs = [(ns + '/odom', t, 'odom', None) for t in odom_times]
    for i, t in enumerate(cmd_times):
        v = 0.25 if name == 'messy' and i == 31 else 0.5
        w = 0.1
        if name == 'idle' and not 1_000_000_000 <= t < 4_000_000_000:
            v = w = 0.0
        kind = 'stamped' if name in ('stamped', 'idle') else 'twist'
        msgs.append((ns + '/cmd_vel', t, kind, (v, w)))
    msgs.sort(key=lambda m: m[1])
    if name == 'messy':
        # Five commands written a second late, as a reordering recorder would.
        late = [m for m in msgs if m[0].endswith('/cmd_vel')][10:15]
        msgs = [m for m in msgs if not any(m is l for l in late)]
        at = next(i for i, m in enumerate(msgs) if m[1] > late[-1][1] + 1_000_000_000)
        msgs[at:at] = late
    return msgs


def expected(msgs):
    """The log the import should make, computed independently of advise."""
    cmds = {}
    for topic, t, kind, payload in msgs:
        if topic.endswith('/cmd_vel'):
            cmds[t] = payload  # the later of equal times wins
    odoms = sorted(t for topic, t, _, _ in msgs if topic.endswith('/odom'))
    rows = []
    for t in sorted(cmds):
        before = [o for o in odoms if o <= t]
        if not before or t - before[-1] > MAX_AGE_NS:
            continue
        x, y, th = pose_at(before[-1] * 1e-9)
        v, w = cmds[t]
        rows.append((t * 1e-9, x, y, th, v, w))
    return rows


def message(kind, t_ns, payload):
    if kind == 'odom':
        return odometry(t_ns), 'nav_msgs/msg/Odometry'
    tw = twist(*payload)
    if kind == 'stamped':
        return T['geometry_msgs/msg/TwistStamped'](header=header(t_ns, 'base_link'), twist=tw), 'geometry_msgs/msg/TwistStamped'
    return tw, 'geometry_msgs/msg/Twist'


def write_rosbags(out, msgs):
    from rosbags.rosbag2 import StoragePlugin, Writer

    with Writer(out, version=8, storage_plugin=StoragePlugin.MCAP) as writer:
        conns = {}
        for topic, t, kind, payload in msgs:
            msg, typename = message(kind, t, payload)
            if topic not in conns:
                conns[topic] = writer.add_connection(topic, typename, typestore=TS)
            writer.write(conns[topic], t, TS.serialize_cdr(msg, typename))


def write_mcap(out, msgs, compression):
    from mcap.writer import CompressionType
    from mcap_ros2.writer import Writer

    with open(out, 'wb') as f:
        writer = Writer(f, chunk_size=4096, compression=getattr(CompressionType, compression))
        schemas = {}
        for topic, t, kind, payload in msgs:
            msg, typename = message(kind, t, payload)
            if typename not in schemas:
                msgdef, _ = TS.generate_msgdef(typename, ros_version=2)
                schemas[typename] = writer.register_msgdef(typename, msgdef)
            writer.write_message(topic, schemas[typename], to_dict(msg), log_time=t, publish_time=t)
        writer.finish()


def to_dict(msg):
    """A rosbags message as the plain dict mcap-ros2-support encodes."""
    if hasattr(msg, '__dataclass_fields__'):
        return {k: to_dict(getattr(msg, k)) for k in msg.__dataclass_fields__ if k != '__msgtype__'}
    if hasattr(msg, 'tolist'):
        return msg.tolist()
    return msg


def main():
    global IDLE
    writer, name, out = sys.argv[1:4]
    IDLE = name == 'idle'
    msgs = scenario(name)
    if writer == 'rosbags':
        write_rosbags(out, msgs)
    elif writer == 'mcap-zstd':
        write_mcap(out, msgs, 'ZSTD')
    elif writer == 'mcap-lz4':
        write_mcap(out, msgs, 'LZ4')
    else:
        raise SystemExit(f'unknown writer {writer}')
    with open(out + '.expected.csv', 'w') as f:
        f.write('time,x,y,theta,v,w\n')
        for row in expected(msgs):
            f.write(','.join(repr(v) for v in row) + '\n')


if __name__ == '__main__':
    main()
