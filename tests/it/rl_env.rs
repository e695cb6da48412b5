//! The reinforcement-learning environment core (`simserpent::env::EnvCore`) with the contact
//! estimator in the loop (`[estimation] enabled`) and sensor noise on: every physics instant is
//! sensed once (no second noise draw, no second estimator update at an action boundary), so an
//! episode equals one `simserpent run` that holds the same commands; saved states carry the
//! estimator's filters and the sensor models' state, so a restored episode continues bit for bit.

use simserpent::config::{Config, ConfigSource, load_config_str};
use simserpent::control::{Command, Controller, Observation};
use simserpent::env::{EnvCore, env_model_config};
use simserpent::estimation::ContactEstimates;
use simserpent::sim::{LoopPlan, Observer, SimError, Simulation, StepView, World};

/// A 5-link snake on a floor with two pegs in its way, estimation on (friction identified
/// online, so the estimator has a long memory), every sensor noisy with a random-walk bias.
fn config(extra: &[&str]) -> Config {
    let mut sets: Vec<String> = [
        "snake.n_links=5",
        "terrain.kind=\"none\"",
        "estimation.enabled=true",
        "estimation.friction=\"identify\"",
        "sensors.noise_enabled=true",
        "sensors.joint_angle.std=0.01",
        "sensors.joint_angle.bias_random_walk_per_sqrt_s=0.01",
        "sensors.gyro.bias_random_walk_per_sqrt_s=0.01",
        "sensors.accelerometer.bias_random_walk_per_sqrt_s=0.05",
        "env.reset_noise_scale=0.0",
        "env.reset_heading_noise_rad=0.0",
        "env.normalize_action=false",
        "env.observe_imu=true",
        "env.observe_contact_estimates=true",
    ]
    .iter()
    .map(|s| (*s).to_string())
    .collect();
    sets.extend(extra.iter().map(|s| (*s).to_string()));
    load_config_str("", ConfigSource::Toml, &sets).unwrap()
}

/// The agent's action `a` (joint targets, rad): a travelling wave.
fn action(a: usize, n_joints: usize) -> Vec<f64> {
    (0..n_joints).map(|j| 0.6 * (0.35 * a as f64 - 0.9 * j as f64).sin()).collect()
}

/// Asserts that two series of what environments showed are equal, action by action.
fn assert_same(a: &[Seen], b: &[Seen], what: &str) {
    assert_eq!(a.len(), b.len(), "{what}");
    for (k, (x, y)) in a.iter().zip(b).enumerate() {
        assert_eq!(x, y, "{what}: action {k}");
    }
}

/// What an environment showed after one action.
#[derive(Debug, PartialEq)]
struct Seen {
    time_secs: f64,
    obs: Vec<f64>,
    estimates: ContactEstimates,
}

fn step_env(env: &mut EnvCore, a: usize, obs: &mut [f64]) -> Seen {
    let out = env.step(&action(a, env.action_size()), obs);
    assert!(!out.terminated, "{:?}", out.error);
    Seen { time_secs: env.time_secs(), obs: obs.to_vec(), estimates: env.contact_estimates().clone() }
}

/// Holds action `k / substeps` at physics instant k, as the environment does.
struct Schedule {
    substeps: usize,
    n_joints: usize,
    k: usize,
}

impl Controller for Schedule {
    fn update(&mut self, _obs: &Observation, cmd: &mut Command) {
        cmd.position_rad.copy_from_slice(&action(self.k / self.substeps, self.n_joints));
        self.k += 1;
    }
}

/// The measured joint angles and the estimates at every action boundary of the run.
struct AtBoundaries {
    substeps: u64,
    seen: Vec<(f64, Vec<f64>, ContactEstimates)>,
}

impl Observer<SimError> for AtBoundaries {
    fn on_step(&mut self, view: &StepView<'_>) -> Result<(), SimError> {
        if view.k > 0 && view.k.is_multiple_of(self.substeps) {
            let o = view.observation;
            self.seen.push((o.time_secs, o.joint_angle_rad.clone(), o.contacts.clone()));
        }
        Ok(())
    }
}

