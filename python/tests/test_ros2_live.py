"""The live ROS 2 bridge (`simserpent run --ros2`) against an independent DDS: Eclipse Cyclone DDS
(the `cyclonedds` Python bindings, which bundle the C library), with the ROS 2 message types
declared as IDL dataclasses here. The peer subscribes to /joint_states and /tf and drives the
snake in lockstep with a sine wave of joint positions on
/snake/forward_position_controller/commands; the angles it received equal the run's CSV, and
the joints follow the commanded sine wave.

Skipped (with the reason) only when the CLI found is not built with the `ros2` feature
(`cargo build --features ros2`) or `cyclonedds` is not installed, and only when
$SIMSERPENT_ROS2_BIN is not set: with it (CI's last step, `.ci/run`) either is an error.

Loopback only: both sides send every datagram, discovery and data, to 127.0.0.1. The simulator
runs with `ros2.interfaces = ["127.0.0.1"]` (RustDDS announces only 127.0.0.1 locators, finds
peers by unicast SPDP to 127.0.0.1 and, as Linux's `lo` has no MULTICAST flag, has no multicast
socket; SIMSERPENT_ROS2_INTERFACES overrides it, e.g. '[]' for every interface, which skips the
loopback test). Cyclone is limited to `lo`, multicast off, and finds the simulator by unicast to
127.0.0.1 (`cyclone_uri`); its only multicast datagram is one 16-byte probe to 239.255.0.1 out of
127.0.0.1 with TTL 0 when its participant starts, which never leaves the machine. The domain id is
random. Both still listen on wildcard-address (0.0.0.0) sockets, as RustDDS and Cyclone bind them.
`test_the_simulator_and_the_peer_send_only_to_loopback` checks this with strace (skipped if strace
is not installed): measured 534-545 datagrams from the simulator and 708 from the peer for a
200-step lockstep run, all to 127.0.0.1 but that probe; with `ros2.interfaces = []` the simulator
also sent 145 to this machine's eth0 address (192.0.2.2) and 91 to the multicast group 239.255.0.1
out of eth0.

The simulator's stdout and stderr go to files: an unread pipe fills (64 KiB) and then blocks
the simulator's next log line, including RustDDS's from its event loop thread, which stops all
DDS traffic. (That, with RustDDS's "No locators" warnings of `["127.0.0.1"]`, was why this file
failed with `["127.0.0.1"]` before; the CLI now shows RustDDS's errors only, src/main.rs.)

Run as a script (`python test_ros2_live.py STEPS`) it measures the lockstep round trip instead
(BENCHMARKS.md, "ROS 2 live bridge").
"""


import importlib
import json
import os
import random
import re
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from conftest import cli  # noqa: E402


def require(module: str, install: str):
    """`module`, or skip the tests — unless $SIMSERPENT_ROS2_BIN names the CLI to test (CI's last
    step): then a missing peer package is an error, so the interop test can never silently skip."""
    if not os.environ.get("SIMSERPENT_ROS2_BIN"):
        return pytest.importorskip(module, reason=install)
    try:
        return importlib.import_module(module)
    except ImportError as e:
        pytest.fail(
            f"SIMSERPENT_ROS2_BIN is set, so the live ROS 2 interop test must run, but {module!r} cannot be "
            f"imported ({e}): {install}",
            pytrace=False,
        )


cyclonedds = require("cyclonedds", "pip install cyclonedds==11.0.1 (python/requirements-dev.txt)")
from cyclonedds.core import Qos, Policy  # noqa: E402
from cyclonedds.domain import DomainParticipant  # noqa: E402
from cyclonedds.idl import IdlStruct  # noqa: E402
from cyclonedds.idl.types import array, float32, float64, int32, sequence, uint8, uint32, uint64  # noqa: E402
from cyclonedds.pub import DataWriter  # noqa: E402
from cyclonedds.sub import DataReader  # noqa: E402
from cyclonedds.topic import Topic  # noqa: E402
from cyclonedds.util import duration  # noqa: E402

pd = require("pandas", "pip install pandas (python/requirements-dev.txt)")


# ROS 2 message types as DDS sees them (rosidl's IDL: module <pkg>::msg, type name with
# `dds_::` and a trailing `_`). Field order and types as in ROS 2 Jazzy's common_interfaces.
@dataclass
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: int32
    nanosec: uint32


@dataclass
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time
    frame_id: str


@dataclass
class JointState(IdlStruct, typename="sensor_msgs::msg::dds_::JointState_"):
    header: Header
    name: sequence[str]
    position: sequence[float64]
    velocity: sequence[float64]
    effort: sequence[float64]


@dataclass
class Vector3(IdlStruct, typename="geometry_msgs::msg::dds_::Vector3_"):
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
class Transform(IdlStruct, typename="geometry_msgs::msg::dds_::Transform_"):
    translation: Vector3
    rotation: Quaternion


@dataclass
class TransformStamped(IdlStruct, typename="geometry_msgs::msg::dds_::TransformStamped_"):
    header: Header
    child_frame_id: str
    transform: Transform


@dataclass
class TFMessage(IdlStruct, typename="tf2_msgs::msg::dds_::TFMessage_"):
    transforms: sequence[TransformStamped]


@dataclass
class MultiArrayDimension(IdlStruct, typename="std_msgs::msg::dds_::MultiArrayDimension_"):
    label: str
    size: uint32
    stride: uint32


@dataclass
class MultiArrayLayout(IdlStruct, typename="std_msgs::msg::dds_::MultiArrayLayout_"):
    dim: sequence[MultiArrayDimension]
    data_offset: uint32


@dataclass
class Float64MultiArray(IdlStruct, typename="std_msgs::msg::dds_::Float64MultiArray_"):
    layout: MultiArrayLayout
    data: sequence[float64]


