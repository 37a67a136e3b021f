#!/usr/bin/env python3
"""A ROS 2 mobile base played by Cyclone DDS, for testing `advise --backend ros2` against a DDS
implementation this project did not write.

It speaks ROS 2's wire names without ROS: `rt/<ns>/cmd_vel` carrying
`geometry_msgs::msg::dds_::Twist_` in, `rt/<ns>/odom` carrying `nav_msgs::msg::dds_::Odometry_` out.
As a robot it integrates the newest command (a unicycle, no lag) into odometry published at 50 Hz
and appends every command it receives to `--log` (`t_s v w`, one line each, flushed). With
`--teleop` it also plays a person at a keyboard: after `--teleop-delay` seconds it publishes a
scripted sequence of commands on cmd_vel (and drives by them), then zero, then prints `done`
(as TwistStamped in frame `base_link` with `--cmd-type stamped`). With `--teleop-topic TOPIC`
the person publishes the script as Twist on that topic instead, at 20 Hz, and then falls silent
(a joystick's deadman released), while the robot drives by what `cmd_vel` says.
Everything is bounded by `--lifetime` seconds.
"""

import argparse
import math
import sys
import time
from dataclasses import dataclass

from cyclonedds.core import Qos, Policy
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import array, float64, int32, uint32
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration


@dataclass
class Vector3(IdlStruct, typename="geometry_msgs::msg::dds_::Vector3_"):
    x: float64
    y: float64
    z: float64


@dataclass
class Twist(IdlStruct, typename="geometry_msgs::msg::dds_::Twist_"):
    linear: Vector3
    angular: Vector3


@dataclass
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: int32
    nanosec: uint32


@dataclass
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time
    frame_id: str


@dataclass
class TwistStamped(IdlStruct, typename="geometry_msgs::msg::dds_::TwistStamped_"):
    header: Header
    twist: Twist


@dataclass
class Point(IdlStruct, typename="geometry_msgs::msg::dds_::Point_"):
    x: float64
    y: float64
    z: float64


@dataclass
class Quaternion(IdlStruct, typename="geometry_msgs::msg::dds_::Quaternion_"):
    x: float64
    y: float64
    z: float64
    w: float64


@dataclass
class Pose(IdlStruct, typename="geometry_msgs::msg::dds_::Pose_"):
    position: Point
    orientation: Quaternion


@dataclass
class PoseWithCovariance(IdlStruct, typename="geometry_msgs::msg::dds_::PoseWithCovariance_"):
    pose: Pose
    covariance: array[float64, 36]


@dataclass
class TwistWithCovariance(IdlStruct, typename="geometry_msgs::msg::dds_::TwistWithCovariance_"):
    twist: Twist
    covariance: array[float64, 36]


@dataclass
class Odometry(IdlStruct, typename="nav_msgs::msg::dds_::Odometry_"):
    header: Header
    child_frame_id: str
    pose: PoseWithCovariance
    twist: TwistWithCovariance


def twist(v, w):
    return Twist(Vector3(v, 0.0, 0.0), Vector3(0.0, 0.0, w))


