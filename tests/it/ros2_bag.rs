//! The ROS 2 bag (`recording.format` with `"mcap"`, user guide, "ROS 2"): the config values, the
//! file read back with the `mcap` crate's reader and CDR-decoded, its values against the CSV
//! tables, and reproducibility. The independent Python readers are in python/tests/test_mcap.py.

use crate::common::{default_config_with, output_dir, read_csv, read_csv_numbers, run_folder};
use serde::Deserialize;
use simserpent::config::{Config, ConfigError, TableFormat};
use std::collections::BTreeMap;
use std::path::Path;

fn config(dir: &Path, overrides: &[&str]) -> Result<Config, ConfigError> {
    let mut all: Vec<String> =
        vec!["general.duration_secs=0.3".into(), "recording.every_n_steps=5".into(), output_dir(&dir.join("runs"))];
    all.extend(overrides.iter().map(|s| s.to_string()));
    default_config_with(&all)
}

fn invalid_key(e: &ConfigError) -> &str {
    match e {
        ConfigError::InvalidValue { key, .. } => key,
        other => panic!("expected an invalid value, got {other}"),
    }
}

#[test]
fn format_takes_one_name_or_a_list() {
    let dir = tempfile::tempdir().unwrap();
    let cases: [(&str, [bool; 3]); 5] = [
        ("\"mcap\"", [false, false, true]),
        ("[\"csv\", \"mcap\"]", [true, false, true]),
        ("[\"mcap\", \"parquet\"]", [false, true, true]),
        ("[\"csv\", \"parquet\", \"mcap\"]", [true, true, true]),
        ("[\"both\"]", [true, true, false]),
    ];
    for (value, [csv, parquet, mcap]) in cases {
        if parquet && !cfg!(feature = "parquet") {
            continue;
        }
        let c = config(dir.path(), &[&format!("recording.format={value}")]).unwrap();
        let f = c.recording.format;
        assert_eq!((f.csv(), f.parquet(), f.mcap()), (csv, parquet, mcap), "{value}");
        // Written back (the run folder's config.toml) and read again: the same formats.
        let again =
            simserpent::config::load_config_str(&c.to_toml_string(), simserpent::config::ConfigSource::Toml, &[])
                .unwrap();
        assert_eq!(again.recording.format, f, "{value}");
    }
    assert_eq!(TableFormat::Csv.with_mcap().to_string(), "[\"csv\", \"mcap\"]");
    assert_eq!(TableFormat::Both.to_string(), "both");
}

#[test]
fn bad_formats_name_the_key_and_what_is_allowed() {
    let dir = tempfile::tempdir().unwrap();
    for value in ["\"xml\"", "[\"csv\", \"xml\"]", "[]", "[\"csv\", \"csv\"]", "3", "[\"mcap\", 1]"] {
        let e = config(dir.path(), &[&format!("recording.format={value}")]).unwrap_err();
        // A bad list element is named by its index: recording.format[1].
        assert!(invalid_key(&e).starts_with("recording.format"), "{value}: {e}");
        let text = e.to_string();
        assert!(text.contains("mcap") || text.contains("twice"), "{value}: {text}");
    }
}

