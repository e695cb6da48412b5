//! Silent surprises, each a test that failed before its fix: a user's robot and its
//! actuators, the model file with a third-party terrain, `render --images` without times, a
//! start inside the terrain, the IMU switch, gait tracking, the sensors table's time, the
//! initial state from the config, and the links' heading.

use crate::common::{data, default_config_with, output_dir, read_csv, run_folders, simserpent, text};
use mujoco_rs::prelude::*;
use mujoco_rs::wrappers::mj_model::MjtObjBase;
use simserpent::config::Config;
use simserpent::run::{self, RunOptions};
use simserpent::sim::{Simulation, Snapshot, World};
use std::collections::HashMap;
use std::path::Path;

fn config(overrides: &[&str]) -> Config {
    let o: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    default_config_with(&o).unwrap()
}

/// Column `name` of a CSV table as numbers.
fn column(header: &[String], rows: &[Vec<String>], name: &str) -> Vec<f64> {
    let k = header.iter().position(|h| h == name).unwrap_or_else(|| panic!("no column {name} in {header:?}"));
    rows.iter().map(|r| r[k].parse().unwrap()).collect()
}

// --- 1. a user's robot -----------------------------------------------------------------------

/// The lowest contact distance (m) of the robot's geoms with the floor at the world's start
/// (`None` without floor contact).
fn start_floor_distance_m(world: &World) -> Option<f64> {
    let floor = world.model().name_to_id(MjtObjBase::mjOBJ_GEOM, "floor")? as i32;
    world.data().contact().iter().filter(|c| c.geom.contains(&floor)).map(|c| c.dist).reduce(f64::min)
}

#[test]
fn a_urdf_robot_floats_and_starts_on_the_floor_not_inside_it() {
    // Before: MuJoCo welded the URDF's base link to the world at z = 0, half inside the floor.
    let c = config(&["gait.kind=\"none\"", "terrain.kind=\"none\""]);
    let options = RunOptions { robot: Some(data("two_link.urdf")), ..RunOptions::default() };
    let world = run::build_world(&c, &options).unwrap();
    assert!(world.index.head_free_qpos_adr.is_some(), "the base link got a free joint");
    let names: Vec<&str> = world.index.links.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, ["base", "arm"], "the base link keeps its own body and mass");
    assert!((world.index.robot_mass_kg - 1.5).abs() < 1e-12);
    // The base box (half height 0.05 m) touches the floor: distance 0, no penetration.
    let d = start_floor_distance_m(&world).expect("the robot rests on the floor");
    assert!(d.abs() < 1e-9, "start distance to the floor {d} m");
    // It rests: after 0.5 s the floor carries its weight with a resting penetration, not kilonewtons.
    let mut sim = Simulation::new(&c, world);
    let mut s = Snapshot::new(sim.world().n_links(), sim.world().n_joints());
    for _ in 0..500 {
        sim.control();
        sim.advance().unwrap();
    }
    sim.control();
    sim.snapshot(&mut s);
    let weight_n = 1.5 * 9.81;
    let normal: f64 = s.link_floor_force_n.iter().map(|f| f[2]).sum();
    assert!((normal - weight_n).abs() < 0.02 * weight_n, "floor carries {normal} N of {weight_n} N");
    assert!(s.max_penetration_m() < 1e-3, "{} m", s.max_penetration_m());

    // Welded where asked: no free joint, lowest point on the floor, moved and turned.
    let welded = config(&[
        "gait.kind=\"none\"",
        "terrain.kind=\"none\"",
        "robot.floating_base=false",
        "robot.position_m=[1.0, 2.0, 5.0]",
        "robot.rotation_deg=[0.0, 0.0, 90.0]",
    ]);
    let world = run::build_world(&welded, &options).unwrap();
    assert!(world.index.head_free_qpos_adr.is_none());
    let base = world.model().name_to_id(MjtObjBase::mjOBJ_BODY, "base").unwrap();
    let p = world.data().xpos()[base];
    assert!((p[0] - 1.0).abs() < 1e-12 && (p[1] - 2.0).abs() < 1e-12 && (p[2] - 0.05).abs() < 1e-12, "{p:?}");
    let arm = world.model().name_to_id(MjtObjBase::mjOBJ_BODY, "arm").unwrap();
    let a = world.data().xpos()[arm];
    // The arm's origin is 0.1 m along the base's x, turned 90° about z: along +y.
    assert!((a[0] - 1.0).abs() < 1e-9 && (a[1] - 2.1).abs() < 1e-9, "{a:?}");
    // place_on_floor = false keeps position_m[2]; a start inside the floor is refused.
    let sunk = config(&[
        "gait.kind=\"none\"",
        "terrain.kind=\"none\"",
        "robot.place_on_floor=false",
        "robot.position_m=[0.0, 0.0, 0.0]",
    ]);
    let e = run::build_world(&sunk, &options).err().expect("starts 50 mm inside the floor").to_string();
    assert!(e.contains("robot.position_m") && e.contains("50.0 mm") && e.contains("floor"), "{e}");
}

