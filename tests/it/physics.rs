//! Physics on short runs, asserted against analytic values and conservation laws.

use crate::common::{bare_floor, snapshot};
use simserpent::config::{Config, ControlMethod, GaitKind};
use simserpent::control::{Command, Controller, Observation};
use simserpent::sim::{Simulation, Snapshot, World};

/// A snake with no terrain and no gait, lifted `height_m` above the floor.
fn bare(n_links: usize, height_m: f64) -> Config {
    let mut c = bare_floor();
    c.snake.n_links = n_links;
    c.snake.head_position_m = [0.0, 0.0, height_m];
    c.gait.ramp_secs = 0.0;
    c
}

#[test]
fn free_fall_follows_g_t_squared_over_two() {
    let mut c = bare(4, 2.0);
    c.general.integrator = simserpent::config::Integrator::RK4;
    c.general.timestep_secs = 0.001;
    let world = World::from_config(&c).unwrap();
    let mut sim = Simulation::new(&c, world);
    let z0: Vec<f64> = snapshot(&mut sim).link_position_m.iter().map(|p| p[2]).collect();
    let g = 9.81;
    for _ in 0..400 {
        sim.step().unwrap();
    }
    let s = snapshot(&mut sim);
    let t = s.time_secs;
    assert!((t - 0.4).abs() < 1e-9);
    for (i, p) in s.link_position_m.iter().enumerate() {
        let expected = z0[i] - 0.5 * g * t * t;
        assert!((p[2] - expected).abs() < 1e-9, "link {i}: z = {} expected {expected}", p[2]);
        assert!((s.link_acceleration_m_per_s2[i][2] + g).abs() < 1e-6, "link {i} acceleration");
        assert!((s.link_velocity_m_per_s[i][2] + g * t).abs() < 1e-9, "link {i} velocity");
        // An accelerometer in free fall reads zero (proper acceleration).
        let acc = s.observation_true.imu_accel_m_per_s2[i];
        assert!(acc.iter().all(|a| a.abs() < 1e-6), "link {i} accelerometer {acc:?}");
    }
    assert!(s.contacts.is_empty());
}

/// Total linear momentum and angular momentum about the centre of mass, from MuJoCo's
/// subtree quantities of the head (the root of the whole snake).
fn momenta(world: &mut World) -> ([f64; 3], [f64; 3]) {
    let head = world.index.links[0].body;
    world.subtree_momentum(head)
}

/// Runs a weightless 6-link snake through 2 s of vigorous undulation and returns the largest
/// momentum error (linear, angular) relative to the momentum scale Σ m·|v| (and Σ m·|r×v| for the
/// angular one), and the largest joint speed.
fn floating_momentum_error(timestep_secs: f64) -> (f64, f64, f64) {
    let mut c = bare(6, 1.0);
    c.general.gravity_m_per_s2 = [0.0; 3];
    c.general.timestep_secs = timestep_secs;
    c.physics.contact_time_constant_secs = 0.02;
    c.gait.kind = GaitKind::SineWave;
    c.gait.sine_wave.amplitude_deg = 40.0;
    c.gait.sine_wave.frequency_hz = 1.0;
    c.control.method = ControlMethod::Position;
    // The soft servo the figures below were measured with. With the default stiff one (kp 100,
    // kv 1) the servo's force is clipped at the ±3 N·m range during the stroke, and the linear
    // error at 1 ms measured 1.7e-5: a clipped force is not smooth, so RK4's order does not hold.
    c.control.position_kp_nm_per_rad = 5.0;
    c.control.position_kv_nm_s_per_rad = 0.1;
    let world = World::from_config(&c).unwrap();
    let mut sim = Simulation::new(&c, world);
    let mut s = Snapshot::new(6, 5);
    let (mut worst_p, mut worst_l, mut max_joint_speed) = (0.0_f64, 0.0_f64, 0.0_f64);
    let steps = (2.0 / timestep_secs).round() as usize;
    for _ in 0..steps {
        sim.step().unwrap();
        sim.control();
        sim.snapshot(&mut s);
        let (p, l) = momenta(sim.world_mut());
        let m = c.snake.link_mass_kg;
        let com =
            s.link_position_m.iter().fold([0.0; 3], |a, x| [a[0] + x[0] / 6.0, a[1] + x[1] / 6.0, a[2] + x[2] / 6.0]);
        let (mut p_scale, mut l_scale) = (0.0, 0.0);
        for (x, v) in s.link_position_m.iter().zip(&s.link_velocity_m_per_s) {
            let r = [x[0] - com[0], x[1] - com[1], x[2] - com[2]];
            let speed = v.iter().map(|a| a * a).sum::<f64>().sqrt();
            let radius = r.iter().map(|a| a * a).sum::<f64>().sqrt();
            p_scale += m * speed;
            l_scale += m * speed * radius;
        }
        let norm = |a: [f64; 3]| a.iter().map(|x| x * x).sum::<f64>().sqrt();
        if p_scale > 1e-6 {
            worst_p = worst_p.max(norm(p) / p_scale);
            worst_l = worst_l.max(norm(l) / l_scale);
        }
        max_joint_speed = s.joint_velocity_rad_per_s.iter().fold(max_joint_speed, |acc, v| acc.max(v.abs()));
    }
    (worst_p, worst_l, max_joint_speed)
}