#[test]
fn bad_ros2_values_name_the_key() {
    let dir = tempfile::tempdir().unwrap();
    for (set, key) in [
        ("ros2.namespace=\"1snake\"", "ros2.namespace"),
        ("ros2.namespace=\"/snake\"", "ros2.namespace"),
        ("ros2.namespace=\"my snake\"", "ros2.namespace"),
        ("ros2.namespace=\"a//b\"", "ros2.namespace"),
        ("ros2.contact_arrow_m_per_n=0.0", "ros2.contact_arrow_m_per_n"),
        ("ros2.contact_arrow_m_per_n=-0.01", "ros2.contact_arrow_m_per_n"),
        ("ros2.contact_arrow_m_per_n=nan", "ros2.contact_arrow_m_per_n"),
        // The live bridge's keys (run --ros2).
        ("ros2.domain_id=233", "ros2.domain_id"),
        ("ros2.interfaces=[\"eth0\"]", "ros2.interfaces"),
        ("ros2.publish_rate_hz=0.0", "ros2.publish_rate_hz"),
        ("ros2.publish_rate_hz=inf", "ros2.publish_rate_hz"),
        ("ros2.history_depth=0", "ros2.history_depth"),
        ("ros2.real_time_factor=-1.0", "ros2.real_time_factor"),
        ("ros2.steps_per_command=0", "ros2.steps_per_command"),
        ("ros2.lockstep_timeout_secs=0.0", "ros2.lockstep_timeout_secs"),
        ("ros2.lockstep_timeout_secs=nan", "ros2.lockstep_timeout_secs"),
    ] {
        let e = config(dir.path(), &[set]).unwrap_err();
        assert_eq!(invalid_key(&e), key, "{set}: {e}");
    }
    for ok in ["ros2.namespace=\"\"", "ros2.namespace=\"lab/snake_1\"", "ros2.interfaces=[\"127.0.0.1\"]"] {
        config(dir.path(), &[ok]).unwrap();
    }
    for bad in ["ros2.clock=\"fast\"", "ros2.reliability=\"sometimes\"", "ros2.durability=\"forever\""] {
        let e = config(dir.path(), &[bad]).unwrap_err().to_string();
        assert!(e.contains(bad.split('=').next().unwrap_or_default()), "{bad}: {e}");
    }
}

/// `--ros2` on a binary without the `ros2` feature: a clear error before anything is written.
#[cfg(not(feature = "ros2"))]
#[test]
fn ros2_without_the_feature_says_how_to_build_it() {
    let dir = tempfile::tempdir().unwrap();
    let c = config(dir.path(), &["general.duration_secs=0.01"]).unwrap();
    let options = simserpent::run::RunOptions { ros2: true, ..Default::default() };
    let e = simserpent::run::run(&c, &options).unwrap_err();
    assert!(e.to_string().contains("--features ros2"), "{e}");
    assert!(!dir.path().join("runs").exists(), "no run folder");
}

#[derive(Deserialize)]
struct Time {
    sec: i32,
    nanosec: u32,
}

#[derive(Deserialize)]
struct Header {
    stamp: Time,
    #[allow(dead_code)]
    frame_id: String,
}

#[derive(Deserialize)]
struct JointState {
    header: Header,
    name: Vec<String>,
    position: Vec<f64>,
    velocity: Vec<f64>,
    effort: Vec<f64>,
}

/// Every message of a bag: topic → (log time, CDR bytes without the encapsulation header).
fn read_bag(path: &Path) -> BTreeMap<String, Vec<(u64, Vec<u8>)>> {
    let bytes = std::fs::read(path).unwrap();
    let mut out: BTreeMap<String, Vec<(u64, Vec<u8>)>> = BTreeMap::new();
    for message in mcap::MessageStream::new(&bytes).unwrap() {
        let message = message.unwrap();
        assert_eq!(message.channel.message_encoding, "cdr");
        let schema = message.channel.schema.as_ref().unwrap();
        assert_eq!(schema.encoding, "ros2msg");
        assert_eq!(&message.data[..4], &[0, 1, 0, 0], "CDR little-endian encapsulation");
        out.entry(message.channel.topic.clone()).or_default().push((message.log_time, message.data[4..].to_vec()));
    }
    out
}