#[test]
fn a_robot_actuator_of_another_kind_than_the_control_method_is_refused() {
    // two_link_arm.xml drives its elbow with a <position> servo; the PID's torques must not go there.
    let options = RunOptions { robot: Some(data("two_link_arm.xml")), ..RunOptions::default() };
    let torque = config(&["control.method=\"torque\"", "terrain.kind=\"none\""]);
    let e = run::build_world(&torque, &options).err().expect("a torque command into a position servo").to_string();
    for part in ["elbow_servo", "<position> servo", "control.method = \"torque\"", "control.method = \"position\""] {
        assert!(e.contains(part), "{part:?} missing in: {e}");
    }
    // With the matching method the servo is found in its own slot (and recorded as such).
    let position = config(&["control.method=\"position\"", "terrain.kind=\"none\""]);
    let world = run::build_world(&position, &options).unwrap();
    let joint = &world.index.joints[0];
    assert_eq!(joint.actuators.map(|a| a.is_some()), [false, true, false, false]);
    // Through the command line: exit code 2, no run folder.
    let dir = tempfile::tempdir().unwrap();
    let robot = data("two_link_arm.xml");
    let out = simserpent(
        dir.path(),
        &["run", "--robot", robot.to_str().unwrap(), "--set", "control.method=\"torque\"", "--quiet"],
    );
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
    assert!(run_folders(dir.path()).is_empty());
}

// --- 2. model -o with a third-party terrain --------------------------------------------------

#[test]
fn a_written_model_with_a_third_party_terrain_loads() {
    let dir = tempfile::tempdir().unwrap();
    let terrain = data("third_party_terrain/terrain.xml");
    let out_dir = dir.path().join("out");
    std::fs::create_dir(&out_dir).unwrap();
    let model_file = out_dir.join("model.xml");
    let out = simserpent(
        dir.path(),
        &[
            "model",
            "--set",
            &format!("terrain.include_mjcf={:?}", terrain.display().to_string()),
            "-o",
            model_file.to_str().unwrap(),
        ],
    );
    assert!(out.status.success(), "{}", text(&out));
    assert!(text(&out).contains("user_terrain.xml"), "{}", text(&out));
    let model = MjModel::from_xml(&model_file).unwrap_or_else(|e| panic!("the written model does not load: {e}"));
    assert!(model.name_to_id(MjtObjBase::mjOBJ_GEOM, "tp_rock").is_some(), "the terrain's mesh rock is in it");
    // To stdout: the model, and a note on stderr that the included file is not in it.
    let out = simserpent(
        dir.path(),
        &["model", "--set", &format!("terrain.include_mjcf={:?}", terrain.display().to_string())],
    );
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("model -o FILE"), "{}", text(&out));
}

// --- 3. render --images without image times --------------------------------------------------

#[cfg(offscreen_render)]
#[test]
fn render_images_without_image_times_fails_naming_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let out = simserpent(
        dir.path(),
        &[
            "run",
            "--set",
            "general.duration_secs=0.05",
            "--set",
            "snake.n_links=3",
            "--set",
            "terrain.kind=\"none\"",
            "--quiet",
        ],
    );
    assert!(out.status.success(), "{}", text(&out));
    let run = &run_folders(dir.path())[0];
    let out = simserpent(dir.path(), &["render", run.to_str().unwrap(), "--images"]);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
    assert!(text(&out).contains("render.image_times_secs"), "{}", text(&out));
    assert!(!run.join("images").exists());
}

// --- 4. a start inside the terrain ------------------------------------------------------------

