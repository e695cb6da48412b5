//! Locomotion physics: ground friction models against their definitions, and shorter versions of
//! the experiment checks (the full ones: `simserpent experiment <name>`).

use crate::common::one_link;
use simserpent::config::{Config, ControlMethod, FloorFriction, GaitKind, GroundModel, TerrainKind};
use simserpent::experiments::{Check, run_experiment};
use simserpent::sim::{Simulation, Snapshot, World};

/// One 0.3 kg link lying on the floor, yawed by 30°, no gait.
fn yawed_link(model: GroundModel) -> Config {
    let mut c = one_link();
    c.snake.head_rotation_deg = [0.0, 0.0, 30.0];
    c.ground.model = model;
    c.ground.axial_friction = 0.1;
    c.ground.backward_friction = 0.3;
    c.ground.lateral_friction = 1.0;
    c
}

/// Settles the link on the floor for 0.3 s (it starts just touching the floor: its normal force
/// rises to the weight over the first steps, and with `"stick_slip"` the friction of a step
/// follows the previous step's normal force), then launches it with `speed` along its axis (angle
/// 0) or across it (angle 90°).
fn launch(config: &Config, direction_deg: f64, speed: f64) -> Simulation {
    let mut sim = Simulation::new(config, World::from_config(config).unwrap());
    for _ in 0..(0.3 / config.general.timestep_secs).round() as usize {
        sim.step().unwrap();
    }
    let heading = (30.0 + direction_deg).to_radians();
    let qvel = sim.world_mut().qvel_mut();
    qvel[0] = speed * heading.cos();
    qvel[1] = speed * heading.sin();
    sim.world_mut().forward();
    sim
}

/// The friction coefficient the link meets: the largest ratio of horizontal friction force to
/// normal force over its first 15 steps of sliding. Coulomb friction never exceeds μ·N and equals
/// it while sliding; a link sliding sideways soon rolls without slipping (after v/(3·μ·g) ≈ 17 ms),
/// so only the first milliseconds show sliding friction across the link.
fn friction_ratio(config: &Config, direction_deg: f64) -> f64 {
    let mut sim = launch(config, direction_deg, 0.5);
    crate::common::largest_floor_friction_ratio(&mut sim, 15)
}

/// Both floor-friction laws: SimSerpent's (the default) and MuJoCo's friction constraints.
const FLOOR_FRICTIONS: [FloorFriction; 2] = [FloorFriction::StickSlip, FloorFriction::Mujoco];

#[test]
fn anisotropic_friction_differs_along_and_across_the_link() {
    // "mujoco": MuJoCo aligns a capsule-plane contact frame with the capsule axis (yawed 30° here).
    for law in FLOOR_FRICTIONS {
        let mut c = yawed_link(GroundModel::Anisotropic);
        c.physics.floor_friction = law;
        let along = friction_ratio(&c, 0.0);
        assert!((along - 0.1).abs() < 0.003, "{law:?}: axial friction coefficient {along}");
        let across = friction_ratio(&c, 90.0);
        assert!((across - 1.0).abs() < 0.03, "{law:?}: lateral friction coefficient {across}");
        let mut c = yawed_link(GroundModel::Isotropic);
        c.physics.floor_friction = law;
        let iso = friction_ratio(&c, 0.0);
        assert!((iso - 0.5).abs() < 0.015, "{law:?}: isotropic coefficient {iso}");
    }
}

#[test]
fn directional_friction_depends_on_the_sliding_direction() {
    for law in FLOOR_FRICTIONS {
        let mut c = yawed_link(GroundModel::Directional);
        c.physics.floor_friction = law;
        let forward = friction_ratio(&c, 0.0);
        let backward = friction_ratio(&c, 180.0);
        assert!((forward - 0.1).abs() < 0.003, "{law:?}: forward {forward}");
        assert!((backward - 0.3).abs() < 0.009, "{law:?}: backward {backward}");
    }
}

#[test]
fn viscous_friction_decays_velocity_exponentially() {
    // m·dv/dt = −c·v: v(t) = v0·exp(−c·t/m), with c = c_t along the link and c_n across it.
    for (direction, c_value) in [(0.0, 1.0), (90.0, 3.0)] {
        let mut c = yawed_link(GroundModel::Viscous);
        c.ground.viscous_tangential_n_s_per_m = 1.0;
        c.ground.viscous_normal_n_s_per_m = 3.0;
        c.snake.link_mass_kg = 1.0;
        let mut sim = launch(&c, direction, 0.5);
        for _ in 0..300 {
            sim.step().unwrap();
        }
        let v = sim.world().data().qvel();
        let speed = v[0].hypot(v[1]);
        let expected = 0.5 * (-c_value * 0.3 / 1.0_f64).exp();
        assert!((speed - expected).abs() < 0.01 * expected, "direction {direction}: {speed} vs {expected}");
    }
}

fn quick_experiment(name: &str) -> Vec<Check> {
    let dir = tempfile::tempdir().unwrap();
    let outcome = run_experiment(name, &Config::default(), dir.path(), true).unwrap();
    outcome.report.checks().cloned().collect()
}

fn assert_all_pass(checks: &[Check]) {
    let failed: Vec<String> = checks
        .iter()
        .filter(|c| !c.passed)
        .map(|c| format!("{}: {} (expected {})", c.name, c.measured, c.expected))
        .collect();
    assert!(failed.is_empty(), "failed checks: {failed:#?}");
}

#[test]
#[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
fn collision_experiment_checks_pass() {
    let checks = quick_experiment("collision");
    assert_eq!(checks.len(), 20);
    assert_all_pass(&checks);
}

#[test]
#[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
fn form_closure_moves_forward_and_first_order_slips_less() {
    assert_all_pass(&quick_experiment("form-closure"));
}