#[test]
fn floating_snake_conserves_momentum_while_joints_move() {
    // Internal forces only: total momentum stays zero. RK4 conserves it only up to its
    // truncation error (momentum is not a linear function of the state, so RK4 does not keep it
    // exactly), so the error must be tiny and must shrink with the timestep.
    let (p_coarse, l_coarse, speed) = floating_momentum_error(0.002);
    let (p_fine, l_fine, _) = floating_momentum_error(0.001);
    assert!(speed > 1.0, "joints barely moved: {speed} rad/s");
    assert!(p_fine < 1e-6 && l_fine < 1e-6, "relative momentum error {p_fine:e}, {l_fine:e}");
    // Measured: 1.2e-6 -> 7.6e-8 (linear), 3.1e-8 -> 1.9e-9 (angular): a factor 16 = 2^4 for
    // halving dt, RK4's order. Require at least 8.
    assert!(
        p_coarse / p_fine > 8.0 && l_coarse / l_fine > 8.0,
        "error does not shrink like RK4: {p_coarse:e}->{p_fine:e}, {l_coarse:e}->{l_fine:e}"
    );
}

#[test]
fn unactuated_snake_at_rest_stays_at_rest_and_floor_carries_its_weight() {
    let mut c = bare(5, 0.0);
    c.control.method = ControlMethod::Torque;
    c.control.pid_kp_nm_per_rad = 0.0;
    c.control.pid_kd_nm_s_per_rad = 0.0;
    let world = World::from_config(&c).unwrap();
    let mut sim = Simulation::new(&c, world);
    let start = snapshot(&mut sim).link_position_m.clone();
    for _ in 0..2000 {
        sim.step().unwrap();
    }
    let s = snapshot(&mut sim);
    for (i, (p, p0)) in s.link_position_m.iter().zip(&start).enumerate() {
        let moved = ((p[0] - p0[0]).powi(2) + (p[1] - p0[1]).powi(2) + (p[2] - p0[2]).powi(2)).sqrt();
        assert!(moved < 1e-4, "link {i} moved {moved} m");
        let speed = s.link_velocity_m_per_s[i].iter().map(|v| v * v).sum::<f64>().sqrt();
        assert!(speed < 1e-4, "link {i} speed {speed}");
    }
    let weight = 5.0 * c.snake.link_mass_kg * 9.81;
    let support: f64 = s.contacts.iter().map(|c| c.force_on_geom2_n[2].abs()).sum();
    assert!((support - weight).abs() < 0.01 * weight, "floor carries {support} N of {weight} N");
    let penetration = s.contacts.iter().map(|c| c.penetration_m()).fold(0.0, f64::max);
    assert!(penetration < 1e-3, "penetration {penetration} m");
    // Contact forces on links add up the same way.
    let on_links: f64 = s.link_contact_force_n.iter().map(|f| f[2]).sum();
    assert!((on_links - weight).abs() < 0.01 * weight);
}

/// Holds one joint at a fixed target through the position servos.
struct Hold(f64);

impl Controller for Hold {
    fn update(&mut self, _obs: &Observation, cmd: &mut Command) {
        cmd.position_rad.fill(self.0);
    }
}

#[test]
fn position_servo_reaches_its_set_point() {
    let mut c = bare(2, 1.0);
    c.general.gravity_m_per_s2 = [0.0; 3];
    c.control.method = ControlMethod::Position;
    c.control.position_kp_nm_per_rad = 5.0;
    c.control.position_kv_nm_s_per_rad = 0.5;
    let world = World::from_config(&c).unwrap();
    let mut sim = Simulation::with_controller(&c, world, Box::new(Hold(0.3)));
    for _ in 0..5000 {
        sim.step().unwrap();
    }
    let s = snapshot(&mut sim);
    assert!((s.joint_angle_rad[0] - 0.3).abs() < 1e-3, "angle {}", s.joint_angle_rad[0]);
    assert!(s.joint_velocity_rad_per_s[0].abs() < 1e-3);
    // At rest the servo force vanishes: kp (target - q) - kv qdot = 0.
    assert!(s.actuator_force_nm[0][1].abs() < 5.0 * 1e-3 + 1e-6);
}