#[test]
fn bag_holds_every_topic_at_every_recorded_instant_with_the_csv_values() {
    let dir = tempfile::tempdir().unwrap();
    let c = config(dir.path(), &["recording.format=[\"csv\", \"mcap\"]", "sensors.noise_enabled=true"]).unwrap();
    let folder = run_folder(&c);
    let bag = read_bag(&folder.join("run.mcap"));
    let (header, sensors) = read_csv_numbers(&folder.join("sensors.csv"));
    let col = |name: &str| header.iter().position(|h| h == name).unwrap_or_else(|| panic!("{name}"));
    let (n_links, n_joints) = (c.snake.n_links, c.snake.n_links - 1);
    // clock, joint states (measured, true), tf, commands, contact markers, contact states, true contact forces; per
    // link imu and contact wrench; per joint wrench (no contact estimates: estimation is off).
    assert_eq!(bag.len(), 8 + 2 * n_links + n_joints, "{:?}", bag.keys().collect::<Vec<_>>());
    for (topic, messages) in &bag {
        assert_eq!(messages.len(), sensors.len(), "{topic}: one message per recorded instant");
        for ((t, _), row) in messages.iter().zip(&sensors) {
            assert_eq!(*t, (row[0] * 1e9).round() as u64, "{topic}: stamped with simulated time");
        }
    }
    for ((_, data), row) in bag["/joint_states"].iter().zip(&sensors) {
        let (js, _) = cdr_encoding::from_bytes::<JointState, byteorder::LittleEndian>(data).unwrap();
        assert_eq!(js.name, (1..=n_joints).map(|j| format!("joint_{j:02}")).collect::<Vec<_>>());
        // Stamps are the simulated time to the nearest nanosecond.
        let stamp_ns = js.header.stamp.sec as u64 * 1_000_000_000 + u64::from(js.header.stamp.nanosec);
        assert_eq!(stamp_ns, (row[0] * 1e9).round() as u64);
        for (j, name) in js.name.iter().enumerate() {
            assert_eq!(js.position[j], row[col(&format!("{name}_encoder_measured_rad"))]);
            assert_eq!(js.velocity[j], row[col(&format!("{name}_encoder_velocity_measured_rad_per_s"))]);
            assert_eq!(js.effort[j], row[col(&format!("{name}_actuator_torque_measured_nm"))]);
        }
    }
    assert!(bag.contains_key("/snake/link_00/imu") && bag.contains_key("/snake/joint_01/wrench"));
}

#[test]
fn same_config_and_seed_give_the_same_bag_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let c = config(dir.path(), &["recording.format=\"mcap\"", "sensors.noise_enabled=true", "ros2.namespace=\"\""])
        .unwrap();
    let a = run_folder(&c);
    let b = run_folder(&c);
    assert_ne!(a, b);
    let bytes = std::fs::read(a.join("run.mcap")).unwrap();
    assert_eq!(bytes, std::fs::read(b.join("run.mcap")).unwrap());
    assert!(!a.join("links.csv").exists(), "\"mcap\" alone writes no tables");
    let bag = read_bag(&a.join("run.mcap"));
    assert!(bag.contains_key("/link_00/imu"), "no namespace: {:?}", bag.keys().collect::<Vec<_>>());
}

#[derive(Deserialize, Debug, Clone, Copy, PartialEq)]
struct Vector3 {
    x: f64,
    y: f64,
    z: f64,
}

impl Vector3 {
    fn xyz(&self) -> [f64; 3] {
        [self.x, self.y, self.z]
    }
}

#[derive(Deserialize)]
struct Wrench {
    force: Vector3,
    torque: Vector3,
}

#[derive(Deserialize)]
struct WrenchStamped {
    header: Header,
    wrench: Wrench,
}

#[derive(Deserialize)]
struct Quaternion {
    x: f64,
    y: f64,
    z: f64,
    w: f64,
}

#[derive(Deserialize)]
struct Imu {
    header: Header,
    orientation: Quaternion,
    orientation_covariance: [f64; 9],
    angular_velocity: Vector3,
    angular_velocity_covariance: [f64; 9],
    linear_acceleration: Vector3,
    linear_acceleration_covariance: [f64; 9],
}

/// `ros_gz_interfaces/Entity`.
#[derive(Deserialize)]
struct Entity {
    id: u64,
    name: String,
    #[serde(rename = "type")]
    kind: u8,
}

/// `ros_gz_interfaces/JointWrench` (std_msgs/String and UInt32 are their one field on the wire).
#[derive(Deserialize)]
struct JointWrench {
    header: Header,
    body_1_name: String,
    body_1_id: u32,
    body_2_name: String,
    body_2_id: u32,
    body_1_wrench: Wrench,
    body_2_wrench: Wrench,
}

/// `ros_gz_interfaces/Contact`.
#[derive(Deserialize)]
struct Contact {
    collision1: Entity,
    collision2: Entity,
    positions: Vec<Vector3>,
    normals: Vec<Vector3>,
    depths: Vec<f64>,
    wrenches: Vec<JointWrench>,
}