@dataclass
class JointTrajectoryPoint(IdlStruct, typename="trajectory_msgs::msg::dds_::JointTrajectoryPoint_"):
    positions: sequence[float64]
    velocities: sequence[float64]
    accelerations: sequence[float64]
    effort: sequence[float64]
    time_from_start: Time


@dataclass
class JointTrajectory(IdlStruct, typename="trajectory_msgs::msg::dds_::JointTrajectory_"):
    header: Header
    joint_names: sequence[str]
    points: sequence[JointTrajectoryPoint]


@dataclass
class Point(IdlStruct, typename="geometry_msgs::msg::dds_::Point_"):
    x: float64
    y: float64
    z: float64


@dataclass
class Wrench(IdlStruct, typename="geometry_msgs::msg::dds_::Wrench_"):
    force: Vector3
    torque: Vector3


@dataclass
class WrenchStamped(IdlStruct, typename="geometry_msgs::msg::dds_::WrenchStamped_"):
    header: Header
    wrench: Wrench


@dataclass
class Imu(IdlStruct, typename="sensor_msgs::msg::dds_::Imu_"):
    header: Header
    orientation: Quaternion
    orientation_covariance: array[float64, 9]
    angular_velocity: Vector3
    angular_velocity_covariance: array[float64, 9]
    linear_acceleration: Vector3
    linear_acceleration_covariance: array[float64, 9]


@dataclass
class String(IdlStruct, typename="std_msgs::msg::dds_::String_"):
    data: str


@dataclass
class UInt32(IdlStruct, typename="std_msgs::msg::dds_::UInt32_"):
    data: uint32


# ros_gz_interfaces (the Gazebo bridge's messages), as in ros_gz's ros_gz_interfaces/msg.
@dataclass
class Entity(IdlStruct, typename="ros_gz_interfaces::msg::dds_::Entity_"):
    id: uint64
    name: str
    type: uint8


@dataclass
class JointWrench(IdlStruct, typename="ros_gz_interfaces::msg::dds_::JointWrench_"):
    header: Header
    body_1_name: String
    body_1_id: UInt32
    body_2_name: String
    body_2_id: UInt32
    body_1_wrench: Wrench
    body_2_wrench: Wrench


@dataclass
class Contact(IdlStruct, typename="ros_gz_interfaces::msg::dds_::Contact_"):
    collision1: Entity
    collision2: Entity
    positions: sequence[Vector3]
    normals: sequence[Vector3]
    depths: sequence[float64]
    wrenches: sequence[JointWrench]


@dataclass
class Contacts(IdlStruct, typename="ros_gz_interfaces::msg::dds_::Contacts_"):
    header: Header
    contacts: sequence[Contact]


# SimSerpent's own message (ros2/simserpent_msgs/msg/ContactEstimates.msg).
@dataclass
class ContactEstimates(IdlStruct, typename="simserpent_msgs::msg::dds_::ContactEstimates_"):
    header: Header
    link_names: sequence[str]
    external_force: sequence[Vector3]
    floor_force: sequence[Vector3]
    obstacle_force: sequence[Vector3]
    contact: sequence[bool]
    contact_point_along: sequence[float64]
    contact_point: sequence[Point]
    self_contact_force: sequence[Vector3]
    self_contact: sequence[bool]


_ = float32  # (ColorRGBA etc. are not needed by the peer)

BRIDGE_BUILT = "live ROS 2 bridge (run --ros2): built in"


def ros2_cli() -> Path | None:
    """The CLI to test: $SIMSERPENT_ROS2_BIN, else the newest built one; None unless it has the bridge."""
    env = os.environ.get("SIMSERPENT_ROS2_BIN")
    binary = Path(env) if env else cli()
    if binary is None or not binary.is_file():
        return None
    out = subprocess.run([str(binary), "--version"], capture_output=True, text=True).stdout
    return binary if BRIDGE_BUILT in out else None


def cyclone_uri(domain: int) -> str:
    """Cyclone on the loopback interface only, finding peers by unicast on 127.0.0.1."""
    return (
        f'<CycloneDDS><Domain id="{domain}"><General><Interfaces>'
        '<NetworkInterface name="lo" multicast="false"/></Interfaces>'
        "<AllowMulticast>false</AllowMulticast></General>"
        "<Discovery><ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>20</MaxAutoParticipantIndex>"
        '<Peers><Peer address="127.0.0.1"/></Peers></Discovery></Domain></CycloneDDS>'
    )


def qos() -> Qos:
    # ros2.reliability = "reliable", durability "volatile", depth 10 (the defaults); plain CDR
    # (XCDR1), as ROS 2 and RustDDS use.
    return Qos(
        Policy.Reliability.Reliable(max_blocking_time=duration(seconds=1)),
        Policy.Durability.Volatile,
        Policy.History.KeepLast(10),
        Policy.DataRepresentation(use_cdrv0_representation=True),
    )


