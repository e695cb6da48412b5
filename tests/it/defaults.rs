//! Defaults that do what they say: the default servos track the default wave (every joint within
//! 90–110 % of its amplitude and 10 % RMS of it, within the ±3 N·m torque range) in the default
//! job and on the bare floor; keys the active controller ignores are reported; start-pose hints
//! that work; optional keys that are optional; URDF robots driven through position servos.

use crate::common::*;
use simserpent::config::{ConfigSource, ControllerKind, load_config_str};
use simserpent::run::{self, RunOptions};
use simserpent::sim::World;
use std::path::Path;

/// Every joint's tracking in `summary` meets the criterion; returns the worst RMS error (%).
fn all_tracked(summary: &run::RunSummary, n_joints: usize) -> f64 {
    let tracking = summary.tracking.as_ref().expect("a tracking report");
    assert_eq!(tracking.len(), n_joints);
    for j in tracking {
        assert!(j.tracks(), "{j:?}");
        assert!((90.0..=110.0).contains(&j.reached_amplitude_percent) && j.rms_error_percent <= 10.0, "{j:?}");
    }
    tracking.iter().map(|j| j.rms_error_percent).fold(0.0, f64::max)
}

/// The default job, whole (20 s from t = 0): path following through the default corridor. Its
/// joints track their commands, the summary and the manifest hold the figures, and the snake
/// passes the corridor without touching a peg.
#[test]
fn the_default_job_tracks_its_commands_and_records_the_figures() {
    let dir = tempfile::tempdir().unwrap();
    let c = default_config_with(&[output_dir(dir.path()), "recording.every_n_steps=100".into()]).unwrap();
    assert_eq!(c.control.controller, ControllerKind::PathFollowing);
    assert_eq!(c.snake.torque_range_nm, [-3.0, 3.0], "the thesis' torque bound");
    let summary = run::run(&c, &RunOptions::default()).unwrap();
    let worst = all_tracked(&summary, c.snake.n_links - 1);
    println!("figures: default job, worst RMS error {worst:.1} % of the commanded amplitude");
    assert!(run::tracking_warning(&c, &summary).is_none());
    assert_eq!(summary.obstacle_contact_secs, 0.0, "the path follower keeps the snake off the corridor's pegs");
    let m = manifest(&summary.run_folder);
    assert_eq!(m["summary"]["tracking"].as_array().map(Vec::len), Some(c.snake.n_links - 1), "{m}");
}

/// A run that ends during the ramp-in (0.5 s of the default job's 1 s): the joints lag a command
/// still growing from rest, so the figures are labelled as the ramp-in's and no warning is given;
/// the same joints judged a second after the ramp-in get their verdict.
#[test]
fn a_run_that_ends_in_the_ramp_in_gets_no_tracking_verdict() {
    let dir = tempfile::tempdir().unwrap();
    let out = output_dir(dir.path());
    let short = default_config_with(&[out.clone(), "general.duration_secs=0.5".into()]).unwrap();
    assert!(short.general.duration_secs < short.gait.ramp_secs);
    let summary = run::run(&short, &RunOptions::default()).unwrap();
    assert!(run::ended_in_ramp_in(&short, &summary));
    let tracking = summary.tracking.as_ref().expect("a tracking report");
    assert!(tracking.iter().any(|t| !t.tracks()), "the ramp-in's lag: {tracking:?}");
    assert!(run::tracking_warning(&short, &summary).is_none());
    let mut after = summary.clone();
    after.simulated_secs = short.gait.ramp_secs + 1.0;
    assert!(!run::ended_in_ramp_in(&short, &after));
    assert!(run::tracking_warning(&short, &after).is_some());
    let printed = simserpent(dir.path(), &["run", "--set", "general.duration_secs=0.5", "--set", &out]);
    assert!(printed.status.success());
    let stdout = String::from_utf8_lossy(&printed.stdout);
    let stderr = String::from_utf8_lossy(&printed.stderr);
    assert!(stdout.contains("(during the ramp-in, which the run ended in: no verdict;"), "{stdout}");
    assert!(!stdout.contains("(not tracked)") && !stderr.contains("do not track"), "{stdout}\n{stderr}");
}