/// `ros_gz_interfaces/Contacts`.
#[derive(Deserialize)]
struct Contacts {
    header: Header,
    contacts: Vec<Contact>,
}

/// `simserpent_msgs/ContactEstimates`.
#[derive(Deserialize)]
struct ContactEstimates {
    header: Header,
    link_names: Vec<String>,
    external_force: Vec<Vector3>,
    floor_force: Vec<Vector3>,
    obstacle_force: Vec<Vector3>,
    contact: Vec<bool>,
    contact_point_along: Vec<f64>,
    contact_point: Vec<Vector3>,
    self_contact_force: Vec<Vector3>,
    self_contact: Vec<bool>,
}

fn decode<'a, T: Deserialize<'a>>(data: &'a [u8]) -> T {
    cdr_encoding::from_bytes::<T, byteorder::LittleEndian>(data).unwrap().0
}

fn stamp_ns(h: &Header) -> u64 {
    h.stamp.sec as u64 * 1_000_000_000 + u64::from(h.stamp.nanosec)
}

/// Every schema of a bag: type name → (encoding, text).
fn read_schemas(path: &Path) -> BTreeMap<String, (String, String)> {
    let bytes = std::fs::read(path).unwrap();
    let summary = mcap::Summary::read(&bytes).unwrap().unwrap();
    summary
        .schemas
        .values()
        .map(|s| (s.name.clone(), (s.encoding.clone(), String::from_utf8(s.data.to_vec()).unwrap())))
        .collect()
}

/// The message types a `ros2msg` text uses (`pkg/Type name`, `pkg/Type[] name`), comments and
/// constants left out.
fn used_types(text: &str) -> Vec<String> {
    text.lines()
        .filter_map(|l| l.split_whitespace().next())
        .filter(|t| !t.starts_with('#') && t.contains('/'))
        .map(|t| t.split('[').next().unwrap().to_string())
        .collect()
}