@dataclass
class Peer:
    """A lockstep ROS 2 controller: for each /joint_states it sends one position command."""

    domain: int
    # The default gait's wave ([gait.sine_wave]: 30 deg, 0.5 Hz, 40 deg phase lag per joint).
    amplitude_rad: float = float(np.radians(30.0))
    frequency_hz: float = 0.5
    phase_rad: float = float(np.radians(40.0))
    timestep_secs: float = 0.001
    received: list = field(default_factory=list)  # (stamp_ns, names, positions)
    tf: list = field(default_factory=list)  # (stamp_ns, [(child, translation, rotation)])
    commands: list = field(default_factory=list)  # (stamp_ns, data)
    round_trip_secs: list = field(default_factory=list)
    # Further topics to take, (ROS 2 topic, message type): subscribed before /joint_states.
    topics: tuple = ()
    # topic -> (reader, message type, [(stamp_ns, message)]), see `subscribe`.
    extra: dict = field(default_factory=dict)

    def __post_init__(self):
        self.participant = DomainParticipant(self.domain)
        for topic, message_type in self.topics:
            self.subscribe(topic, message_type)
        q = qos()
        self.joint_states = DataReader(self.participant, Topic(self.participant, "rt/joint_states", JointState, qos=q), qos=q)
        self.tf_reader = DataReader(self.participant, Topic(self.participant, "rt/tf", TFMessage, qos=q), qos=q)
        topic = Topic(self.participant, "rt/snake/forward_position_controller/commands", Float64MultiArray, qos=q)
        self.writer = DataWriter(self.participant, topic, qos=q)

    def subscribe(self, topic: str, message_type) -> None:
        """Take every sample of `topic` (ROS 2 name) as `message_type` into `self.extra[topic]`."""
        q = qos()
        reader = DataReader(self.participant, Topic(self.participant, "rt" + topic, message_type, qos=q), qos=q)
        self.extra[topic] = (reader, message_type, [])

    def take_extra(self) -> None:
        for reader, message_type, received in self.extra.values():
            for m in reader.take(N=100):
                if isinstance(m, message_type):  # not an InvalidSample (the writer went away)
                    received.append((m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec, m))

    def command(self, t_secs: float, n: int) -> list[float]:
        w = 2 * np.pi * self.frequency_hz
        return [self.amplitude_rad * np.sin(w * t_secs - j * self.phase_rad) for j in range(n)]

    def wait_matched(self, writer, process: subprocess.Popen, timeout_secs: float = 60) -> None:
        """Until `writer` has matched the run's reader (a volatile sample written before is lost)."""
        end = time.monotonic() + timeout_secs
        while not writer.get_matched_subscriptions() and process.poll() is None and time.monotonic() < end:
            time.sleep(0.01)

    def serve(self, process: subprocess.Popen, deadline_secs: float, send: bool = True) -> None:
        last_publish = None
        if send:
            self.wait_matched(self.writer, process)
        end = time.monotonic() + deadline_secs
        while process.poll() is None and time.monotonic() < end:
            for tf in self.tf_reader.take(N=100):
                if not isinstance(tf, TFMessage):
                    continue  # an InvalidSample (the writer went away)
                stamp = tf.transforms[0].header.stamp
                self.tf.append(
                    (
                        stamp.sec * 1_000_000_000 + stamp.nanosec,
                        [(t.child_frame_id, t.transform.translation, t.transform.rotation) for t in tf.transforms],
                    )
                )
            self.take_extra()
            samples = [s for s in self.joint_states.take(N=100) if isinstance(s, JointState)]
            if not samples:
                continue
            for js in samples:
                now = time.perf_counter()
                if last_publish is not None:
                    self.round_trip_secs.append(now - last_publish)
                stamp_ns = js.header.stamp.sec * 1_000_000_000 + js.header.stamp.nanosec
                self.received.append((stamp_ns, list(js.name), list(js.position)))
                if send:
                    # The answer to instant k acts from instant k + 1 (user guide, "ROS 2"): command
                    # the wave at t_k + dt.
                    data = self.command(stamp_ns * 1e-9 + self.timestep_secs, len(js.name))
                    self.commands.append((stamp_ns, data))
                    last_publish = time.perf_counter()
                    self.writer.write(Float64MultiArray(MultiArrayLayout([], 0), data))


# ros2.interfaces of the tests' runs (SIMSERPENT_ROS2_INTERFACES overrides it).
LOOPBACK = '["127.0.0.1"]'


def start_run(binary: Path, tmp: Path, domain: int, *sets: str, wrapper: tuple = ()) -> subprocess.Popen:
    args = [*wrapper, str(binary), "run", "--quiet", "--ros2"]
    base = [
        f'general.output_dir="{tmp}"',
        f"ros2.domain_id={domain}",
        "ros2.interfaces=" + os.environ.get("SIMSERPENT_ROS2_INTERFACES", LOOPBACK),
        'ros2.clock="lockstep"',
        "ros2.lockstep_timeout_secs=30",
        'control.method="position"',
        "recording.every_n_steps=1",
    ]
    for s in base + list(sets):
        args += ["--set", s]
    # Output to files, not pipes: nobody reads a pipe while the run goes on, and a full pipe
    # (64 KiB) blocks the simulator's next write to it, including RustDDS's logging from its
    # event loop thread, which then stops all DDS traffic.
    out, err = tmp / "simserpent.stdout", tmp / "simserpent.stderr"
    with out.open("w") as o, err.open("w") as e:
        process = subprocess.Popen(args, stdout=o, stderr=e, text=True)
    process.output_paths = (out, err)
    return process


@pytest.fixture
def binary():
    b = ros2_cli()
    env = os.environ.get("SIMSERPENT_ROS2_BIN")
    if b is None and env:
        pytest.fail(
            f"SIMSERPENT_ROS2_BIN = {env!r} is not a simserpent CLI built with the live ROS 2 bridge "
            "(cargo build --release --features ros2; `simserpent --version` says whether it is)",
            pytrace=False,
        )
    if b is None:
        pytest.skip(
            "no simserpent CLI built with the live ROS 2 bridge: cargo build --features ros2 "
            "(or set SIMSERPENT_ROS2_BIN)"
        )
    return b


@pytest.fixture
def domain(monkeypatch):
    d = random.randint(1, 200)
    monkeypatch.setenv("CYCLONEDDS_URI", cyclone_uri(d))
    return d


def finish(process: subprocess.Popen) -> tuple[str, str]:
    """Waits for the run (killed after 60 s); its stdout and stderr."""
    try:
        process.wait(timeout=60)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait()
    out, err = process.output_paths
    return out.read_text(), err.read_text()