#[test]
fn a_snake_starting_inside_a_slope_heightfield_or_mesh_is_refused_naming_the_depth() {
    // A 10° slope whose foot is 1.5 m behind the head: at the head it stands 0.26 m high.
    let slope = config(&[
        "terrain.kind=\"none\"",
        "terrain.slope.angle_deg=10.0",
        "terrain.slope.start_m=[-1.5, 0.0]",
        "terrain.slope.length_m=3.0",
        "terrain.slope.width_m=1.0",
    ]);
    let e = World::from_config(&slope).err().expect("the snake starts inside the slope").to_string();
    for part in ["snake.head_position_m", "terrain_slope", "the slope (terrain.slope.*)", "mm deep"] {
        assert!(e.contains(part), "{part:?} missing in: {e}");
    }
    // Through the command line: bad input, exit code 2, no run folder.
    let dir = tempfile::tempdir().unwrap();
    let out = simserpent(
        dir.path(),
        &[
            "run",
            "--set",
            "terrain.kind=\"none\"",
            "--set",
            "terrain.slope.angle_deg=10.0",
            "--set",
            "terrain.slope.start_m=[-1.5, 0.0]",
        ],
    );
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
    assert!(run_folders(dir.path()).is_empty());
    // A heightfield (uniformly 0.1 m high) and a mesh rock over the snake's start.
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("plateau.png");
    crate::common::write_gray_png(&png, 8, 8, &[255u8; 64]);
    let hfield = config(&[
        "terrain.kind=\"none\"",
        &format!("terrain.heightfield.file={:?}", png.display().to_string()),
        "terrain.heightfield.center_m=[-1.0, 0.0]",
        "terrain.heightfield.height_m=0.1",
    ]);
    let e = World::from_config(&hfield).err().expect("the snake starts inside the heightfield").to_string();
    assert!(e.contains("the heightfield (terrain.heightfield.*)") && e.contains("mm deep"), "{e}");
    let rock = config(&[
        "terrain.kind=\"none\"",
        &format!(
            "terrain.mesh_obstacles=[{{ file = {:?}, position_m = [-0.5, 0.0, 0.0], rotation_deg = [0.0, 0.0, 0.0], scale = 2.0 }}]",
            data("rock.stl").display().to_string()
        ),
    ]);
    let e = World::from_config(&rock).err().expect("the snake starts inside the rock").to_string();
    assert!(e.contains("an obstacle") && e.contains("obstacle_00"), "{e}");
    // A one-link snake placed on the same kind of slope starts clear.
    let mut on_slope = crate::common::one_link();
    crate::common::place_link_on_slope(&mut on_slope, 10.0, 1.0);
    World::from_config(&on_slope).unwrap();
}

// --- 5. recording.imu_sensors = false ---------------------------------------------------------
// (tests/it/cli.rs: recording_switches_choose_the_columns)

// --- 6. tracking ------------------------------------------------------------------------------

/// A 10° wave at `frequency_hz` on a bare floor (the default's obstacles block some joints, which
/// is no servo's fault) with everything else default, 3 s, every step recorded.
fn wave(dir: &Path, frequency_hz: f64, extra: &[&str]) -> Config {
    let mut o = vec![
        output_dir(dir),
        "terrain.kind=\"none\"".into(),
        "general.duration_secs=3.0".into(),
        "gait.sine_wave.amplitude_deg=10.0".into(),
        format!("gait.sine_wave.frequency_hz={frequency_hz}"),
        "recording.every_n_steps=1".into(),
        "recording.contacts=false".into(),
        // Tracking is measured against the open-loop gait (path following adds its offsets).
        "control.controller=\"gait\"".into(),
    ];
    o.extend(extra.iter().map(|s| s.to_string()));
    default_config_with(&o).unwrap()
}