#[test]
fn env_episode_with_estimation_equals_a_run_holding_the_same_commands() {
    let c = config(&[]);
    let actions = 12;
    let mut env = EnvCore::new(&c).unwrap();
    let (substeps, nj) = (env.substeps(), env.action_size());
    let mut obs = vec![0.0; env.observation_size()];
    env.reset(c.general.seed, &mut obs).unwrap();
    let from_env: Vec<Seen> = (0..actions).map(|a| step_env(&mut env, a, &mut obs)).collect();

    // One run of the same model (position control, as the environment's) for the same steps.
    let model = env_model_config(&c).unwrap();
    let world = World::from_config(&model).unwrap();
    let schedule = Schedule { substeps: substeps as usize, n_joints: nj, k: 0 };
    let mut sim = Simulation::with_typed_controller(&model, world, schedule);
    let mut boundaries = AtBoundaries { substeps, seen: Vec::new() };
    let plan = LoopPlan { steps: substeps * actions as u64, record_every_n_steps: 0 };
    sim.run::<SimError>(plan, &mut [&mut boundaries]).unwrap();
    // The run's last instant is visited (sensed and controlled) too: one per action.
    assert_eq!(boundaries.seen.len(), actions);

    for (a, (e, (t, angles, estimates))) in from_env.iter().zip(&boundaries.seen).enumerate() {
        assert_eq!(e.time_secs, *t, "action {a}");
        assert!(estimates.active, "action {a}");
        // Bit for bit: the same noise draws and the same estimator updates.
        assert_eq!(&e.obs[..nj], &angles[..], "measured joint angles after action {a}");
        assert_eq!(&e.estimates, estimates, "contact estimates after action {a}");
    }
    // The estimates are not trivially equal: the floor carries the snake's weight. Each action
    // steps the servos' targets, and the stiff default servo jerks the five links at the torque
    // range, so the support at one instant swings (0.1-24 N over these actions, weight 14.7 N);
    // over the episode it carries the snake.
    let support_n: Vec<f64> =
        from_env.iter().map(|e| e.estimates.floor_force_n.iter().map(|f| f[2]).sum::<f64>()).collect();
    println!("figures: estimated floor support after each action {support_n:?} N");
    let mean_support_n = support_n.iter().sum::<f64>() / support_n.len() as f64;
    assert!(mean_support_n > 1.0, "estimated floor support {support_n:?} N");
}

#[test]
fn restored_state_with_estimation_and_noise_continues_bit_for_bit() {
    let c = config(&[]);
    let mut env = EnvCore::new(&c).unwrap();
    let mut obs = vec![0.0; env.observation_size()];
    env.reset(11, &mut obs).unwrap();
    for a in 0..6 {
        step_env(&mut env, a, &mut obs);
    }
    let saved = env.save_state();
    let first: Vec<Seen> = (6..16).map(|a| step_env(&mut env, a, &mut obs)).collect();
    // Another branch (other actions), then back.
    for a in 40..47 {
        step_env(&mut env, a, &mut obs);
    }
    env.restore_state(&saved).unwrap();
    let second: Vec<Seen> = (6..16).map(|a| step_env(&mut env, a, &mut obs)).collect();
    assert_same(&first, &second, "restored in the same environment");
    // Into a second environment of the same config, after an episode of its own.
    let mut other = EnvCore::new(&c).unwrap();
    other.reset(99, &mut obs).unwrap();
    for a in 0..9 {
        step_env(&mut other, a, &mut obs);
    }
    other.restore_state(&saved).unwrap();
    let third: Vec<Seen> = (6..16).map(|a| step_env(&mut other, a, &mut obs)).collect();
    assert_same(&first, &third, "restored in another environment");
    // A state of a world without estimation does not fit.
    let plain = EnvCore::new(&config(&["estimation.enabled=false", "env.observe_contact_estimates=false"])).unwrap();
    let err = env.restore_state(&plain.save_state()).expect_err("rejected").to_string();
    assert!(err.contains("[estimation]"), "{err}");
}

#[test]
fn reset_restarts_the_estimator_and_the_identified_friction() {
    let c = config(&[]);
    let mut env = EnvCore::new(&c).unwrap();
    let mut obs = vec![0.0; env.observation_size()];
    env.reset(3, &mut obs).unwrap();
    let first: Vec<Seen> = (0..10).map(|a| step_env(&mut env, a, &mut obs)).collect();
    // A long episode, so the friction fit and the filters move far from their start.
    for a in 0..60 {
        step_env(&mut env, a, &mut obs);
    }
    env.reset(3, &mut obs).unwrap();
    let again: Vec<Seen> = (0..10).map(|a| step_env(&mut env, a, &mut obs)).collect();
    assert_same(&first, &again, "after a reset");
    let mut fresh = EnvCore::new(&c).unwrap();
    fresh.reset(3, &mut obs).unwrap();
    let from_fresh: Vec<Seen> = (0..10).map(|a| step_env(&mut fresh, a, &mut obs)).collect();
    assert_same(&first, &from_fresh, "fresh environment");
}