def run_folder(tmp: Path) -> Path:
    (folder,) = [p for p in tmp.iterdir() if p.is_dir()]
    return folder


STRACE = shutil.which("strace")
# In strace's log: a datagram's destination (sin_addr=inet_addr("127.0.0.1") or
# sin6_addr=inet_pton(AF_INET6, "::1", ...)), and the multicast options of a socket.
DESTINATION = re.compile(r'sin_addr=inet_addr\("([^"]+)"\)|inet_pton\(AF_INET6, "([^"]+)"')
CALL = re.compile(r"^(\d+) +(sendto|sendmsg|sendmmsg|setsockopt)\((\d+), (.*)")


def strace_sends(output: Path) -> tuple:
    """strace logging every way to send a datagram (sendto, sendmsg, sendmmsg) and the socket
    options (the multicast interface and TTL) to `output`."""
    trace = "trace=sendto,sendmsg,sendmmsg,setsockopt"
    return (STRACE, "-f", "-qq", "-e", trace, "-e", "signal=none", "-o", str(output))


def ip_destinations(trace: Path) -> dict[str, int]:
    """How many datagrams went to each IP address, from a log of `strace_sends`. A multicast
    datagram counts as "loopback multicast" when its socket sends multicast out of 127.0.0.1 with
    TTL 0 (delivered on this machine only); sends to Unix sockets, netlink and socket pairs have
    no IP destination."""
    counts: dict[str, int] = {}
    multicast_if: dict[tuple, str] = {}  # (thread, fd) -> what IP_MULTICAST_IF / _TTL set
    multicast_ttl: dict[tuple, str] = {}
    for line in trace.read_text().splitlines():
        m = CALL.match(line)
        if m is None:
            continue
        tid, call, fd, rest = m.groups()
        key = (tid, fd)  # strace -f logs threads by id; a socket is set up and used by one thread here
        if call == "setsockopt":
            if "IP_MULTICAST_IF" in rest:
                multicast_if[key] = rest
            elif "IP_MULTICAST_TTL" in rest:
                multicast_ttl[key] = rest
            continue
        for v4, v6 in DESTINATION.findall(rest):
            address = v4 or v6
            if v4 and 224 <= int(v4.split(".")[0]) <= 239:
                # 16777343 = 127.0.0.1 as the int IP_MULTICAST_IF takes; "\0" = TTL 0.
                local = "127.0.0.1" in multicast_if.get(key, "") or "16777343" in multicast_if.get(key, "")
                if local and '"\\0"' in multicast_ttl.get(key, ""):
                    address = f"loopback multicast {v4}"
            counts[address] = counts.get(address, 0) + 1
    return counts


@pytest.mark.skipif(STRACE is None, reason="strace is not installed (it lists where the processes send datagrams)")
def test_the_simulator_and_the_peer_send_only_to_loopback(binary, domain, tmp_path):
    # "On loopback only": every datagram either side sends — discovery (SPDP, SEDP) and data —
    # goes to 127.0.0.1, none to another interface's address or to a multicast group. The
    # simulator runs under strace; the peer's process (Cyclone's threads in this process) is
    # traced from before its participant exists.
    if os.environ.get("SIMSERPENT_ROS2_INTERFACES", LOOPBACK) != LOOPBACK:
        pytest.skip(f"SIMSERPENT_ROS2_INTERFACES is not {LOOPBACK}")
    simulator_trace, peer_trace = tmp_path / "simserpent.strace", tmp_path / "peer.strace"
    # The simulator first: a process traced with -f cannot start another strace.
    process = start_run(
        binary, tmp_path, domain, "general.duration_secs=0.2", wrapper=strace_sends(simulator_trace)
    )
    tids = sorted(os.listdir(f"/proc/{os.getpid()}/task"))
    tracer = subprocess.Popen(
        [*strace_sends(peer_trace), *[a for t in tids for a in ("-p", t)]], stderr=subprocess.DEVNULL
    )
    try:
        end = time.monotonic() + 10
        while "TracerPid:\t0\n" in Path("/proc/self/status").read_text() and time.monotonic() < end:
            time.sleep(0.01)
        if "TracerPid:\t0\n" in Path("/proc/self/status").read_text():
            process.kill()
            pytest.skip("strace cannot attach to this process (ptrace not permitted)")
        peer = Peer(domain)
        peer.serve(process, deadline_secs=120)
        out, err = finish(process)
    finally:
        tracer.terminate()
        tracer.wait(timeout=30)
    assert process.returncode == 0, f"stdout:\n{out}\nstderr:\n{err}"
    assert len(peer.received) >= 200, "the peer got the states (so the traces hold the data traffic)"
    for who, trace in (("simulator", simulator_trace), ("peer", peer_trace)):
        destinations = ip_destinations(trace)
        print(f"{who}: datagrams per destination {destinations}")
        assert "127.0.0.1" in destinations, f"the {who}'s trace holds no datagram to 127.0.0.1"
        elsewhere = {a: n for a, n in destinations.items() if a != "127.0.0.1" and not a.startswith("loopback ")}
        assert not elsewhere, f"the {who} sent datagrams off loopback: {destinations}"


