//! Contact estimation in the step loop, the `estimate` tool, and the closed-loop controllers.

use simserpent::config::{Config, ControllerKind, FloorFriction, GroundModel, PegLayout, TerrainKind};
use simserpent::control::PathFollowing;
use simserpent::experiments::oal_bench::{self, Floor, Layout, RANDOM_PEGS_PER_M2};
use simserpent::sim::{LoopPlan, Observer, SimError, Simulation, StepView, World};

/// The default snake on SimSerpent's stick–slip floor, no obstacles.
fn open_floor() -> Config {
    let mut c = Config::default();
    c.physics.floor_friction = FloorFriction::StickSlip;
    c.terrain.kind = TerrainKind::None;
    c
}

/// Cross-track error of the path-following controller's guidance at every instant.
struct CrossTrack {
    time_s: Vec<f64>,
    error_m: Vec<f64>,
    com_x_m: Vec<f64>,
}

impl Observer<SimError> for CrossTrack {
    fn on_step(&mut self, view: &StepView<'_>) -> Result<(), SimError> {
        if view.k.is_multiple_of(100) {
            // The true centre of mass, against the path y = y0 (the controller's own estimate
            // comes from the head pose and the encoders; this is the simulator's).
            let com = view.world.centre_of_mass_m();
            self.time_s.push(view.time_secs());
            self.error_m.push(com[1]);
            self.com_x_m.push(com[0]);
        }
        Ok(())
    }
}

/// Runs the path follower on `config` for `secs`; returns (times, CoM y, CoM x) every 0.1 s.
fn follow(config: &Config, secs: f64) -> CrossTrack {
    config.validate().unwrap();
    let world = World::from_config(config).unwrap();
    let controller = PathFollowing::from_config(config, world.n_joints());
    let mut sim = Simulation::with_typed_controller(config, world, controller);
    let mut trace = CrossTrack { time_s: Vec::new(), error_m: Vec::new(), com_x_m: Vec::new() };
    let steps = (secs / config.general.timestep_secs).round() as u64;
    sim.run(LoopPlan { steps, record_every_n_steps: 0 }, &mut [&mut trace]).unwrap();
    trace
}

/// Liljebäck's line-of-sight path following on anisotropic friction: started 0.3 m beside a
/// straight path, the snake converges, and in steady state (the last 20 s of 60 s) the centre
/// of mass stays within one link radius (4 cm) of the path.
#[test]
#[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
fn path_following_converges_to_a_straight_path_within_one_link_radius() {
    let mut c = open_floor();
    c.ground.model = GroundModel::Anisotropic;
    c.control.controller = ControllerKind::PathFollowing;
    let y0 = 0.3;
    c.path_following.waypoints_m = vec![[0.0, y0], [20.0, y0]];
    let t = follow(&c, 60.0);
    let steady: Vec<f64> =
        t.time_s.iter().zip(&t.error_m).filter(|(time, _)| **time >= 40.0).map(|(_, y)| (y - y0).abs()).collect();
    let worst = steady.iter().copied().fold(0.0, f64::max);
    let start = (t.error_m[0] - y0).abs();
    let travelled = t.com_x_m.last().unwrap() - t.com_x_m[0];
    assert!(start > 0.25, "starts off the path: {start}");
    assert!(travelled > 1.0, "the snake moves along the path: {travelled} m");
    assert!(worst < c.snake.link_radius_m, "steady-state cross-track error {worst} m ≥ link radius");
}

/// Waypoints: a path with a 90° corner; the snake reaches the second segment and ends near it.
#[test]
#[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
fn path_following_turns_at_a_waypoint() {
    let mut c = open_floor();
    c.ground.model = GroundModel::Anisotropic;
    c.control.controller = ControllerKind::PathFollowing;
    c.path_following.waypoints_m = vec![[-1.0, 0.0], [0.5, 0.0], [0.5, 5.0]];
    c.path_following.lookahead_m = 0.6;
    let config = c.clone();
    config.validate().unwrap();
    let world = World::from_config(&config).unwrap();
    let controller = PathFollowing::from_config(&config, world.n_joints());
    let mut sim = Simulation::with_typed_controller(&config, world, controller);
    let steps = (60.0 / config.general.timestep_secs) as u64;
    sim.run::<SimError>(LoopPlan { steps, record_every_n_steps: 0 }, &mut []).unwrap();
    let g = sim.controller().last;
    assert_eq!(g.segment, 1, "{g:?}");
    let com = sim.world().centre_of_mass_m();
    assert!((com[0] - 0.5).abs() < 0.15 && com[1] > 0.5, "on the second segment: {com:?}");
}

