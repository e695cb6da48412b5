//! What the thesis asks for that had no home: the pictures of experiment I,
//! the project assignment's ball drop, a Boa preset, and the platform statement.

use crate::common::{self, output_dir, simserpent, text};
use simserpent::config::{
    Config, ConfigSource, GroundModel, JointAxes, load_config_str,
    presets::{BOA_TOML, config_preset},
};
use simserpent::experiments::bounce::{Contact, predicted_rebound_ratio};
use simserpent::experiments::run_experiment;

fn failed(report: &simserpent::experiments::Report) -> Vec<String> {
    report
        .checks()
        .filter(|c| !c.passed)
        .map(|c| format!("{}: {} (expected {})", c.name, c.measured, c.expected))
        .collect()
}

// --- experiment I: pictures --------------------------------------------------------------------

/// Pixels of a picture whose colour is close to `rgb` (each channel within 60 of 255·rgb).
#[cfg(offscreen_render)]
fn pixels_of_colour(path: &std::path::Path, rgb: [f64; 3]) -> usize {
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgb);
    buf.truncate(info.buffer_size());
    buf.chunks(3).filter(|p| (0..3).all(|k| (f64::from(p[k]) - 255.0 * rgb[k]).abs() < 60.0)).count()
}

#[cfg(offscreen_render)]
#[test]
#[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
fn configure_experiment_draws_each_set_in_its_colour_next_to_the_report() {
    let dir = tempfile::tempdir().unwrap();
    let outcome = run_experiment("configure", &Config::default(), dir.path(), true).unwrap();
    assert!(outcome.report.all_passed(), "{:#?}", failed(&outcome.report));
    let markdown = std::fs::read_to_string(outcome.folder.join("report.md")).unwrap();
    // Table 5's colours: A blue (0, 0, 0.8), B red, C green. Shading darkens the lit colour, so
    // count pixels near the darker half of it too; a set drawn in its colour covers hundreds of
    // pixels, the checkered floor and grey sky none of these.
    for (set, rgb) in [("A", [0.0, 0.0, 0.8]), ("B", [1.0, 0.0, 0.0]), ("C", [0.0, 1.0, 0.0])] {
        let file = format!("configure-{set}.png");
        assert!(markdown.contains(&format!("]({file})")), "report.md links {file}");
        let path = outcome.folder.join(&file);
        let n = pixels_of_colour(&path, rgb) + pixels_of_colour(&path, rgb.map(|c| c * 0.6));
        assert!(n > 500, "set {set}: {n} pixels of its colour in {file}");
    }
}

// --- the ball drop -----------------------------------------------------------------------------

#[test]
fn contact_law_prediction_is_elastic_without_damping_and_matches_a_damped_spring() {
    assert!((predicted_rebound_ratio(Contact::Direct(1.0e5, 0.0)) - 1.0).abs() < 1e-4);
    // Light damping: a linear spring–damper's restitution e = exp(−πζ'/√(1 − ζ'²)) with
    // ζ' = ζ·√d_max (the impedance scales stiffness and damping); rebound height ratio e².
    for zeta in [0.02, 0.05] {
        let z = zeta * 0.95f64.sqrt();
        let e = (-std::f64::consts::PI * z / (1.0 - z * z).sqrt()).exp();
        let predicted = predicted_rebound_ratio(Contact::Standard(0.1, zeta));
        assert!((predicted - e * e).abs() < 0.01 * e * e, "ζ {zeta}: {predicted} vs {}", e * e);
    }
}