#[test]
fn the_summary_reports_tracking_per_joint_and_warns_when_the_gait_is_not_tracked() {
    let dir = tempfile::tempdir().unwrap();
    // A weak position servo (kp 5 N·m/rad) on a default 10-link snake.
    let weak = ["control.position_kp_nm_per_rad=5.0", "control.position_kv_nm_s_per_rad=0.1"];
    let c = wave(dir.path(), 1.0, &weak);
    let summary = run::run(&c, &RunOptions::default()).unwrap();
    let tracking = summary.tracking.clone().expect("a tracking report");
    assert_eq!(tracking.len(), c.snake.n_links - 1);
    // The same numbers from joints.csv and the wave's formula (t >= ramp_secs).
    let (header, rows) = read_csv(&summary.run_folder.join("joints.csv"));
    let time = column(&header, &rows, "time_s");
    let w = &c.gait.sine_wave;
    for (j, report) in tracking.iter().enumerate() {
        let angle = column(&header, &rows, &format!("joint_{:02}_angle_rad", j + 1));
        let (mut sum, mut max, mut n) = (0.0, 0.0f64, 0);
        for (t, a) in time.iter().zip(&angle) {
            if *t < c.gait.ramp_secs {
                continue;
            }
            let phase = std::f64::consts::TAU * w.frequency_hz * t - j as f64 * w.phase_lag_deg.to_radians();
            let e = a - w.amplitude_deg.to_radians() * phase.sin();
            sum += e * e;
            max = max.max(e.abs());
            n += 1;
        }
        let rms = (sum / n as f64).sqrt();
        assert!((report.rms_error_rad - rms).abs() < 1e-9, "{}: {} vs {rms}", report.joint, report.rms_error_rad);
        assert!((report.max_error_rad - max).abs() < 1e-9, "{}", report.joint);
        assert!((report.command_amplitude_rad - 10f64.to_radians()).abs() < 1e-4, "{report:?}");
    }
    let reached: Vec<String> = tracking.iter().map(|t| format!("{:.0}", t.reached_amplitude_percent)).collect();
    let rms: Vec<String> = tracking.iter().map(|t| format!("{:.0}", t.rms_error_percent)).collect();
    println!(
        "figures: kp 5, 10 deg at 1 Hz, bare floor: reached amplitude % per joint {reached:?}, RMS error % {rms:?}"
    );
    assert!(tracking.iter().any(|t| !t.tracks()), "{tracking:?}");
    let warning = run::tracking_warning(&c, &summary).expect("kp 5 cannot track a 10° wave at 1 Hz");
    assert!(warning.contains("control.position_kp_nm_per_rad = 5"), "{warning}");
    // A stiff servo tracks the same wave: no warning.
    // (The middle joints move the most mass against friction: with the default ±3 N·m they
    // saturate even with a stiff servo, so the torque range goes up too.)
    let stiff = wave(
        dir.path(),
        1.0,
        &[
            "control.position_kp_nm_per_rad=400.0",
            "control.position_kv_nm_s_per_rad=1.0",
            "snake.torque_range_nm=[-20.0, 20.0]",
        ],
    );
    let summary = run::run(&stiff, &RunOptions::default()).unwrap();
    let tracking = summary.tracking.clone().unwrap();
    let reached: Vec<String> = tracking.iter().map(|t| format!("{:.0}", t.reached_amplitude_percent)).collect();
    println!("figures: kp 400, kv 1, +-20 N m, 10 deg at 1 Hz, bare floor: reached amplitude % per joint {reached:?}");
    assert!(tracking.iter().all(|t| t.tracks()), "{tracking:?}");
    assert!(run::tracking_warning(&stiff, &summary).is_none());
    // The command line prints the table and the warning.
    let out = simserpent(
        dir.path(),
        &[
            "run",
            "--set",
            "general.duration_secs=2.0",
            "--set",
            "gait.sine_wave.amplitude_deg=10.0",
            "--set",
            "gait.sine_wave.frequency_hz=1.0",
            "--set",
            "recording.enabled=false",
            "--set",
            "control.controller=\"gait\"",
            "--set",
            weak[0],
            "--set",
            weak[1],
            "--quiet",
        ],
    );
    assert!(out.status.success(), "{}", text(&out));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("tracking of the commanded joint angles") && stdout.contains("joint_01"), "{stdout}");
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("warning: the joints do not track their commanded angles"),
        "{}",
        text(&out)
    );
}

// --- 7. sensors.csv holds the previous step's sensors -----------------------------------------