/// With `[estimation] enabled` the controller's observation carries the estimates, and a run
/// writes the `estimates` table next to the truth.
#[test]
#[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
fn estimates_reach_the_observation_and_the_estimates_table() {
    let dir = tempfile::tempdir().unwrap();
    let mut c = open_floor();
    c.general.output_dir = dir.path().display().to_string();
    c.general.duration_secs = 2.0;
    c.estimation.enabled = true;
    c.sensors.noise_enabled = true;
    c.terrain.pegboard.layout = PegLayout::Random;
    c.terrain.pegboard.region_min_m = [-2.2, -0.4];
    c.terrain.pegboard.region_max_m = [0.5, 0.4];
    c.terrain.pegboard.count = 12;
    c.terrain.pegboard.spacing_m = 0.3;
    let summary = simserpent::run::run(&c, &Default::default()).unwrap();
    let (header, rows) = crate::common::read_csv_numbers(&summary.run_folder.join("estimates.csv"));
    for name in [
        "link_00_estimated_obstacle_force_x_n",
        "link_09_estimated_contact",
        "link_09_estimated_point_along_m",
        "link_05_true_obstacle_force_y_n",
        "link_05_true_floor_force_z_n",
    ] {
        assert!(header.iter().any(|h| h == name), "{name} in {header:?}");
    }
    assert!(!rows.is_empty());
    // The floor's support is estimated: together the links' supports carry the weight (pegs
    // push horizontally; one link's share varies with the joints' vertical forces).
    let cols: Vec<usize> = (0..c.snake.n_links)
        .map(|i| header.iter().position(|h| *h == format!("link_{i:02}_estimated_floor_force_z_n")).unwrap())
        .collect();
    let mean = rows.iter().map(|r| cols.iter().map(|&k| r[k]).sum::<f64>()).sum::<f64>() / rows.len() as f64;
    let weight = c.snake.n_links as f64 * c.snake.link_mass_kg * 9.81;
    assert!((mean - weight).abs() < 0.05 * weight, "mean total support {mean} N, weight {weight} N");

    // The tool on the same run folder: its own table, scores and plots.
    let outcome = simserpent::estimate::estimate_run_folder(&summary.run_folder, &[]).unwrap();
    assert_eq!(outcome.rows, rows.len());
    for f in ["estimates.csv", "scores.md", "scores.csv", "plots/estimate_link_00.png"] {
        assert!(outcome.folder.join(f).is_file(), "{f}");
    }
}

/// The obstacle-aided controller's scene: the default
/// 10-link snake on a stick–slip floor with isotropic Coulomb friction among a random peg field
/// (3 pegs per m², seed 1), position servos of 20 N·m/rad and ±10 N·m, a sine wave of 50° and
/// 30° phase lag, default sensor noise, contact estimation in the loop.
fn peg_field(controller: ControllerKind) -> Config {
    let mut c = open_floor();
    c.general.seed = 1;
    c.ground.model = GroundModel::Isotropic;
    c.terrain.pegboard.layout = PegLayout::Random;
    c.terrain.pegboard.region_min_m = [-2.2, -1.0];
    c.terrain.pegboard.region_max_m = [4.0, 1.0];
    c.terrain.pegboard.spacing_m = 0.3;
    c.terrain.pegboard.count = 37;
    c.control.controller = controller;
    c.control.position_kp_nm_per_rad = 20.0;
    c.control.position_kv_nm_s_per_rad = 0.2;
    c.snake.torque_range_nm = [-10.0, 10.0];
    c.gait.sine_wave.amplitude_deg = 50.0;
    c.gait.sine_wave.phase_lag_deg = 30.0;
    c.sensors.noise_enabled = true;
    c.estimation.enabled = true;
    c
}