def test_a_cyclone_peer_drives_the_snake_in_lockstep(binary, domain, tmp_path):
    # Start on the wave, as the built-in gait without ramp does (initial_state.joint_angles_deg =
    # [] puts the joints at the gait's shape at t = 0); the peer's wave at t = 0, in degrees:
    start_deg = [round(float(30.0 * np.sin(-j * np.radians(40.0))), 12) for j in range(9)]
    process = start_run(
        binary, tmp_path, domain, "general.duration_secs=4.0", f"initial_state.joint_angles_deg={start_deg}"
    )
    peer = Peer(domain)
    peer.serve(process, deadline_secs=240)
    out, err = finish(process)
    assert process.returncode == 0, f"stdout:\n{out}\nstderr:\n{err}"
    folder = run_folder(tmp_path)
    manifest = json.loads((folder / "manifest.json").read_text())
    assert manifest["status"] == "complete"
    steps = manifest["steps"]
    assert steps == 4000
    report = manifest["ros2"]
    assert report["clock"] == "lockstep"
    # One command per step: every instant 0 .. steps-1 waited for one, the peer answered each.
    # The first state may have been resent until answered (user guide, "ROS 2", "Clock modes"): the
    # peer answers every copy it got, and the answers to the extra copies count for instant 0.
    copies = next(i for i, (s, _, _) in enumerate(peer.received) if s != 0)
    assert 1 <= copies <= 1 + report["lockstep_state_resends"]
    assert report["lockstep_extra_answers"] == copies - 1
    assert report["lockstep_commands"] == steps
    assert report["commands_accepted"] == steps + copies - 1
    assert all(report[k] == 0 for k in report if k.startswith("rejected_"))

    # The peer's joint angles are the run's, at every instant (CSV floats round-trip exactly).
    sensors = pd.read_csv(folder / "sensors.csv")
    names = sorted({c[:8] for c in sensors.columns if c.startswith("joint_") and c.endswith("_encoder_measured_rad")})
    stamps = np.rint(sensors["time_s"].to_numpy() * 1e9).astype(np.int64)
    received = peer.received[copies - 1 :]
    assert [s for s, _, _ in received] == list(stamps), "one /joint_states per instant, in order"
    for k, (_, js_names, positions) in enumerate(received):
        assert js_names == names
        assert positions == [sensors.iloc[k][f"{j}_encoder_measured_rad"] for j in names]

    # /tf: world -> every link, equal to links.csv's orientation at its instant.
    links = pd.read_csv(folder / "links.csv")
    link_names = sorted({c[:7] for c in links.columns if c.startswith("link_")})
    assert len(peer.tf) > 0.9 * len(links), f"{len(peer.tf)} /tf of {len(links)} instants"
    by_stamp = {s: i for i, s in enumerate(np.rint(links["time_s"].to_numpy() * 1e9).astype(np.int64))}
    for stamp_ns, frames in peer.tf:
        row = links.iloc[by_stamp[stamp_ns]]
        assert [f[0] for f in frames] == link_names
        for name, _, q in frames:
            assert [q.w, q.x, q.y, q.z] == [row[f"{name}_orientation_q{a}"] for a in "wxyz"]

    # The joints follow the commanded sine wave as they follow the built-in gait of the same wave
    # ([gait.sine_wave] defaults, no ramp): the same run without ROS 2. Only instant 0 differs
    # (the bridge holds zero until the first answer; the gait starts on the wave).
    reference = tmp_path / "gait"
    subprocess.run(
        [str(binary), "run", "--quiet", "--set", f'general.output_dir="{reference}"', "--set",
         'control.controller="gait"', "--set", "gait.ramp_secs=0", "--set", "general.duration_secs=4.0",
         "--set", "recording.every_n_steps=1"],
        check=True, capture_output=True,
    )
    gait = pd.read_csv(run_folder(reference) / "joints.csv")
    joints = pd.read_csv(folder / "joints.csv")
    cols = [f"{j}_angle_rad" for j in names]
    ros, ref = joints[cols].to_numpy(), gait[cols].to_numpy()
    assert ros.shape == ref.shape
    a = peer.amplitude_rad
    deviation = np.abs(ros - ref).max()
    tail = slice(steps - 2000, steps)  # the last period
    amp_ros = (ros[tail].max(axis=0) - ros[tail].min(axis=0)) / 2
    amp_ref = (ref[tail].max(axis=0) - ref[tail].min(axis=0)) / 2
    print(f"max |ROS run - gait run| = {deviation:.3e} rad; amplitudes {amp_ros / a} vs {amp_ref / a}")
    assert deviation < 0.01 * a, f"the ROS-driven joints deviate from the gait's by {deviation} rad"


def stamps_ns(table) -> np.ndarray:
    return np.rint(table["time_s"].to_numpy() * 1e9).astype(np.int64)


def xyz(v) -> list[float]:
    return [v.x, v.y, v.z]


def check_received(what: str, received: list, instants: int) -> None:
    """Each instant at most once, in order, and (each topic is discovered on its own, so the first
    instants may be missed) at least 90 % of them."""
    stamps = [s for s, _ in received]
    assert stamps == sorted(set(stamps)), f"{what}: instants repeated or out of order"
    assert len(stamps) >= 0.9 * instants, f"{what}: {len(stamps)} of {instants} instants"


