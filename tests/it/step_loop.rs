//! The step loop's fused step: after a recorded instant the step starts from the recording's
//! forward pass (`World::step_after_forward`) instead of `mj_step` repeating it. It must give
//! the trajectory and the recorded snapshots of plain `mj_step` stepping, bit for bit.

use crate::common::default_config_with;
use simserpent::config::Config;
use simserpent::sim::{LoopPlan, Observer, SimError, Simulation, Snapshot, StepView, World};

/// Everything of one instant that the next step depends on, or that a table records, as exact
/// text (`{:?}` of an `f64` is its shortest round-trip form: equal text ⇔ equal bits).
fn state_text(world: &World) -> String {
    let d = world.data();
    format!(
        "t={:?} qpos={:?} qvel={:?} act={:?} warmstart={:?} ctrl={:?} xfrc={:?}",
        d.time(),
        d.qpos(),
        d.qvel(),
        d.act(),
        d.qacc_warmstart(),
        d.ctrl(),
        d.xfrc_applied()
    )
}

/// Collects the state of every instant and the snapshot of every recorded one.
#[derive(Default)]
struct Trace {
    states: Vec<String>,
    records: Vec<String>,
}

impl Observer<SimError> for Trace {
    fn on_step(&mut self, view: &StepView<'_>) -> Result<(), SimError> {
        self.states.push(state_text(view.world));
        Ok(())
    }
    fn on_record(&mut self, view: &StepView<'_>, snapshot: &Snapshot) -> Result<(), SimError> {
        self.records.push(format!("k={} {snapshot:?}", view.k));
        Ok(())
    }
}

/// The step loop as it was before the fused step: control, (forward + read-out), `mj_step`,
/// with a full forward pass of its own at every instant (and `world_mut` tells the ground that
/// its forward pass may no longer describe the state, so the step's pass is a full one too).
fn reference_trace(config: &Config, plan: LoopPlan) -> Trace {
    let mut sim = Simulation::new(config, World::from_config(config).unwrap());
    let mut snapshot = Snapshot::new(sim.world().n_links(), sim.world().n_joints());
    let mut trace = Trace::default();
    for k in 0..=plan.steps {
        sim.control();
        sim.world_mut().forward();
        if plan.records(k) {
            sim.snapshot(&mut snapshot);
            trace.records.push(format!("k={k} {snapshot:?}"));
        }
        trace.states.push(state_text(sim.world()));
        if k < plan.steps {
            sim.advance().unwrap(); // plain mj_step
        }
    }
    trace
}

fn loop_trace(config: &Config, plan: LoopPlan) -> Trace {
    let mut sim = Simulation::new(config, World::from_config(config).unwrap());
    let mut trace = Trace::default();
    sim.run::<SimError>(plan, &mut [&mut trace]).unwrap();
    trace
}

/// The default job with its corridor of pegs (cylinder path) moved back alongside the body and
/// narrowed to 0.26 m, so that the links hit the pegs within the compared 1.5 s (the default
/// job's head reaches its first peg at 4 s); anisotropic ground friction as in the default.
fn default_job_among_pegs(integrator: &str, floor: &str) -> Config {
    default_config_with(&[
        format!("general.integrator={integrator:?}"),
        format!("physics.floor_friction={floor:?}"),
        "terrain.cylinder_path.start_m=-1.75".into(),
        "terrain.cylinder_path.width_m=0.26".into(),
    ])
    .unwrap()
}

/// The default job among pegs for every integrator and both floor friction laws, recording
/// every step and every 10th: the loop's trajectory and snapshots equal plain `mj_step`
/// stepping bit for bit.
#[test]
#[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
fn fused_step_is_bit_identical_to_mj_step_for_every_integrator() {
    let mut cases = 0;
    for integrator in ["RK4", "Euler", "implicit", "implicitfast"] {
        for floor in ["mujoco", "stick_slip"] {
            let config = default_job_among_pegs(integrator, floor);
            let steps = (1.5 / config.general.timestep_secs).round() as u64;
            for every in [1, 10] {
                let plan = LoopPlan { steps, record_every_n_steps: every };
                let (reference, fused) = (reference_trace(&config, plan), loop_trace(&config, plan));
                let what = format!("{integrator}, floor_friction {floor}, every {every}");
                assert_eq!(reference.states.len(), steps as usize + 1, "{what}");
                assert_eq!(reference.records.len(), fused.records.len(), "{what}");
                for (k, (a, b)) in reference.states.iter().zip(&fused.states).enumerate() {
                    assert!(a == b, "{what}: state differs at instant {k}:\n{a}\n{b}");
                }
                for (a, b) in reference.records.iter().zip(&fused.records) {
                    assert!(a == b, "{what}: snapshot differs:\n{a}\n{b}");
                }
                cases += 1;
            }
        }
    }
    assert_eq!(cases, 16);
}

/// The directional ground model switches each link's contact-pair friction before every step
/// from its sliding direction (a model parameter that enters collision detection): the same
/// identity, recording every step and every 10th.
#[test]
fn fused_step_is_bit_identical_with_pair_friction_switching() {
    for integrator in ["RK4", "implicitfast"] {
        let mut config = default_job_among_pegs(integrator, "mujoco");
        config.ground.model = simserpent::config::GroundModel::Directional;
        let steps = (1.5 / config.general.timestep_secs).round() as u64;
        for every in [1, 10] {
            let plan = LoopPlan { steps, record_every_n_steps: every };
            let (reference, fused) = (reference_trace(&config, plan), loop_trace(&config, plan));
            assert_eq!(reference.states, fused.states, "{integrator}, every {every}");
            assert_eq!(reference.records, fused.records, "{integrator}, every {every}");
        }
    }
}

