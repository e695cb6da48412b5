"""The ROS 2 bag of a run (recording.format with "mcap") read by two independent readers:
Foxglove's `mcap` + `mcap-ros2-support`, and `rosbags`. Every message decodes, and its values
equal the run's CSV tables (the same numbers, not approximately: CSV floats round-trip).

Needs the `simserpent` CLI built (`cargo build`); skipped without it or without the readers.
"""

import subprocess
from pathlib import Path

import numpy as np
import pytest

from conftest import cli

pd = pytest.importorskip("pandas")
mcap_reader = pytest.importorskip("mcap.reader")
mcap_ros2_decoder = pytest.importorskip("mcap_ros2.decoder")
rosbags_highlevel = pytest.importorskip("rosbags.highlevel")


def run(tmp: Path, *sets: str) -> Path:
    binary = cli()
    if binary is None:
        pytest.skip("build the CLI first: cargo build")
    args = [str(binary), "run", "--quiet", "--set", f'general.output_dir="{tmp}"', "--set", "general.duration_secs=0.5"]
    args += ["--set", 'recording.format=["csv", "mcap"]']
    for s in sets:
        args += ["--set", s]
    subprocess.run(args, check=True, capture_output=True)
    (folder,) = [p for p in tmp.iterdir() if p.is_dir()]
    return folder


def read_mcap(path: Path):
    """{topic: [(log_time_ns, message)]} with mcap + mcap-ros2-support."""
    out = {}
    with open(path, "rb") as f:
        reader = mcap_reader.make_reader(f, decoder_factories=[mcap_ros2_decoder.DecoderFactory()])
        summary = reader.get_summary()
        assert summary is not None, "the bag has a summary (it was finished)"
        assert reader.get_header().profile == "ros2"
        for schema, channel, message, decoded in reader.iter_decoded_messages():
            assert schema.encoding == "ros2msg" and channel.message_encoding == "cdr"
            out.setdefault(channel.topic, []).append((message.log_time, decoded))
    return out, summary


def read_rosbags(path: Path):
    """{topic: [(timestamp_ns, message)]} with rosbags (its own CDR and .msg parsers)."""
    out = {}
    with rosbags_highlevel.AnyReader([path]) as reader:
        for connection, timestamp, raw in reader.messages():
            out.setdefault(connection.topic, []).append((timestamp, reader.deserialize(raw, connection.msgtype)))
    return out


def xyz(v):
    return [v.x, v.y, v.z]


def quat_wxyz(q):
    return [q.w, q.x, q.y, q.z]