def test_the_peer_decodes_the_force_torque_imu_and_contact_topics(binary, domain, tmp_path):
    # A lockstep run with the estimator on: the peer takes every joint's force/torque sensor
    # (WrenchStamped), every link's IMU (Imu), the true contacts (ros_gz_interfaces/Contacts) and
    # the contact estimates (simserpent_msgs/ContactEstimates) with its own type declarations, and
    # every value equals the run's tables at the instant of its stamp; the bag's messages of these
    # topics, decoded from the bag's embedded schemas, equal what the peer received.
    n_links = 10
    joints = [f"joint_{j:02}" for j in range(1, n_links)]
    links = [f"link_{i:02}" for i in range(n_links)]
    topics = (
        [(f"/snake/{j}/wrench", WrenchStamped) for j in joints]
        + [(f"/snake/{link}/imu", Imu) for link in links]
        + [("/snake/ground_truth/contacts", Contacts), ("/snake/contact_estimates", ContactEstimates)]
    )
    process = start_run(
        binary,
        tmp_path,
        domain,
        "general.duration_secs=0.3",
        "estimation.enabled=true",
        "sensors.noise_enabled=true",
        'recording.format=["csv", "mcap"]',
    )
    peer = Peer(domain, topics=tuple(topics))
    peer.serve(process, deadline_secs=240)
    out, err = finish(process)
    peer.take_extra()  # what arrived after the last command
    assert process.returncode == 0, f"stdout:\n{out}\nstderr:\n{err}"
    folder = run_folder(tmp_path)
    steps = json.loads((folder / "manifest.json").read_text())["steps"]
    assert steps == 300
    instants = steps + 1
    received = {topic: r for topic, (_, _, r) in peer.extra.items()}
    counts = sorted({len(r) for r in received.values()})
    print(f"instants received per topic: {counts[0]}..{counts[-1]} of {instants}")

    # Force/torque sensors and IMUs: the measured columns of sensors.csv.
    sensors = pd.read_csv(folder / "sensors.csv")
    row_of = {s: i for i, s in enumerate(stamps_ns(sensors))}
    assert len(row_of) == instants
    for j in joints:
        topic = f"/snake/{j}/wrench"
        check_received(topic, received[topic], instants)
        for stamp, m in received[topic]:
            row = sensors.iloc[row_of[stamp]]
            child = "link_" + j.split("_")[1]
            assert m.header.frame_id == child, "the child link's frame"
            assert xyz(m.wrench.force) == [row[f"{j}_force_sensor_measured_{a}_n"] for a in "xyz"]
            assert xyz(m.wrench.torque) == [row[f"{j}_torque_sensor_measured_{a}_nm"] for a in "xyz"]
    for link in links:
        topic = f"/snake/{link}/imu"
        check_received(topic, received[topic], instants)
        for stamp, m in received[topic]:
            row = sensors.iloc[row_of[stamp]]
            assert m.header.frame_id == link
            assert xyz(m.angular_velocity) == [row[f"{link}_gyro_measured_{a}_rad_per_s"] for a in "xyz"]
            assert xyz(m.linear_acceleration) == [row[f"{link}_accelerometer_measured_{a}_m_per_s2"] for a in "xyz"]
            # The IMU's framequat as measured (noise on), with its covariance.
            q = m.orientation
            assert [q.x, q.y, q.z, q.w] == [row[f"{link}_orientation_measured_q{a}"] for a in "xyzw"]
            # Noise on: diagonal covariances, the configured variance.
            for cov in (m.orientation_covariance, m.angular_velocity_covariance, m.linear_acceleration_covariance):
                assert cov[0] == cov[4] == cov[8] > 0 and cov[1] == cov[2] == cov[3] == cov[5] == cov[6] == cov[7] == 0

    # True contacts: contacts.csv, row for row at each instant.
    contacts = pd.read_csv(folder / "contacts.csv")
    by_instant = {s: g for s, g in contacts.groupby(stamps_ns(contacts))}
    topic = "/snake/ground_truth/contacts"
    check_received(topic, received[topic], instants)
    total = 0
    for stamp, m in received[topic]:
        assert m.header.frame_id == "world"
        rows = by_instant.get(stamp)
        assert len(m.contacts) == (0 if rows is None else len(rows))
        for c, (_, row) in zip(m.contacts, [] if rows is None else rows.iterrows()):
            assert (c.collision1.name, c.collision2.name) == (row["geom1"], row["geom2"])
            assert c.collision1.type == c.collision2.type == 5  # Entity.COLLISION
            assert [xyz(p) for p in c.positions] == [[row[f"position_{a}_m"] for a in "xyz"]]
            assert [xyz(n) for n in c.normals] == [[row[f"normal_{a}"] for a in "xyz"]]
            assert list(c.depths) == [-row["distance_m"]]
            (w,) = c.wrenches
            assert (w.body_1_name.data, w.body_2_name.data) == (row["body1"], row["body2"])
            f2 = [row[f"force_on_geom2_{a}_n"] for a in "xyz"]
            assert xyz(w.body_2_wrench.force) == f2
            assert xyz(w.body_1_wrench.force) == [-v for v in f2]
            total += 1
    assert total > len(received[topic]), "the snake lies on the floor: several contacts per instant"

    # Contact estimates: estimates.csv.
    estimates = pd.read_csv(folder / "estimates.csv")
    row_of = {s: i for i, s in enumerate(stamps_ns(estimates))}
    topic = "/snake/contact_estimates"
    check_received(topic, received[topic], instants)
    support = 0.0
    for stamp, m in received[topic]:
        row = estimates.iloc[row_of[stamp]]
        assert m.header.frame_id == "world" and list(m.link_names) == links
        for i, link in enumerate(links):
            for name, values in (
                ("external_force", m.external_force),
                ("floor_force", m.floor_force),
                ("obstacle_force", m.obstacle_force),
            ):
                assert xyz(values[i]) == [row[f"{link}_estimated_{name}_{a}_n"] for a in "xyz"], (stamp, link, name)
            assert float(m.contact[i]) == row[f"{link}_estimated_contact"]
            along = row[f"{link}_estimated_point_along_m"]  # NaN when none, as in the message
            assert np.isnan(m.contact_point_along[i]) == np.isnan(along)
            if not np.isnan(along):
                assert m.contact_point_along[i] == along
            support += m.floor_force[i].z
    assert support > 0, "the estimated floor support is not zero"

    # The bag holds the same messages, decoded from its own schemas (mcap-ros2-support).
    mcap_reader = require("mcap.reader", "pip install mcap (python/requirements-dev.txt)")
    mcap_ros2_decoder = require("mcap_ros2.decoder", "pip install mcap-ros2-support (python/requirements-dev.txt)")
    bag: dict = {}
    with open(folder / "run.mcap", "rb") as f:
        reader = mcap_reader.make_reader(f, decoder_factories=[mcap_ros2_decoder.DecoderFactory()])
        for schema, channel, message, msg in reader.iter_decoded_messages(topics=[t for t, _ in topics]):
            assert schema.encoding == "ros2msg" and channel.message_encoding == "cdr"
            bag.setdefault(channel.topic, {})[message.log_time] = msg
    assert sorted(bag) == sorted(t for t, _ in topics)
    for topic, live in received.items():
        assert len(bag[topic]) == instants, topic
        for stamp, m in live:
            b = bag[topic][stamp]
            if topic.endswith("/wrench"):
                assert xyz(b.wrench.force) == xyz(m.wrench.force) and xyz(b.wrench.torque) == xyz(m.wrench.torque)
            elif topic.endswith("/imu"):
                assert xyz(b.angular_velocity) == xyz(m.angular_velocity)
                assert list(b.orientation_covariance) == list(m.orientation_covariance)
            elif topic.endswith("/contacts"):
                assert [(c.collision1.name, c.collision2.name, c.depths[0]) for c in b.contacts] == [
                    (c.collision1.name, c.collision2.name, c.depths[0]) for c in m.contacts
                ]
                assert [xyz(c.wrenches[0].body_2_wrench.force) for c in b.contacts] == [
                    xyz(c.wrenches[0].body_2_wrench.force) for c in m.contacts
                ]
            else:
                assert [xyz(v) for v in b.external_force] == [xyz(v) for v in m.external_force]
                assert list(b.contact) == list(m.contact)