/// On a step with an obstacle contact the obstacle law runs a full forward pass at the state
/// with the step's forces; the step's own pass then starts from the actuation stage. With
/// SimSerpent's floor among pegs, recording every step and every 10th: the trajectory and the
/// snapshots equal those of full forward passes bit for bit.
#[test]
fn a_step_after_the_obstacle_law_equals_a_full_forward_pass_bit_for_bit() {
    let config = default_job_among_pegs("RK4", "stick_slip");
    let steps = (1.5 / config.general.timestep_secs).round() as u64;
    for every in [1, 10] {
        let plan = LoopPlan { steps, record_every_n_steps: every };
        let (reference, fused) = (reference_trace(&config, plan), loop_trace(&config, plan));
        assert_eq!(reference.states.len(), steps as usize + 1);
        assert!(reference.states == fused.states, "every {every}: the trajectories differ");
        assert!(reference.records == fused.records, "every {every}: the snapshots differ");
    }
}

/// The comparison above means something only if the run has contacts with the pegs and the
/// floor, and the stick-slip law applies forces: checked on the same job.
#[test]
fn compared_job_touches_pegs_and_floor_in_the_compared_window() {
    let config = default_job_among_pegs("RK4", "stick_slip");
    let steps = (1.5 / config.general.timestep_secs).round() as u64;
    let mut sim = Simulation::new(&config, World::from_config(&config).unwrap());
    struct Contacts {
        obstacle: usize,
        floor: usize,
        xfrc: usize,
    }
    impl Observer<SimError> for Contacts {
        fn on_record(&mut self, view: &StepView<'_>, s: &Snapshot) -> Result<(), SimError> {
            let norm = |f: &[f64; 3]| f.iter().map(|x| x * x).sum::<f64>().sqrt();
            self.obstacle += s.link_obstacle_force_n.iter().filter(|f| norm(f) > 0.0).count();
            self.floor += s.link_floor_force_n.iter().filter(|f| norm(f) > 0.0).count();
            self.xfrc += view.world.data().xfrc_applied().iter().filter(|f| f.iter().any(|x| *x != 0.0)).count();
            Ok(())
        }
    }
    let mut c = Contacts { obstacle: 0, floor: 0, xfrc: 0 };
    sim.run::<SimError>(LoopPlan { steps, record_every_n_steps: 1 }, &mut [&mut c]).unwrap();
    assert!(c.obstacle > 0, "no peg contact in 1.5 s");
    assert!(c.floor > 0 && c.xfrc > 0, "floor contacts {} and stick-slip forces {}", c.floor, c.xfrc);
}

/// Sensing is once per instant: a second `sense` before the next step keeps the reading (no
/// second noise draw, no second estimator update); a step, a reset or `world_mut` makes the
/// next `sense` read afresh.
#[test]
fn an_instant_is_sensed_once() {
    let sets: Vec<String> = [
        "snake.n_links=4",
        "terrain.kind=\"none\"",
        "sensors.noise_enabled=true",
        "sensors.joint_angle.std=0.01",
        "estimation.enabled=true",
    ]
    .iter()
    .map(|s| (*s).to_string())
    .collect();
    let config = default_config_with(&sets).unwrap();
    let world = World::from_config(&config).unwrap();
    let mut sim = Simulation::new(&config, world);
    sim.reset(3).unwrap();
    let first = format!("{:?}", sim.observation());
    sim.sense();
    assert_eq!(format!("{:?}", sim.observation()), first, "sensed twice at the reset instant");
    // The state may have changed: read afresh (the noise stream moves on).
    let _ = sim.world_mut();
    sim.sense();
    let fresh = format!("{:?}", sim.observation());
    assert_ne!(fresh, first);
    sim.step().unwrap();
    sim.sense();
    let after_step = format!("{:?}", sim.observation());
    assert_ne!(after_step, fresh);
    sim.sense();
    assert_eq!(format!("{:?}", sim.observation()), after_step);
}

/// The head's pose and velocity in the observation are those of the instant sensed, whatever
/// kinematics ran last (after an RK4 step: its last Runge–Kutta stage's; after an Euler step:
/// the step's start): they equal the head body's pose and centre-of-mass velocity after a forward
/// pass at the same state, at every step.
#[test]
fn the_observed_head_pose_is_the_state_of_its_instant() {
    use mujoco_rs::prelude::MjtObjBase;
    for integrator in ["RK4", "Euler"] {
        let sets: Vec<String> = [
            "snake.n_links=6".to_string(),
            "terrain.kind=\"none\"".to_string(),
            format!("general.integrator=\"{integrator}\""),
        ]
        .to_vec();
        let config = default_config_with(&sets).unwrap();
        let world = World::from_config(&config).unwrap();
        let mut sim = Simulation::new(&config, world);
        sim.reset(1).unwrap();
        let head = sim.world().index.links[0].body;
        let mut worst = [0.0f64; 3];
        for _ in 0..300 {
            sim.step().unwrap();
            let _ = sim.world_mut(); // read afresh at this instant
            sim.sense();
            let obs = sim.true_observation().clone();
            sim.world_mut().forward();
            let d = sim.world().data();
            let v = d.object_velocity(MjtObjBase::mjOBJ_BODY, head, false);
            let diff = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
            worst[0] = worst[0].max(diff(&obs.head_position_m, &d.xpos()[head]));
            worst[1] = worst[1].max(diff(&obs.head_quat, &d.xquat()[head]));
            worst[2] = worst[2].max(diff(&obs.head_velocity_m_per_s, &v[3..6]));
        }
        assert!(worst[0] < 1e-14 && worst[1] < 1e-14 && worst[2] < 1e-12, "{integrator}: {worst:?}");
    }
}