/// Centre-of-mass x (m) every 0.1 s of a run of `secs` with the configured controller.
fn com_x_path(config: &Config, secs: f64) -> Vec<f64> {
    config.validate().unwrap();
    let world = World::from_config(config).unwrap();
    let mut sim = Simulation::new(config, world);
    let mut trace = CrossTrack { time_s: Vec::new(), error_m: Vec::new(), com_x_m: Vec::new() };
    let steps = (secs / config.general.timestep_secs).round() as u64;
    sim.run(LoopPlan { steps, record_every_n_steps: 0 }, &mut [&mut trace]).unwrap();
    trace.com_x_m
}

/// A random field of `simserpent experiment oal-bench` on its isotropic floor (10 links, servos
/// of 20 N·m/rad and ±10 N·m, default sensor noise, estimation on), `density` pegs per m² in the
/// narrower strip the obstacle-aided controllers were tuned beside (x from −2.2 to 4 m, |y| ≤ 1 m),
/// run for `secs` with the configured controller.
fn oal_field(density: f64, seed: u64, secs: f64) -> Config {
    let mut c = oal_bench::field_config(&Config::default(), Floor::Isotropic, Layout::Random(density), seed);
    let p = &mut c.terrain.pegboard;
    p.region_min_m = [-2.2, -1.0];
    p.region_max_m = [4.0, 1.0];
    p.count = (density * 6.2 * 2.0).round() as usize;
    c.general.duration_secs = secs;
    c
}

/// The run's forward speed (m/s: the centre of mass along +x from the end of the ramp-in to the
/// end) and whether it jammed by the benchmark's rule ([`oal_bench::count_jams`]).
fn score_run(config: &Config) -> (f64, bool) {
    config.validate().unwrap();
    let world = World::from_config(config).unwrap();
    let mut sim = Simulation::new(config, world);
    let mut trace = CrossTrack { time_s: Vec::new(), error_m: Vec::new(), com_x_m: Vec::new() };
    let steps = (config.general.duration_secs / config.general.timestep_secs).round() as u64;
    sim.run(LoopPlan { steps, record_every_n_steps: 0 }, &mut [&mut trace]).unwrap();
    let ramp = config.gait.ramp_secs;
    let path: Vec<(f64, f64)> = trace.time_s.iter().copied().zip(trace.com_x_m.iter().copied()).collect();
    let start = path.iter().position(|p| p.0 >= ramp - 1e-9).unwrap();
    let (t0, x0) = path[start];
    let (t1, x1) = path[path.len() - 1];
    ((x1 - x0) / (t1 - t0), oal_bench::count_jams(&path, ramp) > 0)
}

/// With its contact estimates (measured sensors, default noise) the obstacle-aided controller
/// moves the snake forward through the peg field on isotropic friction, where the same wave on
/// the bare floor does not advance.
///
/// **Ignored: it does not measure what it claims.** Its bare-floor run uses the scene's ordinary
/// 50°/30° wave, while the controller runs its own wave toward the head, which advances faster on
/// the bare floor than among pegs (on isotropic random peg fields the pegs only hinder it), so "the pegs help"
/// is not what the comparison shows; and between peg fields the spread is larger than any
/// controller effect. Run it with
/// `cargo test --test it closed_loop -- --ignored`;
/// `obstacle_aided_controller_advances_on_unseen_peg_fields` tests what the controller achieves.
#[test]
#[ignore = "the bare-floor comparison runs another wave than the controller; see the doc comment"]
fn obstacle_aided_controller_moves_through_a_peg_field_on_isotropic_friction() {
    let secs = 12.0;
    let pegs = com_x_path(&peg_field(ControllerKind::ObstacleAided), secs);
    let mut bare = peg_field(ControllerKind::Gait);
    bare.terrain.pegboard.layout = PegLayout::None;
    let bare = com_x_path(&bare, secs);
    let advance = |x: &[f64]| x[x.len() - 1] - x[10];
    let (pegs_m, bare_m) = (advance(&pegs), advance(&bare));
    eprintln!("obstacle-aided among pegs: {pegs_m:.3} m; open loop on the bare floor: {bare_m:.3} m in {secs} s");
    assert!(pegs_m > 0.2, "the obstacle-aided snake advanced only {pegs_m:.3} m in {secs} s");
    assert!(pegs_m > bare_m + 0.15, "pegs {pegs_m:.3} m against bare floor {bare_m:.3} m");
}

