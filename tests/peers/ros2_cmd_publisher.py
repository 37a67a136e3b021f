#!/usr/bin/env python3
"""A ROS 2 teleoperation driver played by Cyclone DDS, for testing `advise ros2-sim` as a base.

It publishes `--speed` m/s on `rt/<ns>/cmd_vel` at 20 Hz with `--qos` (reliable or best-effort)
for `--drive` seconds, then stops publishing at once (as a driver that exits mid-run), and reads
`rt/<ns>/odom` throughout, appending `t_s speed_mps frame_id child_frame_id` for every odometry
message to `--log` and `# stopped T` when it stopped publishing. Bounded by `--lifetime` seconds.
"""

import argparse
import sys
import time

from cyclonedds.core import Qos, Policy
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from ros2_robot import Odometry, Twist, topic_name, twist


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--namespace", default="/")
    ap.add_argument("--log", required=True)
    ap.add_argument("--qos", choices=["reliable", "best-effort"], default="reliable")
    ap.add_argument("--speed", type=float, default=0.5)
    ap.add_argument("--drive", type=float, default=3.0)
    ap.add_argument("--lifetime", type=float, default=8.0)
    args = ap.parse_args()

    dp = DomainParticipant(0)
    reliable = Qos(Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=100)),
                   Policy.History.KeepLast(10))
    best_effort = Qos(Policy.Reliability.BestEffort, Policy.History.KeepLast(10))
    cmd_topic = Topic(dp, topic_name(args.namespace, "cmd_vel"), Twist)
    odom_topic = Topic(dp, topic_name(args.namespace, "odom"), Odometry)
    writer = DataWriter(dp, cmd_topic, qos=reliable if args.qos == "reliable" else best_effort)
    reader = DataReader(dp, odom_topic, qos=best_effort)
    log = open(args.log, "a", buffering=1)
    t0 = time.monotonic()
    print("ready", flush=True)
    stopped = False
    next_cmd = t0
    while time.monotonic() - t0 < args.lifetime:
        now = time.monotonic()
        if now - t0 < args.drive:
            if now >= next_cmd:
                writer.write(twist(args.speed, 0.0))
                next_cmd = now + 0.05
        elif not stopped:
            stopped = True
            log.write(f"# stopped {now - t0:.4f}\n")
        for o in reader.take(N=100):
            if isinstance(o, Odometry):
                log.write(f"{now - t0:.4f} {o.twist.twist.linear.x!r} "
                          f"{o.header.frame_id} {o.child_frame_id}\n")
        time.sleep(0.005)
    print("done", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
