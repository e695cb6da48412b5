//! The original tool's config.json: `simserpent convert`, the conversion notes of
//! `check` and `run`, the guide's tables generated from the conversion data, the original
//! capsules (`legacy.geometry = "faithful"`), the thesis' PD control, experiments that record
//! what their analysis needs, and the shipped example config.json.

use crate::common::{manifest_dir, simserpent, snapshot, text};
use mujoco_rs::prelude::*;
use simserpent::config::{
    self, Config, ControlMethod, GaitKind, LegacyGeometry, TableFormat, TerrainKind, load_config, load_config_str,
};
use simserpent::control::{Command, Controller, Observation};
use simserpent::sim::{Simulation, World};
use std::path::PathBuf;

/// The thesis' config.json (appendix 12.1), as shipped in examples/.
fn thesis_json() -> PathBuf {
    manifest_dir().join("examples/thesis/config.json")
}

/// Experiment III's config.json (thesis table 7), as shipped in examples/.
fn exp3_json() -> PathBuf {
    manifest_dir().join("examples/thesis/experiment3_undulation.json")
}

fn sets(items: &[&str]) -> Vec<String> {
    items.iter().map(|s| s.to_string()).collect()
}

// --- convert, notes, tables ----------------------------------------------------------------------

#[test]
fn convert_writes_an_annotated_toml_that_loads_to_the_same_config() {
    let dir = tempfile::tempdir().unwrap();
    for json in [thesis_json(), exp3_json()] {
        let out = dir.path().join("converted.toml");
        let o = simserpent(dir.path(), &["convert", json.to_str().unwrap(), "-o", out.to_str().unwrap(), "--force"]);
        assert!(o.status.success(), "{}", text(&o));
        let toml_text = std::fs::read_to_string(&out).unwrap();
        // The same config as loading the config.json itself.
        assert_eq!(load_config(&out, &[]).unwrap(), load_config(&json, &[]).unwrap(), "{}", json.display());

        // Every converted key is preceded by a comment naming its config.json key and the rule.
        let lines: Vec<&str> = toml_text.lines().collect();
        let mut keys = 0;
        for (i, line) in lines.iter().enumerate() {
            if line.starts_with('#') || line.starts_with('[') || line.trim().is_empty() {
                continue;
            }
            keys += 1;
            let comments: Vec<&str> =
                lines[..i].iter().rev().take_while(|l| l.starts_with('#')).copied().collect::<Vec<_>>();
            let joined = comments.join(" ");
            assert!(
                joined.contains("config.json `") || joined.contains("every conversion"),
                "{line}: no comment naming its config.json key: {joined}"
            );
        }
        let conversion = config::convert_legacy_file(&json).unwrap();
        assert_eq!(keys, conversion.notes.len());
        // The length rule names its deviation in the comment.
        assert!(toml_text.contains("config.json `snake_specifications.link_lenght_in_m` = 0.1"), "{toml_text}");
        assert!(toml_text.contains("Differs from the original: with legacy.geometry"), "{toml_text}");
    }
    // Without --force an existing file is kept (exit code 2).
    let out = dir.path().join("converted.toml");
    let o = simserpent(dir.path(), &["convert", thesis_json().to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    // A TOML is not converted.
    let o = simserpent(dir.path(), &["convert", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("original tool's config.json"), "{}", text(&o));
}

#[test]
fn check_prints_the_conversion_notes_once_on_stderr() {
    let dir = tempfile::tempdir().unwrap();
    let o = simserpent(dir.path(), &["check", thesis_json().to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o));
    let stderr = String::from_utf8_lossy(&o.stderr);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert_eq!(
        stderr.matches("`snake_specifications.link_lenght_in_m` = 0.1 -> `snake.link_length_m` = 0.2").count(),
        1,
        "{stderr}"
    );
    assert_eq!(stderr.matches("is the original tool's config.json").count(), 1, "{stderr}");
    assert!(
        stderr.contains("`control_parameters.velocity_actuator_KP` = 0 -> `control.position_kv_nm_s_per_rad` = 0"),
        "{stderr}"
    );
    // The notes are the settings that work differently, once each (stdout keeps the resolved
    // TOML); the settings converted as they were are counted, not listed.
    let conversion = config::convert_legacy_file(&thesis_json()).unwrap();
    let notes = conversion.difference_lines();
    assert!(notes.len() < conversion.note_lines().len() / 2, "{notes:?}");
    for n in &notes {
        assert_eq!(stderr.matches(n.as_str()).count(), 1, "{n}");
    }
    assert!(!stderr.contains("`simulation_time` = 100"), "same value, not listed: {stderr}");
    // The thesis' file drives nothing: one line says so.
    assert_eq!(stderr.matches("nothing drives this snake").count(), 1, "{stderr}");
    assert!(!stdout.contains("note:"));
    // `run` prints the same notes, once.
    let json = thesis_json();
    let out = format!("general.output_dir={:?}", dir.path().join("runs").display().to_string());
    let args = ["run", json.to_str().unwrap(), "--quiet", "--set", "general.duration_secs=0.05", "--set", &out];
    let o = simserpent(dir.path(), &args);
    assert!(o.status.success(), "{}", text(&o));
    let run_stderr = String::from_utf8_lossy(&o.stderr);
    for n in &notes {
        assert_eq!(run_stderr.matches(n.as_str()).count(), 1, "{n}");
    }
    // A TOML config gets no notes.
    let toml = dir.path().join("c.toml");
    std::fs::write(&toml, "").unwrap();
    let o = simserpent(dir.path(), &["check", toml.to_str().unwrap()]);
    assert!(o.status.success());
    assert!(!String::from_utf8_lossy(&o.stderr).contains("note:"));
}

/// The guide's page of the original tool, which holds the two generated tables.
const ORIGINAL_TOOL_PAGE: &str = "guide/src/how-to/original-tool.md";

/// The text between `<!-- name:start -->` and `<!-- name:end -->` in the guide's page.
fn readme_block(name: &str) -> String {
    let readme = std::fs::read_to_string(manifest_dir().join(ORIGINAL_TOOL_PAGE)).unwrap();
    let start = format!("<!-- {name}:start -->\n");
    let end = format!("<!-- {name}:end -->");
    let a = readme.find(&start).unwrap_or_else(|| panic!("{ORIGINAL_TOOL_PAGE} has no {start}")) + start.len();
    let b = readme[a..].find(&end).unwrap_or_else(|| panic!("{ORIGINAL_TOOL_PAGE} has no {end}")) + a;
    readme[a..b].to_string()
}

/// Replaces the guide page's block `name` with `text`.
fn write_readme_block(name: &str, text: &str) {
    let path = manifest_dir().join(ORIGINAL_TOOL_PAGE);
    let readme = std::fs::read_to_string(&path).unwrap();
    let start = format!("<!-- {name}:start -->\n");
    let end = format!("<!-- {name}:end -->");
    let a = readme.find(&start).unwrap() + start.len();
    let b = readme[a..].find(&end).unwrap() + a;
    std::fs::write(&path, format!("{}{text}{}", &readme[..a], &readme[b..])).unwrap();
}

/// The guide's two tables of the original tool are generated from `LEGACY_RULES` and
/// `LEGACY_DEVIATIONS`; after changing those, regenerate them with
/// `SIMSERPENT_BLESS_README=1 cargo test --test it readme_tables_are_the_conversion_data`.
#[test]
fn readme_tables_are_the_conversion_data() {
    let blocks =
        [("legacy-deviations", config::legacy_deviation_table()), ("legacy-rules", config::legacy_rule_table())];
    for (name, table) in blocks {
        if std::env::var_os("SIMSERPENT_BLESS_README").is_some() {
            write_readme_block(name, &table);
        }
        assert_eq!(readme_block(name), table, "{ORIGINAL_TOOL_PAGE} block {name}: regenerate it (see this test's doc)");
    }
}

#[test]
fn every_config_json_key_has_a_rule_and_a_note() {
    let text = std::fs::read_to_string(thesis_json()).unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    let conversion = config::convert_legacy_text(&text, "config.json").unwrap();
    let mut legacy_keys = Vec::new();
    for (k, v) in json.as_object().unwrap() {
        match v.as_object() {
            Some(section) => legacy_keys.extend(section.keys().map(|s| format!("{k}.{s}"))),
            None => legacy_keys.push(k.clone()),
        }
    }
    for key in legacy_keys {
        let rule = config::LEGACY_RULES.iter().find(|r| {
            r.legacy_key == key
                || (r.legacy_key.ends_with('>') && key.starts_with(r.legacy_key.split('.').next().unwrap()))
        });
        assert!(rule.is_some(), "{key}: no rule in LEGACY_RULES");
        if key != "xml_path" && !key.starts_with("terrain.") && !key.starts_with("prebuilt_experiments.") {
            assert!(conversion.notes.iter().any(|n| n.legacy_key == key), "{key}: no note");
        }
    }
    // Every note carries the rule of its own key.
    for n in &conversion.notes {
        let keys = n.rule.simserpent_keys;
        assert!(keys.split(", ").any(|k| k == n.key) || keys.contains('<'), "{}: rule for {keys}", n.key);
    }
    // Every SimSerpent key a note names exists in the default config.
    let defaults: toml::Table = config::DEFAULT_CONFIG_TOML.parse().unwrap();
    for n in &conversion.notes {
        let mut t = &defaults;
        let parts: Vec<&str> = n.key.split('.').collect();
        for p in &parts[..parts.len() - 1] {
            t = t.get(*p).and_then(toml::Value::as_table).unwrap_or_else(|| panic!("{}", n.key));
        }
        assert!(t.contains_key(*parts.last().unwrap()), "{}", n.key);
    }
}

// --- the thesis' PD control ------------------------------------------------------------------------

/// Holds every joint at a fixed target through the position servos.
struct Hold(f64);

impl Controller for Hold {
    fn update(&mut self, _obs: &Observation, cmd: &mut Command) {
        cmd.position_rad.fill(self.0);
    }
}

#[test]
fn velocity_actuator_kp_is_the_position_servos_d_gain() {
    let c = load_config(&exp3_json(), &[]).unwrap();
    assert_eq!(c.control.method, ControlMethod::Position);
    assert_eq!(c.control.position_kp_nm_per_rad, 1.0);
    // Thesis table 7: velocity actuator KP 0.4, the D part of the PD control (thesis 11.1).
    assert_eq!(c.control.position_kv_nm_s_per_rad, 0.4);
    assert_eq!(c.control.velocity_kv_nm_s_per_rad, 0.4);
    let xml = simserpent::model::generate(&c).unwrap().xml;
    assert!(xml.contains("<position name=\"position_01\" joint=\"joint_01\" kp=\"1\" kv=\"0.4\""), "{xml}");

    // In the engine the position servo is the PD law kp (target - q) - kv q' with kv = 0.4.
    let mut c = c;
    c.gait.kind = GaitKind::None;
    c.terrain.kind = TerrainKind::None;
    let world = World::from_config(&c).unwrap();
    let mut sim = Simulation::with_controller(&c, world, Box::new(Hold(0.3)));
    let mut checked = 0;
    for _ in 0..200 {
        sim.step().unwrap();
        let s = snapshot(&mut sim);
        for j in 0..s.joint_angle_rad.len() {
            let pd = 1.0 * (0.3 - s.joint_angle_rad[j]) - 0.4 * s.joint_velocity_rad_per_s[j];
            if pd.abs() < 2.9 {
                let force = s.actuator_force_nm[j][1];
                assert!((force - pd).abs() < 1e-9, "joint {j}: servo force {force}, PD law {pd}");
                checked += 1;
            }
        }
    }
    assert!(checked > 1000, "{checked}");
}

// --- the original capsules ------------------------------------------------------------------------

#[test]
fn faithful_geometry_reproduces_the_original_capsules() {
    // The thesis' config.json: 2 links, link_lenght_in_m 0.10, radius 0.08 (listing 3).
    let faithful = load_config(&thesis_json(), &sets(&["legacy.geometry=\"faithful\""])).unwrap();
    assert_eq!(faithful.legacy.geometry, LegacyGeometry::Faithful);
    let world = World::from_config(&faithful).unwrap();
    let m = world.model();
    let geom_size = m.geom_size();
    let body_pos = world.data().xpos();
    for (i, link) in world.index.links.iter().enumerate() {
        let g = (0..geom_size.len()).find(|&g| world.index.geom_link[g] == Some(i)).unwrap();
        // Capsule radius 0.08, core half-length 0.1: 0.36 m long, as listing 3's size="0.08 0.1".
        assert!((geom_size[g][0] - 0.08).abs() < 1e-12 && (geom_size[g][1] - 0.1).abs() < 1e-12, "{:?}", geom_size[g]);
        // The head's body at x = 0.2 (listing 3), the next 0.2 m further along +x; the axis at
        // z = radius (the original floor was at z = -radius, ours is at 0).
        let expected = [0.2 + 0.2 * i as f64, 0.0, 0.08];
        let p = body_pos[link.body];
        for k in 0..3 {
            assert!((p[k] - expected[k]).abs() < 1e-12, "link {i}: body at {p:?}, expected {expected:?}");
        }
    }
    // Mass and inertia of every link are those of listing 3's geom, as MuJoCo compiles it.
    let listing3 = MjModel::from_xml_string(
        r#"<mujoco><worldbody><body name="head" pos="0.2 0 0"><freejoint/>
           <geom type="capsule" friction="0.5" mass="0.3" pos="0.1 0 0" size="0.08 0.1" zaxis="1 0 0"/>
           </body></worldbody></mujoco>"#,
    )
    .unwrap();
    let mut expected_inertia = listing3.body_inertia()[1];
    expected_inertia.sort_by(f64::total_cmp);
    let yaw = |c: &Config| {
        let w = World::from_config(c).unwrap();
        let mut inertia = w.model().body_inertia()[w.index.links[1].body];
        inertia.sort_by(f64::total_cmp);
        inertia
    };
    let no_overlap = load_config(&thesis_json(), &[]).unwrap();
    assert_eq!(no_overlap.legacy.geometry, LegacyGeometry::NoOverlap);
    let (i_faithful, i_no_overlap) = (yaw(&faithful), yaw(&no_overlap));
    for k in 0..3 {
        assert!((i_faithful[k] - expected_inertia[k]).abs() < 1e-12, "{i_faithful:?} vs {expected_inertia:?}");
    }
    // About the vertical axis (the largest): 0.0029 kg m^2 against 0.00105 for the 0.20 m capsule.
    assert!((i_faithful[2] - 0.0029).abs() < 0.00005, "{i_faithful:?}");
    assert!((i_no_overlap[2] - 0.00105).abs() < 0.00001, "{i_no_overlap:?}");

    // Thesis set C: radius 1 m, link_lenght_in_m 1: capsules, not spheres, in faithful mode.
    let set_c = load_config_str(
        r#"{"snake_specifications": {"nr_of_links": 15, "link_lenght_in_m": 1, "link_radius_in_m": 1,
            "head_position_xyz": [0, 0, 5], "head_rotation_xyz": [180, 0, 0]}}"#,
        config::ConfigSource::LegacyJson,
        &sets(&["legacy.geometry=\"faithful\"", "terrain.kind=\"none\""]),
    )
    .unwrap();
    let xml = simserpent::model::generate(&set_c).unwrap().xml;
    assert!(xml.contains("type=\"capsule\" fromto=\"0 0 0 -2 0 0\" size=\"1\""), "{xml}");
    assert!(!xml.contains("type=\"sphere\""));
    // A radius above half the spacing is allowed in faithful mode only.
    let overlapping = r#"{"snake_specifications": {"link_lenght_in_m": 0.05, "link_radius_in_m": 0.08}}"#;
    assert!(load_config_str(overlapping, config::ConfigSource::LegacyJson, &[]).is_err());
    assert!(
        load_config_str(overlapping, config::ConfigSource::LegacyJson, &sets(&["legacy.geometry=\"faithful\""]))
            .is_ok()
    );
}

#[test]
fn faithful_body_extends_along_plus_x_from_the_head_for_any_rotation() {
    // Set B: head at [10, 5, 0] turned 180 deg about z: the body extends along -x.
    let c = load_config_str(
        r#"{"snake_specifications": {"nr_of_links": 5, "link_lenght_in_m": 2, "link_radius_in_m": 0.5,
            "head_position_xyz": [10, 5, 0], "head_rotation_xyz": [0, 0, 180]}}"#,
        config::ConfigSource::LegacyJson,
        &sets(&["legacy.geometry=\"faithful\"", "terrain.kind=\"none\"", "gait.kind=\"none\""]),
    )
    .unwrap();
    let mut world = World::from_config(&c).unwrap();
    world.forward();
    let xpos = world.data().xpos();
    for (i, link) in world.index.links.iter().enumerate() {
        let p = xpos[link.body];
        let expected = [14.0 - 4.0 * i as f64, 5.0, 0.5];
        for k in 0..3 {
            assert!((p[k] - expected[k]).abs() < 1e-9, "link {i}: {p:?} expected {expected:?}");
        }
    }
}