def test_a_silent_peer_stops_the_lockstep_run_cleanly(binary, domain, tmp_path):
    # The peer answers 300 instants, then disappears: the run stops after the timeout, the
    # manifest says why, and the tables hold every instant up to then.
    process = start_run(binary, tmp_path, domain, "general.duration_secs=2.0", "ros2.lockstep_timeout_secs=8")
    peer = Peer(domain)
    end = time.monotonic() + 60
    while process.poll() is None and len(peer.received) < 300 and time.monotonic() < end:
        peer.serve(process, deadline_secs=0.05)
    # Silent from here on: serve without sending (the run waits, then stops).
    peer.serve(process, deadline_secs=30, send=False)
    out, err = finish(process)
    assert process.returncode == 1, f"stdout:\n{out}\nstderr:\n{err}"
    assert "no valid command within" in err
    folder = run_folder(tmp_path)
    manifest = json.loads((folder / "manifest.json").read_text())
    assert manifest["status"] == "incomplete"
    assert "ros2.lockstep_timeout_secs" in manifest["error"]
    assert "no valid command within 8." in manifest["error"], "the configured timeout, not another"
    assert manifest["ros2"]["stopped"] == manifest["error"]
    answered = manifest["ros2"]["lockstep_commands"]
    assert answered >= 300
    sensors = pd.read_csv(folder / "sensors.csv")
    # Every step taken is in the table (instants 0 ..= steps), whole rows.
    assert len(sensors) == manifest["steps"] + 1
    assert not sensors.isna().any().any()


def test_a_lockstep_run_without_a_peer_stops_before_its_first_step(binary, domain, tmp_path):
    # Nobody subscribes to /joint_states: after ros2.lockstep_timeout_secs the run stops, exit
    # 1, and the manifest says why (no step taken).
    started = time.monotonic()
    process = start_run(binary, tmp_path, domain, "general.duration_secs=1.0", "ros2.lockstep_timeout_secs=3")
    out, err = finish(process)
    waited_secs = time.monotonic() - started
    assert process.returncode == 1, f"stdout:\n{out}\nstderr:\n{err}"
    assert "no subscriber to /joint_states appeared within 3." in err
    if "RUST_LOG" not in os.environ:
        # RustDDS's warnings are off by default (src/main.rs, DEFAULT_LOG_FILTER): with
        # ros2.interfaces = ["127.0.0.1"] it logs "No locators" dozens of times a second.
        assert "rustdds" not in err, err[:3000]
    assert waited_secs >= 3.0
    manifest = json.loads((run_folder(tmp_path) / "manifest.json").read_text())
    assert manifest["status"] == "incomplete"
    assert manifest["steps"] == 0
    assert f"ROS_DOMAIN_ID = {domain}" in manifest["error"]
    assert manifest["ros2"]["stopped"] == manifest["error"]
    assert manifest["ros2"]["published_instants"] == 0


def test_a_slow_first_answer_is_not_taken_for_the_next_instant(binary, domain, tmp_path):
    # Until the first command, the bridge publishes the first state again every 0.25 s (a peer's
    # reader that learnt of the bridge's writer only after the first sample never gets it;
    # user guide, "ROS 2", "Clock modes"). A peer that answers late receives several copies and,
    # not looking at stamps, answers each: the extra answers still belong to instant 0, and
    # every later instant gets exactly one command.
    process = start_run(binary, tmp_path, domain, "general.duration_secs=0.2")
    peer = Peer(domain)
    peer.wait_matched(peer.writer, process)
    first: list = []
    end = time.monotonic() + 60
    while not first and process.poll() is None and time.monotonic() < end:
        first = [s for s in peer.joint_states.take(N=100) if isinstance(s, JointState)]
    time.sleep(0.8)  # silent: the bridge sends the state of instant 0 again (at least twice)
    first += [s for s in peer.joint_states.take(N=100) if isinstance(s, JointState)]
    stamps_ns = [js.header.stamp.sec * 1_000_000_000 + js.header.stamp.nanosec for js in first]
    assert stamps_ns and set(stamps_ns) == {0}, stamps_ns
    assert len(first) >= 3, f"{len(first)} copies of the first state reached the peer"
    for js in first:
        peer.writer.write(Float64MultiArray(MultiArrayLayout([], 0), peer.command(peer.timestep_secs, len(js.name))))
    peer.serve(process, deadline_secs=120)
    out, err = finish(process)
    assert process.returncode == 0, f"stdout:\n{out}\nstderr:\n{err}"
    folder = run_folder(tmp_path)
    manifest = json.loads((folder / "manifest.json").read_text())
    steps = manifest["steps"]
    assert steps == 200
    report = manifest["ros2"]
    assert report["lockstep_state_resends"] >= 2
    assert report["lockstep_commands"] == steps
    assert report["lockstep_extra_answers"] == len(first) - 1
    assert report["commands_accepted"] == steps + len(first) - 1
    sensors = pd.read_csv(folder / "sensors.csv")
    stamps = np.rint(sensors["time_s"].to_numpy() * 1e9).astype(np.int64)
    assert [s for s, _, _ in peer.received] == list(stamps[1:]), "every later instant once, in order"