#[test]
fn recording_interval_does_not_change_the_trajectory() {
    let run = |every: u64| {
        let mut c = Config::default();
        c.general.duration_secs = 0.5;
        c.recording.every_n_steps = every;
        let world = World::from_config(&c).unwrap();
        let mut sim = Simulation::new(&c, world);
        let mut s = Snapshot::new(sim.world().n_links(), sim.world().n_joints());
        for k in 0..500 {
            sim.control();
            if k % every == 0 {
                sim.snapshot(&mut s);
            }
            sim.advance().unwrap();
        }
        sim.world().data().qpos().to_vec()
    };
    assert_eq!(run(1), run(7));
}

/// A controller that reads the full state: it logs the contacts and the floor support it is shown.
struct ContactLogger {
    seen: std::rc::Rc<std::cell::RefCell<Vec<(f64, usize, f64)>>>,
}

impl Controller for ContactLogger {
    fn update(&mut self, _obs: &Observation, _cmd: &mut Command) {
        unreachable!("update_with_state is called instead");
    }
    fn needs_full_state(&self) -> bool {
        true
    }
    fn update_with_state(&mut self, obs: &Observation, state: &Snapshot, _cmd: &mut Command) {
        assert_eq!(state.time_secs, obs.time_secs);
        assert_eq!(obs.sensor_time_secs, obs.time_secs, "sensors are fresh with the full state");
        let support: f64 = state.link_contact_force_n.iter().map(|f| f[2]).sum();
        self.seen.borrow_mut().push((state.time_secs, state.contacts.len(), support));
    }
}

#[test]
fn controllers_can_read_the_full_state() {
    let c = bare(3, 0.0);
    let world = World::from_config(&c).unwrap();
    let seen = std::rc::Rc::new(std::cell::RefCell::new(Vec::new()));
    let mut sim = Simulation::with_controller(&c, world, Box::new(ContactLogger { seen: seen.clone() }));
    for _ in 0..500 {
        sim.step().unwrap();
    }
    let seen = seen.borrow();
    assert_eq!(seen.len(), 500, "called every step");
    let (t, contacts, support) = *seen.last().unwrap();
    assert!((t - 0.499).abs() < 1e-9);
    assert_eq!(contacts, 6, "3 links resting on the floor, 2 end contacts each");
    let weight = 3.0 * c.snake.link_mass_kg * 9.81;
    assert!((support - weight).abs() < 0.01 * weight, "support {support} N, weight {weight} N");
}

/// Sends fixed commands to every actuator kind (only the configured kind has gains).
struct Constant {
    velocity_rad_per_s: f64,
    until_secs: f64,
}

impl Controller for Constant {
    fn update(&mut self, obs: &Observation, cmd: &mut Command) {
        let v = if obs.time_secs < self.until_secs { self.velocity_rad_per_s } else { 0.0 };
        cmd.velocity_rad_per_s.fill(v);
        cmd.intvelocity_rad_per_s.fill(v);
    }
}

#[test]
fn velocity_servo_settles_at_the_damped_steady_state() {
    // Servo force kv (v* − q̇) against joint damping b q̇: steady q̇ = kv v* / (kv + b).
    let mut c = bare(2, 1.0);
    c.general.gravity_m_per_s2 = [0.0; 3];
    c.control.method = ControlMethod::Velocity;
    c.control.velocity_kv_nm_s_per_rad = 1.0;
    c.snake.joint_damping_nm_s_per_rad = 0.5;
    c.snake.joint_range_deg = 180.0;
    let world = World::from_config(&c).unwrap();
    let mut sim =
        Simulation::with_controller(&c, world, Box::new(Constant { velocity_rad_per_s: 0.3, until_secs: 10.0 }));
    for _ in 0..1000 {
        sim.step().unwrap();
    }
    let s = snapshot(&mut sim);
    let expected = 1.0 * 0.3 / (1.0 + 0.5);
    assert!((s.joint_velocity_rad_per_s[0] - expected).abs() < 1e-4, "{} vs {expected}", s.joint_velocity_rad_per_s[0]);
}

#[test]
fn intvelocity_servo_holds_the_integrated_set_point() {
    // The actuator integrates the commanded velocity into a position set-point: 0.4 rad/s for
    // 0.5 s, then zero, leaves the joint at 0.2 rad.
    let mut c = bare(2, 1.0);
    c.general.gravity_m_per_s2 = [0.0; 3];
    c.control.method = ControlMethod::Intvelocity;
    c.control.intvelocity_kp_nm_per_rad = 10.0;
    let world = World::from_config(&c).unwrap();
    let mut sim =
        Simulation::with_controller(&c, world, Box::new(Constant { velocity_rad_per_s: 0.4, until_secs: 0.5 }));
    for _ in 0..4000 {
        sim.step().unwrap();
    }
    let s = snapshot(&mut sim);
    assert!((s.joint_angle_rad[0] - 0.2).abs() < 1e-3, "angle {}", s.joint_angle_rad[0]);
}