/// The open-loop gait (20 s from t = 0): tracked by the default servos on the bare floor, every
/// joint within 90–110 % of its amplitude and 10 % RMS error, and when pegs do hold
/// joints back, the tracking warning names the contact as what to look at first. (In the default
/// corridor nothing keeps the open loop inside it, and whether it reaches the pegs is chaotic:
/// from the default start it touches them for 8.3 s of 20.)
#[test]
fn an_open_loop_gait_is_tracked_on_the_bare_floor_and_peg_contact_is_named_first() {
    let dir = tempfile::tempdir().unwrap();
    let c = default_config_with(&[
        output_dir(dir.path()),
        "control.controller=\"gait\"".into(),
        "recording.every_n_steps=100".into(),
        "terrain.kind=\"none\"".into(),
    ])
    .unwrap();
    let mut summary = run::run(&c, &RunOptions::default()).unwrap();
    let worst = all_tracked(&summary, c.snake.n_links - 1);
    println!("figures: default gait open loop on the bare floor, worst RMS error {worst:.1} %");
    assert_eq!(summary.obstacle_contact_secs, 0.0);
    assert!(run::tracking_warning(&c, &summary).is_none());
    // A joint held back by a peg for 3.2 s of the run: the warning names the contact first.
    summary.obstacle_contact_secs = 3.2;
    if let Some(joints) = summary.tracking.as_mut() {
        joints[4].rms_error_percent = 51.0;
    }
    let warning = run::tracking_warning(&c, &summary).expect("a joint misses");
    assert!(warning.contains("but first: the snake touched obstacles for 3.2 s"), "{warning}");
}

/// Keys the active controller does not use are named on stderr, with the controller.
#[test]
fn keys_the_controller_ignores_are_reported() {
    let dir = tempfile::tempdir().unwrap();
    let o = simserpent(dir.path(), &["check", "--set", "gait.sine_wave.offset_deg=10.0"]);
    assert!(o.status.success(), "{}", text(&o));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains(
            "warning: gait.sine_wave.offset_deg = 10.0 has no effect: control.controller = \"path_following\""
        ),
        "{stderr}"
    );
    // Used by the open-loop gait: no warning.
    let o = simserpent(
        dir.path(),
        &["check", "--set", "gait.sine_wave.offset_deg=10.0", "--set", "control.controller=\"gait\""],
    );
    assert!(!String::from_utf8_lossy(&o.stderr).contains("warning:"), "{}", text(&o));
    // The default config warns about nothing.
    let o = simserpent(dir.path(), &["check"]);
    assert!(!String::from_utf8_lossy(&o.stderr).contains("warning:"), "{}", text(&o));
}

/// A 16 × 16 gray PNG rising linearly from black (left, -x) to white (right, +x).
fn write_ramp_png(path: &Path) {
    crate::common::write_gray_png_of(path, 16, 16, |c, _| (c * 255 / 15) as u8);
}

/// A snake started inside a heightfield is refused with the height to raise it by; raising it by
/// exactly that much starts it clear (and half of it does not).
#[test]
fn the_start_hint_raises_the_snake_clear_of_a_heightfield() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("ramp.png");
    write_ramp_png(&png);
    let mut c = default_config_with(&["terrain.kind=\"none\"".into()]).unwrap();
    c.terrain.heightfield.file = png.display().to_string();
    c.terrain.heightfield.size_x_m = 4.0;
    c.terrain.heightfield.size_y_m = 4.0;
    c.terrain.heightfield.height_m = 0.3;
    let e = World::from_config(&c).err().expect("the snake starts inside the ramp").to_string();
    let hint = e.split("up by ").nth(1).unwrap_or_else(|| panic!("no hint: {e}"));
    let raise_m: f64 = hint.split(" m").next().unwrap().parse().unwrap_or_else(|_| panic!("{e}"));
    assert!(raise_m > 0.1 && raise_m < 0.3, "{e}");
    let mut raised = c.clone();
    raised.snake.head_position_m[2] += raise_m;
    World::from_config(&raised).unwrap_or_else(|e| panic!("raised by the printed {raise_m} m: {e}"));
    let mut half = c.clone();
    half.snake.head_position_m[2] += raise_m / 2.0;
    assert!(World::from_config(&half).is_err(), "half of the hint is not enough");
}