/// The new ROS 2 topics of a run with an obstacle and the estimator on: their schemas are
/// registered as ROS 2 bags register them (`ros2msg`, the definition followed by every type it
/// uses, each after a line of 80 `=` and `MSG: pkg/Type`), and every message decodes to the
/// values of the tables: the true contacts to `contacts.csv` (row for row), the estimates to
/// `estimates.csv`, the joint force/torque sensors and IMUs to `sensors.csv`.
#[test]
fn contact_states_estimates_wrenches_and_imus_decode_to_the_table_values() {
    let dir = tempfile::tempdir().unwrap();
    let c = config(
        dir.path(),
        &[
            "recording.format=[\"csv\", \"mcap\"]",
            "sensors.noise_enabled=true",
            "estimation.enabled=true",
            "general.duration_secs=0.5",
        ],
    )
    .unwrap();
    let folder = run_folder(&c);
    let path = folder.join("run.mcap");

    let schemas = read_schemas(&path);
    for ty in ["ros_gz_interfaces/msg/Contacts", "simserpent_msgs/msg/ContactEstimates", "sensor_msgs/msg/Imu"] {
        let (encoding, text) = &schemas[ty];
        assert_eq!(encoding, "ros2msg");
        let separator = format!("{}\n", "=".repeat(80));
        let mut sections = text.split(&separator);
        let main = sections.next().unwrap();
        let mut defined: BTreeMap<String, String> = BTreeMap::new();
        for section in sections {
            let (first, body) = section.split_once('\n').unwrap();
            let name = first.strip_prefix("MSG: ").unwrap_or_else(|| panic!("{ty}: section starts {first:?}"));
            assert!(defined.insert(name.to_string(), body.to_string()).is_none(), "{ty}: {name} twice");
        }
        for used in used_types(main).into_iter().chain(defined.values().flat_map(|b| used_types(b))) {
            assert!(defined.contains_key(&used), "{ty}: {used} is used but not defined in\n{text}");
        }
    }
    assert!(
        schemas["simserpent_msgs/msg/ContactEstimates"].1.starts_with(simserpent::ros2::msgs::CONTACT_ESTIMATES_MSG)
    );

    let bag = read_bag(&path);
    let (n_links, n_joints) = (c.snake.n_links, c.snake.n_links - 1);

    // True contacts against contacts.csv, row for row.
    let (header, rows) = read_csv(&folder.join("contacts.csv"));
    let col = |name: &str| header.iter().position(|h| h == name).unwrap_or_else(|| panic!("{name}"));
    let num = |row: &Vec<String>, name: &str| -> f64 { row[col(name)].parse().unwrap() };
    let xyz = |row: &Vec<String>, prefix: &str, unit: &str| -> [f64; 3] {
        ["x", "y", "z"].map(|a| num(row, &format!("{prefix}_{a}{unit}")))
    };
    let mut at = 0;
    let mut seen = 0;
    let states = &bag["/snake/ground_truth/contacts"];
    for (t, data) in states {
        let m: Contacts = decode(data);
        assert_eq!(stamp_ns(&m.header), *t);
        assert_eq!(m.header.frame_id, "world");
        for contact in &m.contacts {
            let row = &rows[at];
            at += 1;
            assert_eq!((row[0].parse::<f64>().unwrap() * 1e9).round() as u64, *t, "the contact's instant");
            assert_eq!([&contact.collision1.name, &contact.collision2.name], [&row[col("geom1")], &row[col("geom2")]]);
            assert_eq!([contact.collision1.kind, contact.collision2.kind], [5, 5], "COLLISION");
            assert_ne!(contact.collision1.id, contact.collision2.id);
            assert_eq!(contact.positions.iter().map(Vector3::xyz).collect::<Vec<_>>(), [xyz(row, "position", "_m")]);
            assert_eq!(
                contact.normals.iter().map(Vector3::xyz).collect::<Vec<_>>(),
                [["x", "y", "z"].map(|a| num(row, &format!("normal_{a}")))]
            );
            assert_eq!(contact.depths, [-num(row, "distance_m")]);
            let [w] = &contact.wrenches[..] else { panic!("one wrench per contact") };
            assert_eq!(stamp_ns(&w.header), *t);
            assert_eq!([&w.body_1_name, &w.body_2_name], [&row[col("body1")], &row[col("body2")]]);
            let f = xyz(row, "force_on_geom2", "_n");
            assert_eq!(w.body_2_wrench.force.xyz(), f);
            assert_eq!(w.body_1_wrench.force.xyz(), f.map(|v| -v));
            assert_eq!([w.body_1_wrench.torque.xyz(), w.body_2_wrench.torque.xyz()], [[0.0; 3]; 2]);
            assert!(w.body_1_id != w.body_2_id);
            seen += 1;
        }
    }
    assert_eq!(seen, rows.len(), "every row of contacts.csv, none more");
    assert!(seen > states.len(), "the snake lies on the floor: several contacts per instant ({seen})");

    // Estimates against estimates.csv.
    let (header, rows) = read_csv_numbers(&folder.join("estimates.csv"));
    let col = |name: &str| header.iter().position(|h| h == name).unwrap_or_else(|| panic!("{name}"));
    let estimates = &bag["/snake/contact_estimates"];
    assert_eq!(estimates.len(), rows.len());
    let mut floor_support = false;
    for ((t, data), row) in estimates.iter().zip(&rows) {
        let m: ContactEstimates = decode(data);
        assert_eq!(stamp_ns(&m.header), *t);
        assert_eq!((row[0] * 1e9).round() as u64, *t);
        assert_eq!(m.link_names, (0..n_links).map(|i| format!("link_{i:02}")).collect::<Vec<_>>());
        for (i, link) in m.link_names.iter().enumerate() {
            let v = |what: &str| ["x", "y", "z"].map(|a| row[col(&format!("{link}_estimated_{what}_{a}_n"))]);
            assert_eq!(m.external_force[i].xyz(), v("external_force"));
            assert_eq!(m.floor_force[i].xyz(), v("floor_force"));
            assert_eq!(m.obstacle_force[i].xyz(), v("obstacle_force"));
            assert_eq!(m.self_contact_force[i].xyz(), v("self_contact_force"));
            assert_eq!(f64::from(u8::from(m.contact[i])), row[col(&format!("{link}_estimated_contact"))]);
            assert_eq!(f64::from(u8::from(m.self_contact[i])), row[col(&format!("{link}_estimated_self_contact"))]);
            // One "no point" convention: NaN in the message and in the table.
            let along = row[col(&format!("{link}_estimated_point_along_m"))];
            assert_eq!(m.contact_point_along[i].is_nan(), along.is_nan());
            assert_eq!(m.contact_point[i].x.is_nan(), along.is_nan());
            if !along.is_nan() {
                assert_eq!(m.contact_point_along[i], along);
            }
            floor_support |= m.floor_force[i].z > 0.0;
        }
    }
    assert!(floor_support, "the estimates are not all zero");

    // The true contact forces, split, against links.csv: floor, obstacles and other links
    // (self-contact) apart, adding up to the total.
    let (header, rows) = read_csv_numbers(&folder.join("links.csv"));
    let col = |name: &str| header.iter().position(|h| h == name).unwrap_or_else(|| panic!("{name}"));
    let forces = &bag["/snake/ground_truth/contact_forces"];
    assert_eq!(forces.len(), rows.len());
    for ((t, data), row) in forces.iter().zip(&rows) {
        let m: ContactEstimates = decode(data);
        assert_eq!(stamp_ns(&m.header), *t);
        assert_eq!((row[0] * 1e9).round() as u64, *t);
        for (i, link) in m.link_names.iter().enumerate() {
            let v = |what: &str| ["x", "y", "z"].map(|a| row[col(&format!("{link}_{what}_{a}_n"))]);
            assert_eq!(m.external_force[i].xyz(), v("contact_force"));
            assert_eq!(m.floor_force[i].xyz(), v("floor_force"));
            assert_eq!(m.obstacle_force[i].xyz(), v("obstacle_force"));
            assert_eq!(m.self_contact_force[i].xyz(), v("self_contact_force"));
            let other = v("other_contact_force");
            let parts = [m.floor_force[i].xyz(), m.obstacle_force[i].xyz(), m.self_contact_force[i].xyz(), other];
            for (k, total) in m.external_force[i].xyz().iter().enumerate() {
                let sum: f64 = parts.iter().map(|p| p[k]).sum();
                assert!((sum - total).abs() < 1e-9, "{link}: the parts add up");
            }
        }
    }

    // Joint force/torque sensors and IMUs against sensors.csv (measured).
    let (header, rows) = read_csv_numbers(&folder.join("sensors.csv"));
    let col = |name: &str| header.iter().position(|h| h == name).unwrap_or_else(|| panic!("{name}"));
    for j in 1..=n_joints {
        for ((t, data), row) in bag[&format!("/snake/joint_{j:02}/wrench")].iter().zip(&rows) {
            let m: WrenchStamped = decode(data);
            assert_eq!(stamp_ns(&m.header), *t);
            assert_eq!(m.header.frame_id, format!("link_{j:02}"), "the child link's frame");
            let v = |what: &str, unit: &str| {
                ["x", "y", "z"].map(|a| row[col(&format!("joint_{j:02}_{what}_measured_{a}_{unit}"))])
            };
            assert_eq!(m.wrench.force.xyz(), v("force_sensor", "n"));
            assert_eq!(m.wrench.torque.xyz(), v("torque_sensor", "nm"));
        }
    }
    for i in 0..n_links {
        for ((t, data), row) in bag[&format!("/snake/link_{i:02}/imu")].iter().zip(&rows) {
            let m: Imu = decode(data);
            assert_eq!(stamp_ns(&m.header), *t);
            assert_eq!(m.header.frame_id, format!("link_{i:02}"));
            let v = |what: &str, unit: &str| {
                ["x", "y", "z"].map(|a| row[col(&format!("link_{i:02}_{what}_measured_{a}_{unit}"))])
            };
            assert_eq!(m.angular_velocity.xyz(), v("gyro", "rad_per_s"));
            assert_eq!(m.linear_acceleration.xyz(), v("accelerometer", "m_per_s2"));
            // The IMU's framequat as measured, with the [sensors.orientation] covariance.
            let q = ["qx", "qy", "qz", "qw"].map(|a| row[col(&format!("link_{i:02}_orientation_measured_{a}"))]);
            assert_eq!([m.orientation.x, m.orientation.y, m.orientation.z, m.orientation.w], q);
            let diag = |c: &[f64; 9]| [c[0], c[4], c[8], c[1] + c[2] + c[3] + c[5] + c[6] + c[7]];
            let o = c.sensors.orientation.std;
            assert!(o > 0.0);
            assert_eq!(diag(&m.orientation_covariance), [o * o, o * o, o * o, 0.0]);
            let (g, a) = (c.sensors.gyro.std, c.sensors.accelerometer.std);
            assert_eq!(diag(&m.angular_velocity_covariance), [g * g, g * g, g * g, 0.0]);
            assert_eq!(diag(&m.linear_acceleration_covariance), [a * a, a * a, a * a, 0.0]);
        }
    }
}