def topic_name(ns, name):
    ns = ns.strip("/")
    return f"rt/{ns}/{name}" if ns else f"rt/{name}"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--namespace", default="/")
    ap.add_argument("--domain", type=int, default=0)
    ap.add_argument("--log", required=True, help="file to append received commands to")
    ap.add_argument("--odom-qos", choices=["reliable", "best-effort"], default="best-effort")
    ap.add_argument("--odom-stop-after", type=float, default=None,
                    help="stop publishing odometry this long after the first non-zero command")
    ap.add_argument("--odom-bad-after", type=float, default=None,
                    help="publish corrupt odometry this long after the first non-zero command")
    ap.add_argument("--odom-bad-value", default="nan",
                    help="the corrupt odometry's x: nan, inf, a number, or `jump` (x + 50 m)")
    ap.add_argument("--cmd-type", choices=["twist", "stamped"], default="twist",
                    help="what the base reads on cmd_vel: Twist, or TwistStamped (Jazzy's default)")
    ap.add_argument("--cmd-durability", choices=["volatile", "transient-local"],
                    default="volatile", help="the durability the cmd_vel reader asks for")
    ap.add_argument("--frame-id", default="odom")
    ap.add_argument("--child-frame-id", default="base_link")
    ap.add_argument("--teleop", default=None,
                    help="script `v,w,seconds;v,w,seconds;...` published on cmd_vel")
    ap.add_argument("--teleop-delay", type=float, default=3.0)
    ap.add_argument("--teleop-topic", default=None,
                    help="publish the teleoperation there (Twist, 20 Hz), then fall silent")
    ap.add_argument("--lifetime", type=float, default=60.0)
    args = ap.parse_args()

    dp = DomainParticipant(args.domain)
    reliable = Qos(Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=100)),
                   Policy.History.KeepLast(10))
    odom_qos = reliable if args.odom_qos == "reliable" else Qos(
        Policy.Reliability.BestEffort, Policy.History.KeepLast(10))
    cmd_type = TwistStamped if args.cmd_type == "stamped" else Twist
    cmd_topic = Topic(dp, topic_name(args.namespace, "cmd_vel"), cmd_type)
    odom_topic = Topic(dp, topic_name(args.namespace, "odom"), Odometry)
    cmd_qos = reliable if args.cmd_durability == "volatile" else Qos(
        Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=100)),
        Policy.History.KeepLast(10), Policy.Durability.TransientLocal)
    reader = DataReader(dp, cmd_topic, qos=cmd_qos)
    odom_writer = DataWriter(dp, odom_topic, qos=odom_qos)
    teleop_writer = DataWriter(dp, cmd_topic, qos=reliable) if args.teleop else None
    if args.teleop and args.teleop_topic:
        teleop_topic = Topic(dp, topic_name(args.namespace, args.teleop_topic.lstrip("/")), Twist)
        teleop_writer = DataWriter(dp, teleop_topic, qos=reliable)
    next_teleop = 0.0

    script = []
    if args.teleop:
        for part in args.teleop.split(";"):
            v, w, s = (float(x) for x in part.split(","))
            script.append((v, w, s))

    log = open(args.log, "a", buffering=1)
    t0 = time.monotonic()
    x = y = th = 0.0
    v = w = 0.0
    first_motion = None
    bad_since = None
    last = t0
    print("ready", flush=True)
    done = False
    while time.monotonic() - t0 < args.lifetime:
        now = time.monotonic()
        for sample in reader.take(N=100):
            frame = ""
            if isinstance(sample, TwistStamped):
                frame = sample.header.frame_id
                sample = sample.twist
            if not isinstance(sample, Twist):
                continue
            log.write(f"{now - t0:.4f} {sample.linear.x!r} {sample.angular.z!r} {frame}\n")
            if args.teleop is None or args.teleop_topic:
                v, w = sample.linear.x, sample.angular.z
            if (sample.linear.x != 0.0 or sample.angular.z != 0.0) and first_motion is None:
                first_motion = now
        if teleop_writer is not None:
            elapsed = now - t0 - args.teleop_delay
            cmd = None
            if elapsed >= 0:
                for sv, sw, ss in script:
                    if elapsed < ss:
                        cmd = (sv, sw)
                        break
                    elapsed -= ss
                in_script = cmd is not None
                if cmd is None:
                    cmd = (0.0, 0.0)
                    if elapsed > 1.0 and not done:
                        print("done", flush=True)
                        done = True
                if args.teleop_topic:
                    # A person on a joystick: commands at 20 Hz while the script lasts, then none.
                    if in_script and now >= next_teleop:
                        teleop_writer.write(twist(*cmd))
                        log.write(f"# teleop {now - t0:.4f} {cmd[0]!r} {cmd[1]!r}\n")
                        next_teleop = now + 0.05
                elif args.cmd_type == "stamped":
                    # Jazzy's teleop_twist_keyboard with stamped:=true.
                    wall = time.time()
                    teleop_writer.write(TwistStamped(
                        header=Header(stamp=Time(int(wall), int((wall % 1) * 1e9)),
                                      frame_id="base_link"),
                        twist=twist(*cmd)))
                else:
                    teleop_writer.write(twist(*cmd))
                if not args.teleop_topic:
                    v, w = cmd
        dt = now - last
        last = now
        th_mid = th + 0.5 * w * dt
        x += v * dt * math.cos(th_mid)
        y += v * dt * math.sin(th_mid)
        th = math.atan2(math.sin(th + w * dt), math.cos(th + w * dt))
        stopped = (args.odom_stop_after is not None and first_motion is not None
                   and now - first_motion > args.odom_stop_after)
        bad = (args.odom_bad_after is not None and first_motion is not None
               and now - first_motion > args.odom_bad_after)
        x_out = x
        if bad:
            if bad_since is None:
                bad_since = time.monotonic()
                # The time the first corrupt sample is published, on the log's clock.
                log.write(f"# bad {bad_since - t0:.4f}\n")
            v_bad = args.odom_bad_value
            x_out = x + 50.0 if v_bad == "jump" else float(v_bad)
        if not stopped:
            wall = time.time()
            odom_writer.write(Odometry(
                header=Header(stamp=Time(int(wall), int((wall % 1) * 1e9)),
                              frame_id=args.frame_id),
                child_frame_id=args.child_frame_id,
                pose=PoseWithCovariance(
                    pose=Pose(Point(x_out, y, 0.0),
                              Quaternion(0.0, 0.0, math.sin(th / 2), math.cos(th / 2))),
                    covariance=[0.0] * 36),
                twist=TwistWithCovariance(twist=twist(v, w), covariance=[0.0] * 36),
            ))
        time.sleep(max(0.0, 0.02 - (time.monotonic() - now)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