// --- experiments force their recording -----------------------------------------------------------

#[test]
#[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
fn experiments_record_what_their_analysis_reads_whatever_the_base_config_says() {
    let mut off = load_config(&thesis_json(), &[]).unwrap();
    assert!(!off.recording.enabled && !off.recording.link_position);
    let notes = simserpent::experiments::force_analysis_recording(&mut off);
    assert!(off.recording.enabled && off.recording.link_position && off.recording.contacts);
    assert!(notes.iter().any(|n| n == "recording.enabled = false -> true"), "{notes:?}");

    let mut parquet = Config::default();
    parquet.recording.format = TableFormat::Parquet;
    let notes = simserpent::experiments::force_analysis_recording(&mut parquet);
    assert_eq!(parquet.recording.format, TableFormat::Both);
    assert_eq!(notes.len(), 1, "{notes:?}");
    assert!(simserpent::experiments::force_analysis_recording(&mut Config::default()).is_empty());

    // The thesis' own config.json (store_data = false) runs an experiment to its checks; with the
    // original capsules, experiment I finds every link where the original tool put it.
    let dir = tempfile::tempdir().unwrap();
    let out = format!("general.output_dir={:?}", dir.path().display().to_string());
    let json = thesis_json();
    let args = [
        "experiment",
        "configure",
        "--quick",
        json.to_str().unwrap(),
        "--set",
        &out,
        "--set",
        "legacy.geometry=\"faithful\"",
    ];
    let o = simserpent(dir.path(), &args);
    let all = text(&o);
    assert!(o.status.success(), "{all}");
    assert!(all.contains("note: recording.enabled = false -> true"), "{all}");
    assert!(all.contains("6 of 6 checks passed"), "{all}"); // placement and picture of each set
    // `configure` keeps the original capsules (the other experiments use SimSerpent's links and
    // say so in a note).
    assert!(!all.contains("legacy.geometry = \"faithful\" -> \"no_overlap\""), "{all}");
}