#[test]
#[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
fn bounce_experiment_rebounds_to_the_drop_height_and_measures_the_soft_contact() {
    let dir = tempfile::tempdir().unwrap();
    let outcome = run_experiment("bounce", &Config::default(), dir.path(), true).unwrap();
    let report = &outcome.report;
    assert!(report.all_passed(), "{:#?}", failed(report));
    let names: Vec<&str> = report.checks().map(|c| c.name.as_str()).collect();
    for needed in ["time of first touch", "speed at first touch", "energy conserved", "restitution 1", "energy after"] {
        assert!(names.iter().any(|n| n.contains(needed)), "no check `{needed}` in {names:?}");
    }
    let rebound = report.checks().find(|c| c.name.starts_with("restitution 1")).unwrap().measured;
    assert!(report.checks().all(|c| !c.name.contains('|')), "a check name would break the Markdown table");
    assert!((rebound - 1.0).abs() < 0.01, "{rebound}");
    // The sweep: SimSerpent's default contact (critically damped) keeps under 2 % of the height,
    // the direct undamped contact (stiffness 1e5) more than 99 %.
    let markdown = std::fs::read_to_string(outcome.folder.join("report.md")).unwrap();
    let row = |solref: &str| -> Vec<String> {
        let line = markdown.lines().find(|l| l.contains(&format!("| `{solref}` |"))).unwrap_or_else(|| {
            panic!("no sweep row for solref {solref} in\n{markdown}");
        });
        line.split('|').map(|s| s.trim().to_string()).collect()
    };
    let default_row = row("0.02 1");
    let measured: f64 = default_row[3].parse().unwrap();
    assert!(measured < 0.02, "default contact rebounds to {measured} of the height");
    let elastic: f64 = row("-100000 0")[3].parse().unwrap();
    assert!(elastic > 0.99, "{elastic}");
}

#[test]
fn direct_contact_stiffness_reaches_the_model_and_bad_values_are_named() {
    let mut c = Config::default();
    c.physics.contact_stiffness_per_s2 = 1.0e4;
    let xml = simserpent::model::generate(&c).unwrap().xml;
    assert!(xml.contains("solref=\"-10000 0\""), "{xml}");
    c.physics.contact_damping_per_s = 2.5;
    assert!(simserpent::model::generate(&c).unwrap().xml.contains("solref=\"-10000 -2.5\""));
    for (set, key, words) in [
        (&["physics.contact_damping_per_s=1.0"][..], "physics.contact_damping_per_s", "contact_stiffness_per_s2 > 0"),
        (&["physics.contact_stiffness_per_s2=-1.0"][..], "physics.contact_stiffness_per_s2", "at least 0"),
        (&["physics.contact_stiffness_per_s2=2e6"][..], "physics.contact_stiffness_per_s2", "at most"),
    ] {
        let overrides: Vec<String> = set.iter().map(|s| s.to_string()).collect();
        let e = common::default_config_with(&overrides).unwrap_err().to_string();
        assert!(e.contains(key) && e.contains(words), "{set:?}: {e}");
    }
}

// --- the Boa preset ----------------------------------------------------------------------------

#[test]
fn boa_preset_loads_validates_compiles_and_runs_with_its_sensors() {
    assert_eq!(config_preset("boa"), Some(BOA_TOML));
    for source in ["github.com/Boa-Snake-Robot/Boa-Manual", "NOT published", "11250/2781042"] {
        assert!(BOA_TOML.contains(source), "the preset cites {source}");
    }
    let dir = tempfile::tempdir().unwrap();
    let overrides = vec![output_dir(dir.path()), "general.duration_secs=0.5".to_string()];
    let c = load_config_str(BOA_TOML, ConfigSource::Toml, &overrides).unwrap();
    assert_eq!(c.snake.joint_axes, JointAxes::Yaw, "Boa is planar");
    assert_eq!(c.ground.model, GroundModel::Isotropic);
    assert_eq!(c.snake.link_mass_kg, 1.0);
    assert!(c.recording.imu_sensors && c.recording.internal_joint_forces);
    let run = common::run_folder(&c);
    let (header, rows) = common::read_csv(&run.join("sensors.csv"));
    assert!(rows.len() > 10);
    // One IMU per link and one constraint force sensor per joint, as on Boa.
    let has = |prefix: &str| header.iter().any(|h| h.starts_with(prefix));
    for i in 0..c.snake.n_links {
        for part in ["accelerometer", "gyro"] {
            assert!(has(&format!("link_{i:02}_{part}")), "IMU {part} of link {i}: {header:?}");
        }
    }
    for j in 1..c.snake.n_links {
        assert!(has(&format!("joint_{j:02}_force_sensor")), "force sensor of joint {j}: {header:?}");
    }
}

