//! The ROS 2 bag (`recording.format` with `"mcap"`, user guide, "ROS 2"): the config values, the
//! file read back with the `mcap` crate's reader and CDR-decoded, its values against the CSV
//! tables, and reproducibility. The independent Python readers are in python/tests/test_mcap.py.

use crate::common::{default_config_with, output_dir, read_csv_numbers, run_folder};
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
    // clock, joint states (measured, true), tf, commands, contacts; per link imu and contact
    // wrench; per joint wrench.
    assert_eq!(bag.len(), 6 + 2 * n_links + n_joints, "{:?}", bag.keys().collect::<Vec<_>>());
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
