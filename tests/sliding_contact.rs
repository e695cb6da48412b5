//! Sliding floor contact (issue 14): measured from every step's snapshot, as the recorded tables
//! would show it (`Simulation::control`, then the recording's forward pass at x_k, then the step).
//!
//! The hop figures: the fraction of link-steps without floor contact (no floor normal force),
//! the largest floor normal force of one link over its weight, and the recorded floor impulse
//! (Σ vertical floor force · dt) over the weight's impulse. Run with `--nocapture` to see them.
#![allow(clippy::unwrap_used)]

use simserpent::config::{Config, FloorFriction, GaitKind, GroundModel, TerrainKind};
use simserpent::sim::{Simulation, Snapshot, World};

/// Gravity of the default config (m/s²).
const G: f64 = 9.81;

/// Hop figures of a run segment.
#[derive(Debug, Clone, Copy)]
struct Hop {
    /// Link-steps without any floor normal force / all link-steps.
    no_contact_fraction: f64,
    /// Largest floor normal force of one link at one step / that link's weight.
    peak_over_weight: f64,
    /// Smallest floor normal force of one link at one step / that link's weight.
    min_over_weight: f64,
    /// Σ vertical floor force · dt over Σ weight · dt.
    impulse_over_weight: f64,
    /// Head link's mean x acceleration (from its x velocity at the ends of the segment), m/s².
    mean_accel_x_m_per_s2: f64,
}

fn simulation(c: &Config) -> Simulation {
    Simulation::new(c, World::from_config(c).unwrap())
}

/// Runs `settle_secs` unmeasured, then measures every step for `secs`.
fn measure(c: &Config, settle_secs: f64, secs: f64) -> Hop {
    let mut sim = simulation(c);
    let dt = c.general.timestep_secs;
    let n = c.snake.n_links;
    for _ in 0..(settle_secs / dt).round() as usize {
        sim.step().unwrap();
    }
    let mut s = Snapshot::new(n, n.saturating_sub(1));
    let steps = (secs / dt).round() as usize;
    let (mut without, mut peak, mut min, mut impulse, mut weight_impulse) = (0usize, 0.0f64, f64::INFINITY, 0.0, 0.0);
    let mut v_first = None;
    let mut v_last = 0.0;
    for _ in 0..steps {
        sim.control();
        sim.snapshot(&mut s);
        for i in 0..n {
            let w = s.link_mass_kg[i] * G;
            let fz = s.link_floor_force_n[i][2];
            if fz <= 0.0 {
                without += 1;
            }
            peak = peak.max(fz / w);
            min = min.min(fz / w);
            impulse += fz * dt;
            weight_impulse += w * dt;
        }
        v_first.get_or_insert(s.link_velocity_m_per_s[0][0]);
        v_last = s.link_velocity_m_per_s[0][0];
        sim.advance().unwrap();
    }
    let v0 = v_first.unwrap();
    Hop {
        no_contact_fraction: without as f64 / (steps * n) as f64,
        peak_over_weight: peak,
        min_over_weight: min,
        impulse_over_weight: impulse / weight_impulse,
        mean_accel_x_m_per_s2: (v_last - v0) / ((steps - 1) as f64 * dt),
    }
}

/// One 0.3 kg link (L 0.2 m, r 0.04 m) on a bare floor, isotropic μ 0.5, RK4, 1 ms, pushed by
/// 2 N along +x (its axis) at its centre of mass. The push is a horizontal gravity component
/// F/m, so that nothing but the engine's own force input is involved.
fn pushed_link(friction: FloorFriction) -> Config {
    let mut c = Config::default();
    c.terrain.kind = TerrainKind::None;
    c.gait.kind = GaitKind::None;
    c.snake.n_links = 1;
    c.ground.model = GroundModel::Isotropic;
    c.snake.ground_friction = [0.5, 0.0, 0.0];
    c.physics.floor_friction = friction;
    c.general.gravity_m_per_s2 = [2.0 / c.snake.link_mass_kg, 0.0, -G];
    c
}

const PUSH_N: f64 = 2.0;

fn pushed_link_expected_accel(c: &Config) -> f64 {
    let m = c.snake.link_mass_kg;
    (PUSH_N - c.snake.ground_friction[0] * m * G) / m
}

/// The default job (10 links, anisotropic 0.1 / 1.0, default gait, cylinder path).
fn default_job(friction: FloorFriction) -> Config {
    let mut c = Config::default();
    c.physics.floor_friction = friction;
    c
}

#[test]
fn measure_hops_with_mujoco_friction() {
    let c = pushed_link(FloorFriction::Mujoco);
    let h = measure(&c, 0.2, 1.0);
    eprintln!("single link, mujoco: {h:?}, expected accel {}", pushed_link_expected_accel(&c));
    let h = measure(&default_job(FloorFriction::Mujoco), 2.0, 4.0);
    eprintln!("default job, mujoco: {h:?}");
}

#[test]
fn measure_hops_with_stick_slip_friction() {
    let c = pushed_link(FloorFriction::StickSlip);
    let h = measure(&c, 0.2, 1.0);
    eprintln!("single link, stick_slip: {h:?}, expected accel {}", pushed_link_expected_accel(&c));
    let h = measure(&default_job(FloorFriction::StickSlip), 2.0, 4.0);
    eprintln!("default job, stick_slip: {h:?}");
}

// --- the targets (physics.floor_friction = "stick_slip") ------------------------------

#[test]
fn a_pushed_link_keeps_its_contact_and_slides_at_f_minus_mu_m_g() {
    let c = pushed_link(FloorFriction::StickSlip);
    let h = measure(&c, 0.2, 1.0);
    let expected = pushed_link_expected_accel(&c);
    eprintln!("{h:?}, expected accel {expected}");
    assert!(h.no_contact_fraction <= 0.01, "steps without contact: {}", h.no_contact_fraction);
    assert!(
        h.peak_over_weight <= 1.05 && h.min_over_weight >= 0.95,
        "normal force / weight within {} .. {}",
        h.min_over_weight,
        h.peak_over_weight
    );
    let err = (h.mean_accel_x_m_per_s2 - expected).abs() / expected;
    assert!(err <= 0.01, "acceleration {} m/s², expected {expected} ({:.2} %)", h.mean_accel_x_m_per_s2, err * 100.0);
}

#[test]
fn the_default_job_keeps_its_floor_contacts() {
    let h = measure(&default_job(FloorFriction::StickSlip), 2.0, 4.0);
    eprintln!("{h:?}");
    assert!(h.no_contact_fraction <= 0.01, "link-steps without contact: {}", h.no_contact_fraction);
    assert!(h.peak_over_weight <= 2.0, "peak normal force / weight {}", h.peak_over_weight);
    assert!((h.impulse_over_weight - 1.0).abs() <= 0.01, "floor impulse / weight impulse {}", h.impulse_over_weight);
}