def rotation(q):
    w, x, y, z = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def check_against_csv(folder: Path, topics, noise_std):
    links = pd.read_csv(folder / "links.csv")
    joints = pd.read_csv(folder / "joints.csv")
    sensors = pd.read_csv(folder / "sensors.csv")
    contacts = pd.read_csv(folder / "contacts.csv")
    n = len(links)
    link_names = sorted({c[:7] for c in links.columns if c.startswith("link_")})
    joint_names = sorted({c[:8] for c in joints.columns if c.startswith("joint_")})
    stamps = np.rint(links["time_s"].to_numpy() * 1e9).astype(np.int64)

    expected = {"/clock", "/joint_states", "/tf", "/snake/ground_truth/joint_states", "/snake/contacts"}
    expected |= {"/snake/ground_truth/contacts", "/snake/ground_truth/contact_forces"}
    estimates = folder / "estimates.csv"
    if estimates.exists():
        expected |= {"/snake/contact_estimates"}
    expected |= {"/snake/forward_position_controller/commands"}
    expected |= {f"/snake/{j}/wrench" for j in joint_names}
    expected |= {f"/snake/{name}/{kind}" for name in link_names for kind in ("imu", "contact_wrench")}
    assert set(topics) == expected
    for topic, messages in topics.items():
        assert [t for t, _ in messages] == list(stamps), f"{topic}: one message per recorded instant, simulated time"

    def stamp_ns(header):
        return header.stamp.sec * 1_000_000_000 + header.stamp.nanosec

    for k, (t, clock) in enumerate(topics["/clock"]):
        assert clock.clock.sec * 1_000_000_000 + clock.clock.nanosec == stamps[k]

    for k, (_, js) in enumerate(topics["/joint_states"]):
        row = sensors.iloc[k]
        assert stamp_ns(js.header) == stamps[k]
        assert list(js.name) == joint_names
        assert list(js.position) == [row[f"{j}_encoder_measured_rad"] for j in joint_names]
        assert list(js.velocity) == [row[f"{j}_encoder_velocity_measured_rad_per_s"] for j in joint_names]
        assert list(js.effort) == [row[f"{j}_actuator_torque_measured_nm"] for j in joint_names]

    for k, (_, js) in enumerate(topics["/snake/ground_truth/joint_states"]):
        row = joints.iloc[k]
        assert list(js.position) == [row[f"{j}_angle_rad"] for j in joint_names]
        assert list(js.velocity) == [row[f"{j}_velocity_rad_per_s"] for j in joint_names]

    # /tf: world -> every link; the rotation is the link's orientation; the centre of mass sits at
    # a fixed point of each link's frame (a rigid body), so the frame origin is consistent with it.
    offsets = {name: [] for name in link_names}
    for k, (_, tf) in enumerate(topics["/tf"]):
        row = links.iloc[k]
        assert [t.child_frame_id for t in tf.transforms] == link_names
        for t in tf.transforms:
            name = t.child_frame_id
            assert t.header.frame_id == "world" and stamp_ns(t.header) == stamps[k]
            q = quat_wxyz(t.transform.rotation)
            assert q == [row[f"{name}_orientation_q{a}"] for a in "wxyz"]
            com = np.array([row[f"{name}_position_{a}_m"] for a in "xyz"])
            offsets[name].append(rotation(q).T @ (com - np.array(xyz(t.transform.translation))))
    for name, o in offsets.items():
        o = np.array(o)
        assert np.abs(o - o[0]).max() < 1e-9, f"{name}: centre of mass fixed in the link frame"
        assert 0.0 < np.linalg.norm(o[0]) < 1.0

    for name in link_names:
        for k, (_, imu) in enumerate(topics[f"/snake/{name}/imu"]):
            row = sensors.iloc[k]
            assert imu.header.frame_id == name
            assert xyz(imu.angular_velocity) == [row[f"{name}_gyro_measured_{a}_rad_per_s"] for a in "xyz"]
            assert xyz(imu.linear_acceleration) == [row[f"{name}_accelerometer_measured_{a}_m_per_s2"] for a in "xyz"]
            # The IMU's framequat (the link's orientation: links.csv's without noise), measured.
            q = [row[f"{name}_orientation_measured_q{a}"] for a in "xyzw"]
            assert [imu.orientation.x, imu.orientation.y, imu.orientation.z, imu.orientation.w] == q
            if not noise_std["gyro"]:
                lq = links.iloc[k]
                # The same rotation (q and -q are one orientation) up to one step's turn: the IMU's
                # sample is the sensors' latest, one step older (sensor_time_s).
                dot = abs(np.dot(q, [lq[f"{name}_orientation_q{a}"] for a in "xyzw"]))
                assert 2.0 * np.arccos(min(1.0, dot)) < 0.01  # rad: one 1-ms step at up to 10 rad/s
            orientation_var = noise_std["orientation"] ** 2
            assert list(imu.orientation_covariance) == [orientation_var, 0, 0, 0, orientation_var, 0, 0, 0, orientation_var]
            gyro_var, accel_var = noise_std["gyro"] ** 2, noise_std["accelerometer"] ** 2
            assert list(imu.angular_velocity_covariance) == [gyro_var, 0, 0, 0, gyro_var, 0, 0, 0, gyro_var]
            assert list(imu.linear_acceleration_covariance) == [accel_var, 0, 0, 0, accel_var, 0, 0, 0, accel_var]
        for k, (_, w) in enumerate(topics[f"/snake/{name}/contact_wrench"]):
            row = links.iloc[k]
            assert w.header.frame_id == "world"
            assert xyz(w.wrench.force) == [row[f"{name}_contact_force_{a}_n"] for a in "xyz"]
            assert xyz(w.wrench.torque) == [row[f"{name}_contact_torque_{a}_nm"] for a in "xyz"]

    for j in joint_names:
        for k, (_, w) in enumerate(topics[f"/snake/{j}/wrench"]):
            row = sensors.iloc[k]
            assert w.header.frame_id == j.replace("joint_", "link_")
            assert xyz(w.wrench.force) == [row[f"{j}_force_sensor_measured_{a}_n"] for a in "xyz"]
            assert xyz(w.wrench.torque) == [row[f"{j}_torque_sensor_measured_{a}_nm"] for a in "xyz"]

    for _, cmd in topics["/snake/forward_position_controller/commands"]:
        assert len(cmd.data) == len(joint_names) and np.isfinite(cmd.data).all()

    by_step = contacts.groupby("time_s")
    seen_contacts = 0
    for k, (_, markers) in enumerate(topics["/snake/contacts"]):
        first, *arrows = markers.markers
        assert first.action == 3, "DELETEALL first"
        t = links["time_s"].iloc[k]
        rows = by_step.get_group(t) if t in by_step.groups else contacts.iloc[0:0]
        assert len(arrows) == len(rows)
        for arrow, (_, c) in zip(arrows, rows.iterrows()):
            assert arrow.type == 0 and arrow.action == 0 and arrow.header.frame_id == "world"
            start, tip = arrow.points
            p = [c[f"position_{a}_m"] for a in "xyz"]
            f = np.array([c[f"force_on_geom2_{a}_n"] for a in "xyz"])
            assert xyz(start) == p
            assert np.allclose(np.array(xyz(tip)) - p, 0.01 * f, rtol=0, atol=1e-12)
            seen_contacts += 1
    assert seen_contacts > 0, "the snake touches the floor"

    # ros_gz_interfaces/Contacts: one Contact per row of contacts.csv, in order.
    seen = 0
    for k, (_, msg) in enumerate(topics["/snake/ground_truth/contacts"]):
        assert msg.header.frame_id == "world" and stamp_ns(msg.header) == stamps[k]
        t = links["time_s"].iloc[k]
        rows = by_step.get_group(t) if t in by_step.groups else contacts.iloc[0:0]
        assert len(msg.contacts) == len(rows)
        for c, (_, row) in zip(msg.contacts, rows.iterrows()):
            assert (c.collision1.name, c.collision2.name) == (row["geom1"], row["geom2"])
            assert c.collision1.type == c.collision2.type == 5  # COLLISION
            assert [xyz(p) for p in c.positions] == [[row[f"position_{a}_m"] for a in "xyz"]]
            assert [xyz(v) for v in c.normals] == [[row[f"normal_{a}"] for a in "xyz"]]
            assert list(c.depths) == [-row["distance_m"]]
            (w,) = c.wrenches
            assert (w.body_1_name.data, w.body_2_name.data) == (row["body1"], row["body2"])
            f = [row[f"force_on_geom2_{a}_n"] for a in "xyz"]
            assert xyz(w.body_2_wrench.force) == f and xyz(w.body_1_wrench.force) == [-v for v in f]
            seen += 1
    assert seen == len(contacts)

    # simserpent_msgs/ContactEstimates: estimates.csv.
    if estimates.exists():
        table = pd.read_csv(estimates)
        for k, (_, msg) in enumerate(topics["/snake/contact_estimates"]):
            row = table.iloc[k]
            assert stamp_ns(msg.header) == stamps[k] and list(msg.link_names) == link_names
            for i, name in enumerate(link_names):
                for field in ("external_force", "floor_force", "obstacle_force", "self_contact_force"):
                    got = xyz(getattr(msg, field)[i])
                    assert got == [row[f"{name}_estimated_{field}_{a}_n"] for a in "xyz"]
                assert float(msg.contact[i]) == row[f"{name}_estimated_contact"]
                assert float(msg.self_contact[i]) == row[f"{name}_estimated_self_contact"]
                # One "no point" convention: NaN in the message and in the table.
                along = row[f"{name}_estimated_point_along_m"]
                assert np.isnan(msg.contact_point_along[i]) == np.isnan(along)
                assert np.isnan(along) or msg.contact_point_along[i] == along
    return n


