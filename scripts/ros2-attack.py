#!/usr/bin/env python3
"""Attacks the live ROS 2 bridge (`simserpent run --ros2`) from a hostile Cyclone DDS peer and
prints one line of figures per attack (RELIABILITY.md, "live ROS 2 bridge"):

- malformed commands: wrong length, NaN, inf, 1e308, empty, unknown trajectory joints, a
  trajectory with no points — each answered in lockstep before one valid command;
- oversized commands: a Float64MultiArray of 1 M and 10 M values (8 and 80 MB);
- a flood: 20,000 commands as fast as the peer can write them during a free-running run;
- a peer that vanishes in the middle of a lockstep run.

For each: the run's exit code, how long it took, its peak memory (from /proc), the manifest's
status and its ROS 2 report (commands accepted and rejected by reason, why it stopped).

Needs a CLI built with the bridge (`cargo build --features ros2`; $SIMSERPENT_ROS2_BIN or the
newest under $CARGO_TARGET_DIR) and `cyclonedds` (python/requirements-dev.txt). Loopback only,
as python/tests/test_ros2_live.py (whose message types and peer set-up it uses).

    python scripts/ros2-attack.py [ATTACK ...]     # malformed oversized flood vanish (default: all)
"""

import json
import os
import random
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "python" / "tests"))

import test_ros2_live as live  # noqa: E402
from cyclonedds.domain import DomainParticipant  # noqa: E402
from cyclonedds.pub import DataWriter  # noqa: E402
from cyclonedds.sub import DataReader  # noqa: E402
from cyclonedds.topic import Topic  # noqa: E402


def peak_kb(pid: int, stop: threading.Event, out: list) -> None:
    """Samples the process's VmHWM (peak resident memory) until `stop`."""
    while not stop.is_set():
        try:
            for line in Path(f"/proc/{pid}/status").read_text().splitlines():
                if line.startswith("VmHWM:"):
                    out[0] = max(out[0], int(line.split()[1]))
        except OSError:
            return
        time.sleep(0.05)


class Hostile:
    """A peer: reads /joint_states, writes position commands and trajectories."""

    def __init__(self, domain: int):
        self.participant = DomainParticipant(domain)
        q = live.qos()
        p = self.participant
        self.joint_states = DataReader(p, Topic(p, "rt/joint_states", live.JointState, qos=q), qos=q)
        self.writer = DataWriter(
            p, Topic(p, "rt/snake/forward_position_controller/commands", live.Float64MultiArray, qos=q), qos=q
        )
        self.trajectory = DataWriter(
            p,
            Topic(p, "rt/snake/joint_trajectory_controller/joint_trajectory", live.JointTrajectory, qos=q),
            qos=q,
        )

    def array(self, data) -> None:
        self.writer.write(live.Float64MultiArray(live.MultiArrayLayout([], 0), list(data)))

    def states(self):
        return [s for s in self.joint_states.take(N=100) if isinstance(s, live.JointState)]


def run(attack, *sets: str) -> str:
    binary = live.ros2_cli()
    if binary is None:
        sys.exit("no simserpent CLI built with the live ROS 2 bridge (cargo build --features ros2)")
    domain = random.randint(1, 200)
    os.environ["CYCLONEDDS_URI"] = live.cyclone_uri(domain)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        started = time.monotonic()
        process = live.start_run(binary, tmp, domain, *sets)
        stop, peak = threading.Event(), [0]
        sampler = threading.Thread(target=peak_kb, args=(process.pid, stop, peak))
        sampler.start()
        peer = Hostile(domain)
        note = attack(peer, process)
        try:
            process.wait(timeout=120)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
            note += "; KILLED after 120 s"
        stop.set()
        sampler.join()
        secs = time.monotonic() - started
        err = process.output_paths[1].read_text()
        folders = [p for p in tmp.iterdir() if p.is_dir()]
        manifest = json.loads((folders[0] / "manifest.json").read_text()) if folders else {}
        report = manifest.get("ros2") or {}
        counts = {k: v for k, v in report.items() if k.startswith(("rejected", "commands", "lockstep")) and v}
        last = err.strip().splitlines()[-1][:160] if err.strip() else ""
        return (
            f"exit {process.returncode} in {secs:.1f} s, peak {peak[0] / 1024:.0f} MB, "
            f"status {manifest.get('status')}, {counts}, stopped: {report.get('stopped')}; {note}; stderr: {last}"
        )