#[test]
fn the_documented_join_pairs_each_sensor_row_with_the_state_it_measured() {
    let dir = tempfile::tempdir().unwrap();
    let c = config(&[
        &output_dir(dir.path()),
        "general.duration_secs=0.5",
        "gait.ramp_secs=0.0",
        "terrain.kind=\"none\"",
        "recording.every_n_steps=1",
        "recording.contacts=false",
    ]);
    let folder = crate::common::run_folder(&c);
    let (sh, srows) = read_csv(&folder.join("sensors.csv"));
    let (jh, jrows) = read_csv(&folder.join("joints.csv"));
    // pandas: sensors.drop(columns="time_s").merge(joints, left_on="sensor_time_s", right_on="time_s")
    let at: HashMap<&str, usize> = jrows.iter().enumerate().map(|(i, r)| (r[0].as_str(), i)).collect();
    let st = sh.iter().position(|h| h == "sensor_time_s").unwrap();
    let col = |h: &[String], name: &str| h.iter().position(|x| x == name).unwrap();
    // Measured by the step's model evaluation: the force/torque sensors (and the IMU), at
    // sensor_time_s. (The actuator torque comes from the step too; with the default RK4 from its
    // last stage, so it matches no recorded instant exactly: README.)
    let previous = [
        ("joint_03_force_sensor_true_x_n", "joint_03_internal_force_x_n"),
        ("joint_03_torque_sensor_true_z_nm", "joint_03_internal_torque_z_nm"),
    ];
    // Read from the state itself: the encoders, at time_s.
    let current = [
        ("joint_03_encoder_true_rad", "joint_03_angle_rad"),
        ("joint_03_encoder_velocity_true_rad_per_s", "joint_03_velocity_rad_per_s"),
    ];
    let (mut joined, mut lagging) = (0, 0);
    for (k, s) in srows.iter().enumerate() {
        let Some(&i) = at.get(s[st].as_str()) else { panic!("sensor_time_s {} is no time_s of joints.csv", s[st]) };
        joined += 1;
        // Row 0's force/torque values come from the evaluation at t = 0 before the first command
        // and floor friction were applied (there is no earlier step; README), so they describe
        // x_0 without the forces of row 0 of joints.csv: compared from row 1 on.
        let compared: &[(&str, &str)] = if k == 0 { &[] } else { &previous };
        for &(sensor, state) in compared {
            assert_eq!(s[col(&sh, sensor)], jrows[i][col(&jh, state)], "row {k}: {sensor} vs {state} at {}", s[st]);
        }
        for (sensor, state) in current {
            assert_eq!(s[col(&sh, sensor)], jrows[k][col(&jh, state)], "row {k}: {sensor} vs {state} at time_s");
        }
        // Joined on time_s instead, the force sensor is one step behind the joint.
        if s[col(&sh, previous[0].0)] != jrows[k][col(&jh, previous[0].1)] {
            lagging += 1;
        }
    }
    assert_eq!(joined, srows.len());
    assert!(lagging > srows.len() / 2, "joining on time_s pairs other instants ({lagging} of {})", srows.len());
}

// --- 8. the initial state from the config ----------------------------------------------------