/// Rotates `v` by the unit quaternion `q` (w, x, y, z).
fn rotate(q: [f64; 4], v: [f64; 3]) -> [f64; 3] {
    let [w, x, y, z] = q;
    let u = [x, y, z];
    let cross =
        |a: [f64; 3], b: [f64; 3]| [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
    let t = cross(u, v).map(|c| 2.0 * c);
    let ut = cross(u, t);
    [0, 1, 2].map(|k| v[k] + w * t[k] + ut[k])
}

/// The frame convention of the joint force/torque sensors (`/<ns>/joint_NN/wrench`, user guide
/// "ROS 2"): the force the parent link exerts on the child link and everything behind it, in the
/// child link's axes. Newton's second law on the links behind joint j (children of the joint, to
/// the tail), over a default run from t = 0: R(link j) f_j + Σ (contact force + m g) = Σ m a, with
/// every term from the same forward pass.
#[test]
fn joint_force_sensor_is_the_parent_s_force_on_the_links_behind_the_joint_in_the_child_s_axes() {
    use simserpent::sim::{Simulation, Snapshot, World};
    let c = default_config_with(&["general.duration_secs=1.0".to_string()]).unwrap();
    let mut sim = Simulation::new(&c, World::from_config(&c).unwrap());
    let n = c.snake.n_links;
    let g = c.general.gravity_m_per_s2;
    let mut s = Snapshot::new(n, n - 1);
    let steps = (c.general.duration_secs / c.general.timestep_secs).round() as usize;
    let (mut worst, mut largest, mut flipped) = (0.0f64, 0.0f64, 0.0f64);
    for _ in 0..steps {
        sim.control();
        sim.snapshot(&mut s);
        for j in 0..n - 1 {
            // Joint j (`joint_{j+1:02}`) joins link j (parent) and link j + 1 (child).
            let behind = j + 1..n;
            let f_world = rotate(s.link_quat[j + 1], s.joint_force_n[j]);
            // The other forces on those links: contacts and gravity, less their mass times
            // acceleration; the joint's force must balance them.
            let mut rest = [0.0; 3];
            let mut weight_n = 0.0;
            for i in behind {
                let m = s.link_mass_kg[i];
                for k in 0..3 {
                    rest[k] += s.link_contact_force_n[i][k] + m * g[k] - m * s.link_acceleration_m_per_s2[i][k];
                }
                weight_n += m * 9.81;
            }
            let norm = |v: [f64; 3]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
            worst = worst.max(norm([0, 1, 2].map(|k| f_world[k] + rest[k])) / weight_n);
            // The opposite convention (the child's force on the parent) would leave twice the force.
            flipped = flipped.max(norm([0, 1, 2].map(|k| -f_world[k] + rest[k])) / weight_n);
            largest = largest.max(f_world.iter().map(|v| v * v).sum::<f64>().sqrt() / weight_n);
        }
        sim.advance().unwrap();
    }
    assert!(largest > 0.1, "the joints carry forces ({largest} weights)");
    assert!(worst < 1e-6, "Newton's law on the links behind a joint: residual {worst} of their weight");
    assert!(flipped > 0.2, "the opposite sign is told apart ({flipped})");
    eprintln!("joint forces up to {largest:.3} weights of the links behind; residual at most {worst:.1e}");
}