#[test]
#[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
fn configure_experiment_places_every_link() {
    assert_all_pass(&quick_experiment("configure"));
}

/// Mean forward (+x) speed of the centre of mass after the ramp-in.
fn undulation_speed(model: GroundModel, axial: f64) -> (f64, f64) {
    let mut c = Config::default();
    c.snake.link_radius_m = 0.08;
    c.terrain.kind = TerrainKind::None;
    c.gait.kind = GaitKind::SineWave;
    c.gait.ramp_secs = 2.0;
    c.control.method = ControlMethod::Position;
    // The open-loop gait (the default job steers with path following).
    c.control.controller = simserpent::config::ControllerKind::Gait;
    c.ground.model = model;
    c.snake.ground_friction = [0.5, 0.0, 0.0];
    c.ground.lateral_friction = 0.5;
    c.ground.axial_friction = axial;
    let world = World::from_config(&c).unwrap();
    let mut sim = Simulation::new(&c, world);
    let mut s = Snapshot::new(10, 9);
    let com = |s: &Snapshot| -> [f64; 2] {
        let n = s.link_position_m.len() as f64;
        s.link_position_m.iter().fold([0.0; 2], |a, p| [a[0] + p[0] / n, a[1] + p[1] / n])
    };
    let mut start = [0.0; 2];
    let (ramp_steps, total_steps) = (2000, 6000);
    for k in 0..=total_steps {
        sim.control();
        if k == ramp_steps || k == total_steps {
            sim.snapshot(&mut s);
            if k == ramp_steps {
                start = com(&s);
            }
        }
        if k < total_steps {
            sim.advance().unwrap();
        }
    }
    let end = com(&s);
    let secs = (total_steps - ramp_steps) as f64 * c.general.timestep_secs;
    ((end[0] - start[0]) / secs, (end[1] - start[1]) / secs)
}

#[test]
fn anisotropic_friction_propels_where_isotropic_does_not() {
    // 10 links of 0.2 m (body 2 m), sine wave f = 0.5 Hz: one cycle is 2 s.
    let (iso_x, iso_y) = undulation_speed(GroundModel::Isotropic, 0.5);
    let per_cycle_percent = iso_x.hypot(iso_y) * 2.0 / 2.0 * 100.0;
    let (v5, _) = undulation_speed(GroundModel::Anisotropic, 0.1);
    let (v10, _) = undulation_speed(GroundModel::Anisotropic, 0.05);
    let v10_percent = v10 * 2.0 / 2.0 * 100.0;
    println!(
        "figures: isotropic drift {per_cycle_percent:.2} % of the body per cycle ({iso_x:.4}, {iso_y:.4}) m/s; ratio 10: {v10_percent:.1} %"
    );
    // The isotropic floor does not propel the snake forward: with the wave executed (every joint
    // within 10 % RMS of its command) the body drifts the way the wave runs, toward the tail, at
    // about 1.2 % of its length per cycle (the drift obstacle-aided locomotion uses on isotropic
    // floors), under 2 % and a small fraction of what anisotropic friction gives.
    assert!(iso_x < 0.0, "no forward propulsion on the isotropic floor: {iso_x} m/s");
    assert!(per_cycle_percent < 2.0, "isotropic drift {per_cycle_percent} % of the body per cycle");
    assert!(per_cycle_percent < 0.1 * v10_percent, "isotropic drift {per_cycle_percent} % vs {v10_percent} %");
    assert!(v10_percent > 2.0, "ratio 10: {v10} m/s");
    assert!(v10 > v5 && v5 > iso_x, "speed grows with the friction ratio: {iso_x} < {v5} < {v10}");
}

#[test]
#[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
fn viscous_undulation_matches_the_averaged_model() {
    // Liljebäck et al.'s standard set, two cycles after one cycle of ramp-in.
    let mut c = Config::default();
    c.snake.link_length_m = 0.14;
    c.snake.link_radius_m = 0.02;
    c.snake.link_mass_kg = 1.0;
    c.snake.joint_damping_nm_s_per_rad = 0.0;
    c.snake.torque_range_nm = [-50.0, 50.0];
    c.physics.self_collision = false;
    c.ground.model = GroundModel::Viscous;
    c.terrain.kind = TerrainKind::None;
    c.gait.kind = GaitKind::SineWave;
    c.gait.sine_wave.frequency_hz = 50.0 / 360.0;
    c.gait.ramp_secs = 7.2;
    c.control.position_kp_nm_per_rad = 50.0;
    c.control.position_kv_nm_s_per_rad = 2.0;
    let world = World::from_config(&c).unwrap();
    let mut sim = Simulation::new(&c, world);
    let ramp_steps = 7200;
    let total_steps = ramp_steps + 14_400;
    let mut x0 = 0.0;
    for k in 0..total_steps {
        if k == ramp_steps {
            x0 = sim.world().data().subtree_com()[1][0];
        }
        sim.step().unwrap();
    }
    sim.world_mut().forward();
    let v = (sim.world().data().subtree_com()[1][0] - x0) / 14.4;
    let theory = simserpent::experiments::averaged_viscous_speed(
        10,
        0.14,
        1.0,
        10.0,
        30f64.to_radians(),
        50f64.to_radians(),
        40f64.to_radians(),
    );
    assert!((v / theory - 1.0).abs() < 0.10, "simulated {v} m/s, averaged model {theory} m/s");
}

#[test]
#[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
fn pegs_propel_a_snake_that_the_isotropic_floor_holds_back() {
    // Quick oal: 2 cycles on each terrain; bare-floor drift within 2 % of the body per cycle,
    // at least 5 % per cycle among the pegs.
    assert_all_pass(&quick_experiment("oal"));
}
