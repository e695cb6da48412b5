//! Contact estimation in the step loop, the `estimate` tool, and the closed-loop controllers.

use simserpent::config::{Config, ControllerKind, FloorFriction, GroundModel, PegLayout, TerrainKind};
use simserpent::control::PathFollowing;
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
    // `simserpent estimate` (below) needs every step recorded.
    c.recording.every_n_steps = 1;
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
