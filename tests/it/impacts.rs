//! Impacts with the DEFAULT contact settings: snakes of 1 and 10 links at 5 m/s into a
//! cylinder (along x: head first; along y: side-on at the middle of the body) and flat onto the
//! floor, measured from every step's snapshot, as the recorded tables show it (no filtering).
//!
//! The bodies are those of the collision experiment (`experiments::collision_case_bodies`: 0.3 kg
//! links of 0.2 m, radius 0.08 m, cylinder of radius 0.2 m 0.3 m away, no friction, joints held
//! straight by stiff servos); timestep, integrator and contact settings are the defaults.
//!
//! Targets: penetration ≤ 5 mm, peak force ≤ 3 × the mean force of its contact episode, impulse
//! (Σ recorded force · dt) = momentum change within 5 %. The impulse target needs a finer step
//! than the default 1 ms: stopping 5 m/s within 5 mm takes at most 2·5 mm / 5 m/s = 2 ms, so the
//! recorded (instantaneous) forces sample the impact 2–4 times, and their sum misses Δp by up to
//! ±20 % depending on where the first touch falls between steps (`measure_impulse_at_the_default_step`
//! prints it); at 0.1 ms it holds (asserted below, as in `simserpent experiment collision`).

use simserpent::config::Config;
use simserpent::config::Integrator;
use simserpent::experiments::{LAUNCH_SPEED_M_PER_S, collision_case_bodies};
use simserpent::sim::{Simulation, Snapshot, World};
use simserpent::state::ContactForcePeaks;

use crate::common::G;

/// One impact: into the cylinder along x (0) or y (1), or onto the floor (2).
#[derive(Debug, Clone, Copy)]
struct Impact {
    max_penetration_mm: f64,
    /// Peak force / mean force of the contact episode around the peak.
    peak_over_mean: f64,
    /// Σ F·dt of the recorded forces / momentum change (the floor: with the weight's impulse).
    impulse_over_momentum_change: f64,
    contact_steps: usize,
}

/// Runs one case: `n_links`, launched at 5 m/s along `axis` (2: downward onto the floor from
/// 2 cm above it), `shift_m` farther from the cylinder or floor (to move the first touch between
/// two steps), with `timestep_secs` (`None`: the default).
fn impact(n_links: usize, axis: usize, shift_m: f64, timestep_secs: Option<f64>) -> Impact {
    let mut c = collision_case_bodies(&Config::default(), n_links);
    if let Some(dt) = timestep_secs {
        c.general.timestep_secs = dt;
    }
    if axis == 2 {
        c.snake.head_position_m[2] = 0.02 + shift_m;
    } else {
        // The cylinders stand `distance_m` ahead of and beside the head.
        c.terrain.two_cylinders.distance_m += shift_m;
    }
    let mut world = World::from_config(&c).unwrap();
    world.qvel_mut()[axis] = if axis == 2 { -LAUNCH_SPEED_M_PER_S } else { LAUNCH_SPEED_M_PER_S };
    world.forward();
    let mut sim = Simulation::new(&c, world);
    let dt = c.general.timestep_secs;
    let n = c.snake.n_links;
    let weight_n = n as f64 * c.snake.link_mass_kg * G;
    let steps = (0.15 / dt).round() as usize;
    let mut s = Snapshot::new(n, n - 1);
    let (mut force, mut momentum, mut penetration) = (vec![0.0; steps], vec![0.0; steps], vec![0.0; steps]);
    for k in 0..steps {
        sim.control();
        sim.snapshot(&mut s);
        for i in 0..n {
            force[k] += if axis == 2 { s.link_floor_force_n[i][2] } else { s.link_obstacle_force_n[i][axis] };
            momentum[k] += s.link_mass_kg[i] * s.link_velocity_m_per_s[i][axis];
        }
        penetration[k] = s.max_penetration_m();
        sim.advance().unwrap();
    }
    // The contact: obstacles, any force; the floor (which carries the weight before and after),
    // from the first touch to the end of the run of steps above twice the weight.
    let first = force.iter().position(|f| f.abs() > 1e-9).expect("the snake touched");
    let threshold = if axis == 2 { 2.0 * weight_n } else { 1e-9 };
    let last = if axis == 2 {
        let above = (first..steps).find(|&k| force[k] > threshold).expect("an impact");
        (above..steps).take_while(|&k| force[k] > threshold).last().unwrap()
    } else {
        (first..steps).rev().find(|&k| force[k].abs() > threshold).unwrap()
    };
    let (before, after) = (first - 1, (last + 1).min(steps - 1));
    let peak_row = (first..=last).max_by(|&a, &b| force[a].abs().total_cmp(&force[b].abs())).unwrap();
    let (mut start, mut end) = (peak_row, peak_row);
    while start > first && force[start - 1].abs() > threshold {
        start -= 1;
    }
    while end < last && force[end + 1].abs() > threshold {
        end += 1;
    }
    let episode_mean = force[start..=end].iter().sum::<f64>().abs() / (end - start + 1) as f64;
    let impulse = force[first..=last].iter().sum::<f64>() * dt;
    // Gravity acts on the floor case over the steps from `before` to `after`.
    let gravity_impulse = if axis == 2 { -weight_n * (after - before) as f64 * dt } else { 0.0 };
    let dp = momentum[after] - momentum[before] - gravity_impulse;
    Impact {
        max_penetration_mm: penetration[first..=last].iter().fold(0.0f64, |a, &b| a.max(b)) * 1e3,
        peak_over_mean: force[peak_row].abs() / episode_mean,
        impulse_over_momentum_change: impulse / dp,
        contact_steps: last - first + 1,
    }
}