/// `simserpent init --preset boa` then a run, as a user makes it (5 s): the snake moves head first
/// and every joint tracks its command (the run's tracking warning stays silent), with its
/// servos within the RMD-X6's rated torque. Measured: 0.139 m in 5 s, 0.027 m/s along the start's
/// heading (0.68 m in 20 s); with the wave reversed, -0.029 m/s.
#[test]
fn boa_preset_moves_head_first_and_tracks_its_joints() {
    let dir = tempfile::tempdir().unwrap();
    let overrides = vec![output_dir(dir.path()), "general.duration_secs=5".to_string()];
    let c = load_config_str(BOA_TOML, ConfigSource::Toml, &overrides).unwrap();
    assert_eq!(c.snake.torque_range_nm, [-4.5, 4.5], "the RMD-X6 V3's rated torque");
    let summary = simserpent::run::run(&c, &Default::default()).unwrap();
    let warning = simserpent::run::tracking_warning(&c, &summary);
    assert!(warning.is_none(), "{warning:?}");
    let tracking = summary.tracking.as_deref().unwrap();
    assert_eq!(tracking.len(), c.snake.n_links - 1);
    for j in tracking {
        assert!(j.tracks(), "{j:?}");
    }
    assert!(summary.distance_m > 0.12, "moved {} m in 5 s", summary.distance_m);
    assert!(summary.forward_speed_m_per_s > 0.024, "forward speed {} m/s", summary.forward_speed_m_per_s);
    // The wave running toward the tail, as in a biological snake: on the isotropic floor the
    // snake slides backward as fast (the preset's comment and the guide say so).
    let reversed = [overrides, vec!["gait.sine_wave.phase_lag_deg=60".to_string()]].concat();
    let c = load_config_str(BOA_TOML, ConfigSource::Toml, &reversed).unwrap();
    let summary = simserpent::run::run(&c, &Default::default()).unwrap();
    assert!(summary.forward_speed_m_per_s < -0.024, "forward speed {} m/s", summary.forward_speed_m_per_s);
}

#[test]
fn init_preset_writes_boa_and_names_the_presets_when_unknown() {
    let dir = tempfile::tempdir().unwrap();
    let o = simserpent(dir.path(), &["init", "--preset", "boa", "boa.toml"]);
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(std::fs::read_to_string(dir.path().join("boa.toml")).unwrap(), BOA_TOML);
    let o = simserpent(dir.path(), &["check", "boa.toml"]);
    assert!(o.status.success(), "{}", text(&o));
    let o = simserpent(dir.path(), &["init", "--preset", "anaconda", "x.toml"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("unknown preset `anaconda`") && text(&o).contains("boa"), "{}", text(&o));
    assert!(!dir.path().join("x.toml").exists());
}

// --- the platform statement --------------------------------------------------------------------

#[test]
fn the_guide_states_the_supported_platforms() {
    let page = "guide/src/getting-started/installation.md";
    let readme = std::fs::read_to_string(common::manifest_dir().join(page)).unwrap();
    let start = readme.find("## Platforms").expect("the installation page has a `## Platforms` section");
    let section = &readme[start..];
    let section = &section[..section[3..].find("\n## ").map_or(section.len(), |e| e + 3)];
    for needed in ["Linux x86-64", "macOS", "Windows", "build.rs", ".ci/run"] {
        assert!(section.contains(needed), "the Platforms section mentions {needed}");
    }
}