/// `rotation_deg` and `scale` of a mesh obstacle are optional: [0, 0, 0] and 1.
#[test]
fn mesh_obstacle_rotation_and_scale_are_optional() {
    let rock = data("rock.stl").display().to_string();
    let text =
        format!("[terrain]\nkind = \"none\"\nmesh_obstacles = [{{ file = {rock:?}, position_m = [3.0, 3.0, 0.0] }}]\n");
    let c = load_config_str(&text, ConfigSource::Toml, &[]).unwrap();
    let m = &c.terrain.mesh_obstacles[0];
    assert_eq!((m.rotation_deg, m.scale), ([0.0; 3], 1.0));
    let with = format!(
        "[terrain]\nkind = \"none\"\nmesh_obstacles = [{{ file = {rock:?}, position_m = [3.0, 3.0, 0.0], rotation_deg = \
         [0.0, 0.0, 0.0], scale = 1.0 }}]\n"
    );
    let explicit = load_config_str(&with, ConfigSource::Toml, &[]).unwrap();
    assert_eq!(
        simserpent::model::generate(&c).unwrap().xml,
        simserpent::model::generate(&explicit).unwrap().xml,
        "the defaults are the explicit [0, 0, 0] and 1"
    );
}

/// A URDF has no actuators: its joints are passive and the run says so; with
/// `robot.position_servos` every joint gets a position servo and the gait drives it.
#[test]
fn urdf_joints_get_position_servos_from_the_config() {
    let dir = tempfile::tempdir().unwrap();
    let urdf = data("urdf_snake.urdf");
    let options = RunOptions { robot: Some(urdf.clone()), ..RunOptions::default() };
    let base = |extra: &[&str]| {
        let mut o = vec![output_dir(dir.path()), "terrain.kind=\"none\"".into(), "general.duration_secs=4.0".into()];
        o.extend(extra.iter().map(|s| s.to_string()));
        default_config_with(&o).unwrap()
    };
    // Passive: the run says which joints no actuator drives.
    let passive = base(&["gait.kind=\"none\""]);
    let summary = run::run(&passive, &options).unwrap();
    assert_eq!(summary.notes.len(), 1, "{:?}", summary.notes);
    assert!(summary.notes[0].contains("2 of the 2 joints") && summary.notes[0].contains("joint_a, joint_b"));
    assert!(summary.notes[0].contains("robot.position_servos = true"), "{:?}", summary.notes);
    // A gait without servos is refused, naming the switch.
    let e = run::run(&base(&["control.controller=\"gait\""]), &options).expect_err("no actuators").to_string();
    assert!(e.contains("robot.position_servos = true"), "{e}");
    // With the switch the joints follow a 20° wave.
    let driven =
        base(&["control.controller=\"gait\"", "robot.position_servos=true", "gait.sine_wave.amplitude_deg=20.0"]);
    let world = run::build_world(&driven, &options).unwrap();
    assert!(world.passive_joints().is_empty());
    let actuators: Vec<String> = (0..world.model().nu() as usize)
        .map(|a| world.model().id_to_name(mujoco_rs::prelude::MjtObjBase::mjOBJ_ACTUATOR, a).unwrap().to_string())
        .collect();
    assert_eq!(actuators, ["joint_a_position_servo", "joint_b_position_servo"]);
    let summary = run::run(&driven, &options).unwrap();
    assert!(summary.notes.is_empty(), "{:?}", summary.notes);
    all_tracked(&summary, 2);
}

/// The thesis' own config.json says in one line that nothing moves its snake.
#[test]
fn the_thesis_config_says_its_snake_lies_still() {
    let dir = tempfile::tempdir().unwrap();
    let json = manifest_dir().join("examples/thesis/config.json");
    let out = format!("general.output_dir={:?}", dir.path().display().to_string());
    let o = simserpent(
        dir.path(),
        &["run", json.to_str().unwrap(), "--quiet", "--set", "general.duration_secs=0.05", "--set", &out],
    );
    assert!(o.status.success(), "{}", text(&o));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(stderr.matches("note: nothing drives this snake").count(), 1, "{stderr}");
    assert!(stderr.lines().count() < 20, "a short set of notes: {stderr}");
}