def answer_each_state(peer: Hostile, process, answers, deadline_secs: float = 60) -> int:
    """In lockstep: answers the k-th state with answers(k, n_joints) (a list of commands)."""
    peer_writer = peer.writer
    end = time.monotonic() + 60
    while not peer_writer.get_matched_subscriptions() and process.poll() is None and time.monotonic() < end:
        time.sleep(0.01)
    k = 0
    end = time.monotonic() + deadline_secs
    while process.poll() is None and time.monotonic() < end:
        for js in peer.states():
            for command in answers(k, len(js.name)):
                command()
            k += 1
        time.sleep(0.0005)
    return k


def malformed(peer: Hostile, process) -> str:
    bad = [
        lambda n: peer.array([0.0] * (n - 1)),
        lambda n: peer.array([0.0] * (n + 5)),
        lambda n: peer.array([]),
        lambda n: peer.array([float("nan")] * n),
        lambda n: peer.array([float("inf")] * n),
        lambda n: peer.array([1e308] * n),
        lambda n: peer.trajectory.write(
            live.JointTrajectory(live.Header(live.Time(0, 0), ""), ["no_such_joint"], [])
        ),
        lambda n: peer.trajectory.write(
            live.JointTrajectory(live.Header(live.Time(0, 0), ""), [f"joint_{j + 1:02}" for j in range(n)], [])
        ),
    ]

    def answers(k, n):
        return [lambda b=b: b(n) for b in bad] + [lambda: peer.array([0.0] * n)]

    states = answer_each_state(peer, process, answers)
    return f"{states} states answered with {len(bad)} malformed commands then 1 valid"


def oversized(peer: Hostile, process) -> str:
    sizes = [1_000_000, 10_000_000]

    def answers(k, n):
        if k < len(sizes):
            return [lambda s=sizes[k]: peer.array([0.0] * s), lambda: peer.array([0.0] * n)]
        return [lambda: peer.array([0.0] * n)]

    states = answer_each_state(peer, process, answers)
    return f"{states} states; the first two answered with {sizes} values, then a valid one"


def flood(peer: Hostile, process) -> str:
    end = time.monotonic() + 60
    while not peer.writer.get_matched_subscriptions() and process.poll() is None and time.monotonic() < end:
        time.sleep(0.01)
    sent, t0 = 0, time.monotonic()
    while process.poll() is None and sent < 20_000:
        peer.array([0.1] * 9)
        sent += 1
    return f"{sent} commands written in {time.monotonic() - t0:.1f} s"


def vanish(peer: Hostile, process) -> str:
    states = answer_each_state(peer, process, lambda k, n: [lambda: peer.array([0.0] * n)], deadline_secs=1.0)
    peer.participant = None
    peer.writer = peer.trajectory = peer.joint_states = None
    return f"the peer answered {states} states, then vanished (participant closed)"


ATTACKS = {
    "malformed": (malformed, ["general.duration_secs=0.05", "ros2.lockstep_timeout_secs=10"]),
    "oversized": (oversized, ["general.duration_secs=0.02", "ros2.lockstep_timeout_secs=20"]),
    "flood": (flood, ['ros2.clock="free"', "general.duration_secs=2"]),
    "vanish": (vanish, ["general.duration_secs=20", "ros2.lockstep_timeout_secs=3"]),
}

if __name__ == "__main__":
    for name in sys.argv[1:] or list(ATTACKS):
        attack, sets = ATTACKS[name]
        print(f"figures: ros2 {name}: {run(attack, *sets)}", flush=True)