/// The obstacle-aided controller with its default config (its own 65° / −75° wave at a fixed
/// 0.5 Hz, running toward the head, the forward gait on isotropic friction; yielding at
/// resisting pegs from the estimated contacts, pressing off; no heading control, no jam
/// recovery) moves the snake forward on `oal-bench`'s isotropic floor among random pegs,
/// on fields nobody tuned on (seeds 40–42, the medium density, 10 s; speed: the centre
/// of mass along +x from the end of the ramp), at least 20 mm/s and without a jam by the benchmark's
/// rule (5 s without 2 cm). Measured with `cargo test`: 26.9, 27.2 and 25.2 mm/s.
/// What this does not show: that the contacts help. On this floor the pegs only hinder the
/// reversed wave, and the yield-only default jams about as often as its wave alone (9 against 8
/// jams on 270 such fields).
#[test]
#[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
fn obstacle_aided_controller_advances_on_unseen_peg_fields() {
    for seed in 40..=42 {
        let mut c = oal_field(RANDOM_PEGS_PER_M2[1], seed, 10.0);
        c.control.controller = ControllerKind::ObstacleAided;
        c.estimation.enabled = true;
        let (speed_m_per_s, jammed) = score_run(&c);
        eprintln!("seed {seed}: {:.1} mm/s, jammed {jammed}", 1e3 * speed_m_per_s);
        assert!(speed_m_per_s > 0.020, "seed {seed}: {:.1} mm/s", 1e3 * speed_m_per_s);
        assert!(!jammed, "seed {seed} jammed");
    }
}

/// The rail controller with its default `[rail]` values (it starts in the floor-drift gait,
/// 65°/−75°, and switches to follow-the-leader on what the estimated contacts say; no jam
/// switch) and estimated contacts, on `oal-bench` random fields that nobody tuned
/// on (seeds 40–42, every density, 10 s; forward speed and jams as the experiment scores them),
/// against the open-loop wave 65°/−60° (the best open-loop wave toward the head on sparse and medium fields) on the same
/// fields: rail advances steadily on every field,
/// at least 20 mm/s and without a jam, and its slowest field is faster than the open loop's.
/// Measured with `cargo test`: rail 27, 27, 27 / 27, 27, 25 / 27, 28, 25 mm/s; open loop 65°/−60°
/// 39, 39, 37 / 10, 38, 11 / 10, 40, 7 mm/s (jammed where below 12 mm/s).
#[test]
#[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
fn rail_controller_advances_through_unseen_peg_fields() {
    use simserpent::config::{ContactSource, GaitKind};
    let mut rail = Vec::new();
    let mut open = Vec::new();
    for density in RANDOM_PEGS_PER_M2 {
        for seed in 40..=42 {
            let mut c = oal_field(density, seed, 10.0);
            let mut o = c.clone();
            c.control.controller = ControllerKind::Rail;
            c.rail.contacts = ContactSource::Estimated;
            c.estimation.enabled = true;
            let (speed, jammed) = score_run(&c);
            assert!(!jammed, "rail jammed on seed {seed}, {density} pegs/m²");
            rail.push(speed);
            o.control.controller = ControllerKind::Gait;
            o.gait.kind = GaitKind::SineWave;
            o.gait.sine_wave.amplitude_deg = 65.0;
            o.gait.sine_wave.phase_lag_deg = -60.0;
            o.estimation.enabled = false;
            open.push(score_run(&o).0);
        }
    }
    eprintln!("seeds 40-42 (sparse, medium, dense; m/s): rail {rail:.3?}, open loop 65/-60 {open:.3?}");
    let slowest = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
    assert!(slowest(&rail) > 0.020, "a run was slower than 20 mm/s: {rail:.3?}");
    assert!(
        slowest(&rail) > slowest(&open),
        "rail's slowest field {:.3} m/s against the open loop's {:.3} m/s: {rail:.3?} {open:.3?}",
        slowest(&rail),
        slowest(&open)
    );
}