const CASES: [(usize, usize, &str); 6] = [
    (1, 0, "1 link along x"),
    (1, 1, "1 link along y"),
    (10, 0, "10 links along x"),
    (10, 1, "10 links along y"),
    (1, 2, "1 link onto the floor"),
    (10, 2, "10 links onto the floor"),
];

/// Launch points moved back by 0, 1/3 and 2/3 of the distance covered in one default step, so
/// that the first touch falls at different points between two steps.
const SHIFTS_M: [f64; 3] = [0.0, 0.005 / 3.0, 0.01 / 3.0];

#[test]
fn impacts_with_default_settings_penetrate_at_most_5_mm_and_do_not_spike() {
    let mut failures = Vec::new();
    for (n, axis, label) in CASES {
        for shift in SHIFTS_M {
            let i = impact(n, axis, shift, None);
            eprintln!("{label}, shift {:.2} mm: {i:?}", shift * 1e3);
            if i.max_penetration_mm > 5.0 || i.peak_over_mean > 3.0 {
                failures.push(format!("{label}, shift {:.2} mm: {i:?}", shift * 1e3));
            }
        }
    }
    assert!(failures.is_empty(), "penetration > 5 mm or peak > 3 x mean: {failures:#?}");
}

#[test]
fn impact_impulse_matches_the_momentum_change_at_a_0_1_ms_step() {
    // The default contact settings ("auto": 2 ms, 0.5 at any step up to 1 ms), sampled finely.
    let mut failures = Vec::new();
    for (n, axis, label) in CASES {
        let i = impact(n, axis, 0.0, Some(0.0001));
        eprintln!("{label}, 0.1 ms: {i:?}");
        let ok = (i.impulse_over_momentum_change - 1.0).abs() <= 0.05
            && i.max_penetration_mm <= 5.0
            && i.peak_over_mean <= 3.0;
        if !ok {
            failures.push(format!("{label}: {i:?}"));
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
#[ignore = "probe: the impulse of the recorded forces at the default 1 ms step (run with --ignored --nocapture)"]
fn measure_impulse_at_the_default_step() {
    for (n, axis, label) in CASES {
        let r: Vec<String> = (0..5)
            .map(|k| impact(n, axis, k as f64 * 0.001, None))
            .map(|i| format!("{:+.1} % ({} steps)", (i.impulse_over_momentum_change - 1.0) * 100.0, i.contact_steps))
            .collect();
        eprintln!("{label}: Σ F·dt / Δp − 1 at shifts 0..4 mm: {}", r.join(", "));
    }
}

/// One link launched down at 5 m/s from 2 cm onto the floor (the collision experiment's body,
/// no friction), stepped `dt` with `integrator` for 0.1 s: the run's peak forces, and the
/// link's vertical velocity at every instant.
fn drop_trace(dt: f64, integrator: Integrator) -> (ContactForcePeaks, Vec<f64>) {
    let mut c = collision_case_bodies(&Config::default(), 1);
    c.general.timestep_secs = dt;
    c.general.integrator = integrator;
    c.snake.head_position_m[2] = 0.02;
    let mut world = World::from_config(&c).unwrap();
    world.qvel_mut()[2] = -LAUNCH_SPEED_M_PER_S;
    world.forward();
    let mut sim = Simulation::new(&c, world);
    let steps = (0.1 / dt).round() as usize;
    let mut v = Vec::with_capacity(steps + 1);
    for _ in 0..steps {
        sim.control();
        v.push(sim.world().data().qvel()[2]);
        sim.advance().unwrap();
    }
    v.push(sim.world().data().qvel()[2]);
    (sim.contact_peaks().clone(), v)
}

/// The largest momentum change over a 10-ms window of steps plus the weight's impulse, over
/// 10 ms: what the floor's force averaged over the window must be (Newton's second law).
fn momentum_change_force_n(v: &[f64], dt: f64, mass_kg: f64) -> f64 {
    let w = (0.01 / dt).round() as usize;
    (0..v.len() - w).map(|k| mass_kg * (v[k + w] - v[k]) / 0.01 + mass_kg * G).fold(0.0, f64::max)
}

#[test]
fn the_windowed_peak_force_of_a_landing_is_its_momentum_change_over_the_window() {
    // Euler and implicitfast apply each step's contact force, read at the step's start, for the
    // whole step: the floor's impulse over a window is the momentum change plus the weight's
    // impulse, exactly, at every step (the landing itself differs from step to step: the contact's
    // time constant follows the step, and with it the rebound).
    let mass_kg = collision_case_bodies(&Config::default(), 1).snake.link_mass_kg;
    let mut failures = Vec::new();
    for integrator in [Integrator::Euler, Integrator::ImplicitFast] {
        for dt in [0.00025, 0.0005, 0.001, 0.002] {
            let (peaks, v) = drop_trace(dt, integrator);
            let expected_n = momentum_change_force_n(&v, dt, mass_kg);
            eprintln!("{integrator:?} {dt}: windowed {:.3} N, m·Δv/T + m·g {expected_n:.3} N", peaks.peak_windowed_n);
            if (peaks.peak_windowed_n - expected_n).abs() > 1e-9 * expected_n || peaks.peak_windowed_link != Some(0) {
                failures.push(format!("{integrator:?} dt {dt}: {} N against {expected_n} N", peaks.peak_windowed_n));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
fn the_windowed_peak_force_equals_the_momentum_change_with_rk4_on_the_floor_law() {
    // RK4 (the default) with the default floor law (`physics.floor_friction = "stick_slip"`):
    // the floor's normal force is SimSerpent's own, computed at the step's start and held over
    // the step, so the force the figure reads is the force the step integrates — the windowed
    // impulse equals the momentum change at every step size, as with Euler.
    let mass_kg = collision_case_bodies(&Config::default(), 1).snake.link_mass_kg;
    let mut failures = Vec::new();
    for dt in [0.001, 0.0005, 0.00025] {
        let (peaks, v) = drop_trace(dt, Integrator::RK4);
        let expected_n = momentum_change_force_n(&v, dt, mass_kg);
        eprintln!("RK4 {dt}: windowed {:.3} N, m·Δv/T + m·g {expected_n:.3} N", peaks.peak_windowed_n);
        if (peaks.peak_windowed_n - expected_n).abs() > 1e-9 * expected_n || peaks.peak_windowed_link != Some(0) {
            failures.push(format!("RK4 dt {dt}: {} N against {expected_n} N", peaks.peak_windowed_n));
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
#[ignore = "probe: the run summary's peak contact forces of the collision cases at 0.25/0.5/1/2 ms (run with --ignored --nocapture)"]
fn measure_peak_force_convergence_of_the_collision_cases() {
    eprintln!("| case | dt (ms) | peak averaged over 10 ms (N) | peak at a single step (N) |");
    eprintln!("|---|---|---|---|");
    for (n, axis, label) in CASES {
        for dt in [0.00025, 0.0005, 0.001, 0.002] {
            let mut c = collision_case_bodies(&Config::default(), n);
            c.general.timestep_secs = dt;
            if axis == 2 {
                c.snake.head_position_m[2] = 0.02;
            }
            let mut world = World::from_config(&c).unwrap();
            world.qvel_mut()[axis] = if axis == 2 { -LAUNCH_SPEED_M_PER_S } else { LAUNCH_SPEED_M_PER_S };
            world.forward();
            let mut sim = Simulation::new(&c, world);
            let plan = simserpent::sim::LoopPlan { steps: (0.25 / dt).round() as u64, record_every_n_steps: 0 };
            sim.run::<simserpent::sim::SimError>(plan, &mut []).unwrap();
            let p = sim.contact_peaks();
            eprintln!("| {label} | {} | {:.1} | {:.1} |", dt * 1e3, p.peak_windowed_n, p.peak_step_n);
        }
    }
}