@pytest.mark.parametrize("noise", [False, True], ids=["default", "noise and estimation"])
def test_bag_decodes_and_equals_csv(tmp_path, noise):
    sets = ["sensors.noise_enabled=true", "estimation.enabled=true"] if noise else []
    folder = run(tmp_path, *sets)
    bag = folder / "run.mcap"
    topics, summary = read_mcap(bag)
    std = {"gyro": 0.005, "accelerometer": 0.05, "orientation": 0.01} if noise else {"gyro": 0.0, "accelerometer": 0.0, "orientation": 0.0}
    n = check_against_csv(folder, topics, std)
    assert summary.statistics.message_count == n * len(topics)

    # rosbags decodes the same messages to the same values.
    other = read_rosbags(bag)
    assert set(other) == set(topics)
    for topic in ("/joint_states", "/snake/link_03/imu", "/snake/joint_04/wrench"):
        assert [t for t, _ in other[topic]] == [t for t, _ in topics[topic]]
    check_against_csv(folder, other, std)

    if noise:
        sensors = pd.read_csv(folder / "sensors.csv")
        assert (sensors["link_02_gyro_measured_x_rad_per_s"] != sensors["link_02_gyro_true_x_rad_per_s"]).any()


def test_bag_alone_and_manifest(tmp_path):
    folder = run(tmp_path, 'recording.format="mcap"')
    assert not list(folder.glob("*.csv")) or {p.name for p in folder.glob("*.csv")} <= {"state.csv"}
    import json

    manifest = json.loads((folder / "manifest.json").read_text())
    assert manifest["status"] == "complete"
    assert [name for name, _ in manifest["tables"]] == ["run.mcap"]
    topics, _ = read_mcap(folder / "run.mcap")
    assert len(topics["/clock"]) == manifest["tables"][0][1]