def test_malformed_commands_are_counted_and_the_last_valid_one_holds(binary, domain, tmp_path):
    # Free clock: a valid command, then bad ones; the run completes, the manifest counts them,
    # and the joints hold the valid command.
    process = start_run(
        binary,
        tmp_path,
        domain,
        "general.duration_secs=3.0",
        'ros2.clock="free"',
        "ros2.real_time_factor=1.0",
        'recording.format=["csv", "mcap"]',
    )
    peer = Peer(domain)
    q = qos()
    topic = Topic(peer.participant, "rt/snake/joint_trajectory_controller/joint_trajectory", JointTrajectory, qos=q)
    trajectory = DataWriter(peer.participant, topic, qos=q)
    velocity = DataWriter(
        peer.participant,
        Topic(peer.participant, "rt/snake/forward_velocity_controller/commands", Float64MultiArray, qos=q),
        qos=q,
    )
    # Wait for the run's first state (discovery done both ways, as the bridge publishes).
    end = time.monotonic() + 60
    while not peer.received and time.monotonic() < end:
        peer.serve(process, deadline_secs=0.05, send=False)
    n = len(peer.received[0][1])
    valid = [0.2] * n
    layout = MultiArrayLayout([], 0)
    for w in (peer.writer, trajectory, velocity):
        peer.wait_matched(w, process)
    peer.writer.write(Float64MultiArray(layout, valid))
    time.sleep(0.2)
    peer.writer.write(Float64MultiArray(layout, valid[:-1]))  # wrong length
    peer.writer.write(Float64MultiArray(layout, valid + [0.0]))  # wrong length
    peer.writer.write(Float64MultiArray(layout, [float("nan")] + valid[1:]))  # NaN
    peer.writer.write(Float64MultiArray(layout, [float("inf")] + valid[1:]))  # inf
    velocity.write(Float64MultiArray(layout, [0.0] * n))  # wrong interface
    point = JointTrajectoryPoint([1.0], [], [], [], Time(1, 0))
    trajectory.write(JointTrajectory(Header(Time(0, 0), ""), ["joint_99"], [point]))  # unknown joint
    peer.serve(process, deadline_secs=60, send=False)
    out, err = finish(process)
    assert process.returncode == 0, f"stdout:\n{out}\nstderr:\n{err}"
    assert "ROS 2 command rejected" in err
    folder = run_folder(tmp_path)
    report = json.loads((folder / "manifest.json").read_text())["ros2"]
    assert report["commands_accepted"] == 1
    assert report["rejected_wrong_length"] == 2
    assert report["rejected_not_finite"] == 2
    assert report["rejected_wrong_interface"] == 1
    assert report["rejected_unknown_joint"] == 1
    # The command applied at every instant (the bag's command topic): zero until the valid one,
    # then exactly it to the end — never a partial, NaN or out-of-interface command.
    mcap_reader = require("mcap.reader", "pip install mcap (python/requirements-dev.txt)")
    mcap_ros2_decoder = require("mcap_ros2.decoder", "pip install mcap-ros2-support (python/requirements-dev.txt)")
    applied = []
    with open(folder / "run.mcap", "rb") as f:
        reader = mcap_reader.make_reader(f, decoder_factories=[mcap_ros2_decoder.DecoderFactory()])
        for _, _, _, msg in reader.iter_decoded_messages(topics=["/snake/forward_position_controller/commands"]):
            applied.append(list(msg.data))
    assert applied[-1] == valid
    first = applied.index(valid)
    assert all(c == [0.0] * n for c in applied[:first]) and all(c == valid for c in applied[first:])


def measure(steps: int) -> None:
    """Lockstep round trip over `steps` steps: the peer's time from sending a command to receiving
    the next /joint_states (the simulator takes the command, steps once, publishes)."""
    binary = ros2_cli()
    if binary is None:
        raise SystemExit("no simserpent CLI with the ros2 feature (set SIMSERPENT_ROS2_BIN)")
    import tempfile

    domain = random.randint(1, 200)
    os.environ["CYCLONEDDS_URI"] = cyclone_uri(domain)
    with tempfile.TemporaryDirectory() as tmp:
        process = start_run(
            binary, Path(tmp), domain, f"general.duration_secs={steps * 0.001}", 'recording.format="csv"'
        )
        peer = Peer(domain)
        peer.serve(process, deadline_secs=3600)
        finish(process)
        rt = np.array(peer.round_trip_secs) * 1e3
        print(
            f"{len(rt)} round trips: median {np.median(rt):.3f} ms, p99 {np.percentile(rt, 99):.3f} ms, "
            f"max {rt.max():.3f} ms (exit {process.returncode})"
        )


if __name__ == "__main__":
    measure(int(sys.argv[1]) if len(sys.argv) > 1 else 10_000)