#[test]
fn initial_joint_angles_and_velocity_come_from_the_config() {
    let c = config(&[
        "snake.n_links=4",
        "terrain.kind=\"none\"",
        "gait.kind=\"none\"",
        "general.gravity_m_per_s2=[0.0, 0.0, 0.0]",
        "snake.head_position_m=[0.0, 0.0, 1.0]",
        "snake.head_rotation_deg=[90.0, 0.0, 30.0]",
        "initial_state.joint_angles_deg=[10.0, -20.0, 30.0]",
        "initial_state.linear_velocity_m_per_s=[1.0, 0.5, 0.0]",
        "initial_state.angular_velocity_rad_per_s=[0.0, 0.0, 2.0]",
    ]);
    let world = World::from_config(&c).unwrap();
    let mut sim = Simulation::new(&c, world);
    let mut s = Snapshot::new(4, 3);
    sim.control();
    sim.snapshot(&mut s);
    for (a, want) in s.joint_angle_rad.iter().zip([10.0f64, -20.0, 30.0]) {
        assert!((a - want.to_radians()).abs() < 1e-12, "{a}");
    }
    assert!(s.joint_velocity_rad_per_s.iter().all(|v| v.abs() < 1e-12));
    // A rigid motion: each link's centre moves with v + ω × (centre − head tip).
    let tip = [0.0, 0.0, 1.0 + c.snake.link_radius_m];
    let (v, w) = ([1.0, 0.5, 0.0], [0.0, 0.0, 2.0]);
    for (i, (p, vel)) in s.link_position_m.iter().zip(&s.link_velocity_m_per_s).enumerate() {
        let r = [p[0] - tip[0], p[1] - tip[1], p[2] - tip[2]];
        let want =
            [v[0] + w[1] * r[2] - w[2] * r[1], v[1] + w[2] * r[0] - w[0] * r[2], v[2] + w[0] * r[1] - w[1] * r[0]];
        for k in 0..3 {
            assert!((vel[k] - want[k]).abs() < 1e-9, "link {i}: {vel:?} vs {want:?}");
        }
    }
    // Without a gait the servos hold the starting angles (before, they pulled the joints back to
    // zero): no gravity, no contact, no spin, so nothing else moves them.
    let still = config(&[
        "snake.n_links=4",
        "terrain.kind=\"none\"",
        "gait.kind=\"none\"",
        "general.gravity_m_per_s2=[0.0, 0.0, 0.0]",
        "snake.head_position_m=[0.0, 0.0, 1.0]",
        "initial_state.joint_angles_deg=[10.0, -20.0, 30.0]",
    ]);
    let mut sim = Simulation::new(&still, World::from_config(&still).unwrap());
    for _ in 0..300 {
        sim.control();
        sim.advance().unwrap();
    }
    sim.control();
    sim.snapshot(&mut s);
    for (a, want) in s.joint_angle_rad.iter().zip([10.0f64, -20.0, 30.0]) {
        assert!((a - want.to_radians()).abs() < 1e-9, "{a} vs {want}°");
    }
    // Bad values name the key and what is allowed.
    let o = |x: &str| default_config_with(&["snake.n_links=4".into(), x.into()]);
    let e = o("initial_state.joint_angles_deg=[1.0, 2.0]").unwrap_err().to_string();
    assert!(e.contains("initial_state.joint_angles_deg") && e.contains("3 joints"), "{e}");
    let e = o("initial_state.joint_angles_deg=[1.0, 2.0, 170.0]").unwrap_err().to_string();
    assert!(e.contains("joint_03") && e.contains("snake.joint_range_deg"), "{e}");
    let e = o("initial_state.linear_velocity_m_per_s=[1.0, nan, 0.0]").unwrap_err().to_string();
    assert!(e.contains("initial_state.linear_velocity_m_per_s"), "{e}");
}

// --- 9. the links' heading --------------------------------------------------------------------

#[test]
fn links_carry_a_readable_yaw_next_to_the_quaternion() {
    let dir = tempfile::tempdir().unwrap();
    let c = config(&[
        &output_dir(dir.path()),
        "general.duration_secs=0.3",
        "snake.n_links=3",
        "terrain.kind=\"none\"",
        "snake.head_rotation_deg=[0.0, 0.0, 30.0]",
        if cfg!(feature = "parquet") { "recording.format=\"both\"" } else { "recording.format=\"csv\"" },
    ]);
    let folder = crate::common::run_folder(&c);
    let (h, rows) = read_csv(&folder.join("links.csv"));
    let k = h.iter().position(|x| x == "link_00_orientation_qz").unwrap();
    assert_eq!(h[k + 1], "link_00_yaw_rad", "next to the quaternion");
    let yaw = column(&h, &rows, "link_00_yaw_rad");
    assert!((yaw[0] - 30f64.to_radians()).abs() < 1e-9, "{}", yaw[0]);
    let q: Vec<Vec<f64>> =
        ["qw", "qx", "qy", "qz"].iter().map(|c| column(&h, &rows, &format!("link_01_orientation_{c}"))).collect();
    for (i, y) in column(&h, &rows, "link_01_yaw_rad").iter().enumerate() {
        let (w, x, yy, z) = (q[0][i], q[1][i], q[2][i], q[3][i]);
        let want = (2.0 * (x * yy + w * z)).atan2(1.0 - 2.0 * (yy * yy + z * z));
        assert!((y - want).abs() < 1e-12);
    }
    if cfg!(feature = "parquet") {
        assert!(
            folder.join("links.parquet").exists(),
            "Parquet has the same columns (tests/it/parquet.rs compares them)"
        );
    }
}
