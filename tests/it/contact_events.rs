//! Contact events with the default contact law (`physics.floor_friction = "stick_slip"`), with
//! both its solves (`physics.environment_contact_solve`: `"per_link"`, the default, and
//! `"whole_body"`; a slow test's whole-body twin runs with the slow tests),
//! measured from every step's snapshot as the recorded tables show it (`Simulation::control`, the
//! recording's forward pass at x_k, then the step): a straight snake at rest, launched sideways,
//! standing upright, hit sideways on the cylinders, the gait's ramp, a slowly ramped push that
//! breaks a link away, and a coasting snake.
//!
//! Figures of the reference engine (Drake, the same chain, `validation/`): a straight chain
//! launched sideways rolls as one body (0 % airborne, the floor carrying its weight); during the
//! gait's ramp links lift 0.65–1.2 mm and land at 7–16 × a link's weight. Run with
//! `--nocapture` to see ours.

use simserpent::config::{Config, ExternalForce};
use simserpent::sim::{Simulation, Snapshot, World};
use simserpent::state::x_axis;

use crate::common::{G, default_config_with};

/// The two solves of the contact law (`physics.environment_contact_solve`).
const PER_LINK: &str = "per_link";
const WHOLE_BODY: &str = "whole_body";
const LAWS: [&str; 2] = [PER_LINK, WHOLE_BODY];

/// The validation suite's scene settings (`validation/scenes.py`): the default snake on a bare
/// floor, isotropic μ everywhere, plus the scene's own keys; position servos with the gains the
/// reference figures below were computed with (kp 5 N·m/rad, kv 0.1 N·m·s/rad: stiffer servos
/// lift the links more during the ramp, in both engines), with
/// `physics.environment_contact_solve = law`.
fn scene_in(law: &str, mu: f64, keys: &[&str]) -> Config {
    let mut sets: Vec<String> = [
        format!("physics.environment_contact_solve=\"{law}\""),
        "control.controller=\"gait\"".to_string(),
        "control.position_kp_nm_per_rad=5.0".to_string(),
        "control.position_kv_nm_s_per_rad=0.1".to_string(),
        "ground.model=\"isotropic\"".to_string(),
        format!("snake.ground_friction=[{mu}, 0.0, 0.0]"),
        format!("snake.link_friction=[{mu}, 0.0, 0.0]"),
        format!("terrain.obstacle_friction=[{mu}, 0.0, 0.0]"),
        "terrain.kind=\"none\"".to_string(),
    ]
    .into();
    sets.extend(keys.iter().map(|k| k.to_string()));
    default_config_with(&sets).unwrap()
}

/// A straight snake (no gait, servos holding it straight) on the bare floor.
fn straight(mu: f64, keys: &[&str]) -> Config {
    straight_in(PER_LINK, mu, keys)
}

/// [`straight`] with `physics.environment_contact_solve = law`.
fn straight_in(law: &str, mu: f64, keys: &[&str]) -> Config {
    let mut k = vec!["gait.kind=\"none\""];
    k.extend_from_slice(keys);
    scene_in(law, mu, &k)
}

/// Height of a link's lowest point above the floor (m): its capsule's axis segment end nearest
/// the floor, minus the radius.
fn lift_m(c: &Config, s: &Snapshot, i: usize) -> f64 {
    let (l, r) = (c.snake.link_length_m, c.snake.link_radius_m);
    let a = x_axis(s.link_quat[i]);
    s.link_position_m[i][2] - (0.5 * l - r) * a[2].abs() - r
}

/// What one run segment shows, every step.
#[derive(Debug, Default, Clone, Copy)]
struct Events {
    /// Link-steps without floor normal force / all link-steps.
    airborne_fraction: f64,
    /// Largest floor normal force of one link / its weight.
    peak_over_weight: f64,
    /// Largest |Σ floor normal force / weight − 1| of the whole snake.
    total_load_error: f64,
    /// Largest |floor normal force / weight − 1| of one link.
    link_load_error: f64,
    /// Largest lift of a link's lowest point above the floor (m).
    max_lift_m: f64,
    /// Largest |friction| / (μ N) of a contact row, and friction on rows without normal force.
    friction_over_mu_n: f64,
    friction_without_contact_n: f64,
}

/// Steps `sim` for `secs`, reading every instant's snapshot.
fn measure(c: &Config, sim: &mut Simulation, secs: f64, mu: f64) -> Events {
    let n = c.snake.n_links;
    let dt = c.general.timestep_secs;
    let mut s = Snapshot::new(n, n.saturating_sub(1));
    let steps = (secs / dt).round() as usize;
    let mut e = Events::default();
    let mut airborne = 0usize;
    for _ in 0..steps {
        sim.control();
        sim.snapshot(&mut s);
        let (mut total, mut weight) = (0.0, 0.0);
        for i in 0..n {
            let w = s.link_mass_kg[i] * G;
            let fz = s.link_floor_force_n[i][2];
            if fz <= 0.0 {
                airborne += 1;
            }
            total += fz;
            weight += w;
            e.peak_over_weight = e.peak_over_weight.max(fz / w);
            e.link_load_error = e.link_load_error.max((fz / w - 1.0).abs());
            e.max_lift_m = e.max_lift_m.max(lift_m(c, &s, i));
        }
        e.total_load_error = e.total_load_error.max((total / weight - 1.0).abs());
        for row in &s.contacts {
            let f = row.friction_force_n[0].hypot(row.friction_force_n[1]);
            if row.normal_force_n > 0.0 {
                e.friction_over_mu_n = e.friction_over_mu_n.max(f / (mu * row.normal_force_n));
            } else {
                e.friction_without_contact_n = e.friction_without_contact_n.max(f);
            }
        }
        sim.advance().unwrap();
    }
    e.airborne_fraction = airborne as f64 / (steps * n) as f64;
    e
}

fn run_for(sim: &mut Simulation, c: &Config, secs: f64) {
    for _ in 0..(secs / c.general.timestep_secs).round() as usize {
        sim.step().unwrap();
    }
}

fn simulation(c: &Config) -> Simulation {
    Simulation::new(c, World::from_config(c).unwrap())
}

#[test]
fn a_straight_snake_at_rest_carries_each_links_weight_on_that_link() {
    for law in LAWS {
        let c = straight_in(law, 0.5, &[]);
        let mut sim = simulation(&c);
        run_for(&mut sim, &c, 0.5);
        let e = measure(&c, &mut sim, 0.5, 0.5);
        eprintln!("{law}: {e:?}");
        assert!(
            e.link_load_error <= 0.02,
            "{law}: a link's floor load differs from its weight by {:.2} %",
            e.link_load_error * 100.0
        );
        assert_eq!(e.airborne_fraction, 0.0, "{law}");
    }
}

#[test]
fn a_straight_snake_launched_sideways_rolls_without_lifting() {
    for (law, mu) in LAWS.into_iter().flat_map(|law| [(law, 0.5), (law, 1.0)]) {
        let c = straight_in(law, mu, &["initial_state.linear_velocity_m_per_s=[0.0, 5.0, 0.0]"]);
        // The snake starts touching the floor exactly and settles onto its sink under its own
        // weight (g/ω² ≈ 10 µm) within the first steps; measured from 50 ms on.
        let mut sim = simulation(&c);
        run_for(&mut sim, &c, 0.05);
        let e = measure(&c, &mut sim, 0.95, mu);
        eprintln!("{law}, μ {mu}: {e:?}");
        assert_eq!(e.airborne_fraction, 0.0, "{law}, μ {mu}: {e:?}");
        assert!(e.total_load_error <= 0.02, "{law}, μ {mu}: Σ N / W − 1 up to {:.2} %", e.total_load_error * 100.0);
        assert!(e.friction_over_mu_n <= 1.0 + 1e-9 && e.friction_without_contact_n == 0.0, "{law}, μ {mu}: {e:?}");
    }
}

#[test]
fn an_upright_snake_stands() {
    for law in LAWS {
        an_upright_snake_stands_with(law);
    }
}

fn an_upright_snake_stands_with(law: &str) {
    // Standing on the head's tip: the body (along −x of the head) pointing up.
    let c = straight_in(law, 0.5, &["snake.head_rotation_deg=[0.0, 90.0, 0.0]"]);
    let mut world = World::from_config(&c).unwrap();
    // The configured pose holds the tip one radius above the floor: lower it onto the floor.
    world.qpos_mut()[2] -= c.snake.link_radius_m;
    world.forward();
    let mut sim = Simulation::new(&c, world);
    let n = c.snake.n_links;
    let mut s = Snapshot::new(n, n - 1);
    sim.control();
    sim.snapshot(&mut s);
    let start = s.link_position_m[n - 1];
    run_for(&mut sim, &c, 2.0);
    sim.control();
    sim.snapshot(&mut s);
    let top = s.link_position_m[n - 1];
    let off = (top[0] - start[0]).hypot(top[1] - start[1]);
    eprintln!("{law}: top link {off:e} m off the vertical");
    assert!(off <= 1e-3, "{law}: the top link is {off} m off the vertical after 2 s");
}

/// The sideways hit on the cylinders: the straight snake at 5 m/s into the two-cylinder terrain
/// (distance 0.3 m, radius 0.2 m).
fn hit(law: &str, mu: f64) -> Config {
    straight_in(
        law,
        mu,
        &[
            "initial_state.linear_velocity_m_per_s=[0.0, 5.0, 0.0]",
            "terrain.kind=\"two_cylinders\"",
            "terrain.two_cylinders.distance_m=0.3",
            "terrain.two_cylinders.radius_m=0.2",
        ],
    )
}

/// At μ 0.5 the reference (Drake) throws the snake off the floor too: its largest lift is 182 mm.
#[test]
fn a_sideways_hit_on_the_cylinders_stays_within_the_reference_lift() {
    for law in LAWS {
        let c = hit(law, 0.5);
        let e = measure(&c, &mut simulation(&c), 1.0, 0.5);
        eprintln!("{law}: {e:?}");
        assert!(e.max_lift_m <= 1.5 * 0.182, "{law}: a link lifts {} mm (reference 182 mm)", e.max_lift_m * 1e3);
        // Friction of the same instant's contacts, floor and cylinders: within μN, none on an
        // open row.
        assert!(e.friction_over_mu_n <= 1.0 + 1e-9 && e.friction_without_contact_n == 0.0, "{law}: {e:?}");
    }
}

/// A 64 × 64 gray PNG of bumps (a product of sines, four bumps across), for a heightfield.
fn write_bumps_png(path: &std::path::Path) {
    crate::common::write_gray_png_of(path, 64, 64, |c, r| {
        let (x, y) = (c as f64 / 64.0, r as f64 / 64.0);
        (127.5 + 127.5 * (8.0 * std::f64::consts::PI * x).sin() * (8.0 * std::f64::consts::PI * y).cos()) as u8
    });
}

/// On heightfield ground (the law's contacts at the link's ends and under a bump at its middle)
/// friction is bounded by the normal force of the same instant too: the gait on 10 mm bumps,
/// every step for 3 s from t = 0, μ 0.5 and 1.
#[test]
fn friction_on_a_bumpy_heightfield_stays_within_mu_n_of_the_same_instant() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("bumps.png");
    write_bumps_png(&png);
    for (law, mu) in LAWS.into_iter().flat_map(|law| [(law, 0.5), (law, 1.0)]) {
        let c = scene_in(
            law,
            mu,
            &[
                &format!("terrain.heightfield.file={:?}", png.display().to_string()),
                "terrain.heightfield.size_x_m=4.0",
                "terrain.heightfield.size_y_m=4.0",
                "terrain.heightfield.height_m=0.01",
                "snake.head_position_m=[0.0, 0.0, 0.011]",
            ],
        );
        let e = measure(&c, &mut simulation(&c), 3.0, mu);
        eprintln!("{law}, μ {mu}: {e:?}");
        assert!(e.friction_over_mu_n <= 1.0 + 1e-9 && e.friction_without_contact_n == 0.0, "{law}, μ {mu}: {e:?}");
    }
}

/// The validation suite's bumpy heightfield (`validation/scenes.py`, "hf_bumps"): a 3 m × 2 m
/// grid of 2 cm (151 × 101 points, 40 mm of height; 8 bits here) 20 mm above the floor, with six
/// spherical caps 10 mm high (sphere radius 0.5 m) at x = −0.3, −0.9, −1.5 m, y = ±0.15 m.
fn write_validation_bumps_png(path: &std::path::Path) {
    let (cols, rows) = (151u32, 101u32);
    let caps: Vec<(f64, f64)> = [-0.3, -0.9, -1.5].into_iter().flat_map(|x| [(x, -0.15), (x, 0.15)]).collect();
    crate::common::write_gray_png_of(path, cols, rows, |c, r| {
        let x = -1.0 + (c as f64 / (cols - 1) as f64 - 0.5) * 3.0;
        let y = (0.5 - r as f64 / (rows - 1) as f64) * 2.0;
        // The caps' height above the flat part: sphere (radius 0.5 m) centres 0.49 m below it.
        let cap = caps
            .iter()
            .map(|&(cx, cy)| (0.25 - (x - cx).powi(2) - (y - cy).powi(2)).max(0.0).sqrt() - 0.49)
            .fold(0.0, f64::max);
        ((0.02 + cap) / 0.04 * 255.0).round() as u8
    });
}

/// Two starts a nanometre apart on the bumps stay a nanometre apart through the first impacts
/// on them (0.3 s, μ 1, every link within 1e-7 m of its twin). The point under a link's middle
/// over a bump is sampled along the capsule's own length: sampled over the span between the
/// ends' world positions, 0.12 m over the 2-cm grid rounded to either side of 6 samples, and the
/// point jumped between the twins (2.6e-6 m apart at 0.3 s here, 5.7e-5 m in the suite's 16-bit scene).
#[test]
fn two_starts_a_nanometre_apart_on_bumps_stay_together_through_the_first_impacts() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("bumps.png");
    write_validation_bumps_png(&png);
    let file = format!("terrain.heightfield.file={:?}", png.display().to_string());
    let positions = ["0.0", "1e-9"].map(|y| {
        let head = format!("snake.head_position_m=[0.0, {y}, 0.02]");
        let mut sets: Vec<String> = [
            "control.controller=\"gait\"",
            "ground.model=\"isotropic\"",
            "snake.ground_friction=[1.0, 0.0, 0.0]",
            "snake.link_friction=[1.0, 0.0, 0.0]",
            "terrain.obstacle_friction=[1.0, 0.0, 0.0]",
            "terrain.kind=\"none\"",
            "terrain.heightfield.center_m=[-1.0, 0.0]",
            "terrain.heightfield.size_x_m=3.0",
            "terrain.heightfield.size_y_m=2.0",
            "terrain.heightfield.height_m=0.04",
        ]
        .map(String::from)
        .into();
        sets.extend(SCENE_GAIT.map(String::from));
        sets.extend([file.clone(), head]);
        let c = default_config_with(&sets).unwrap();
        let mut sim = simulation(&c);
        for _ in 0..300 {
            sim.control();
            sim.advance().unwrap();
        }
        let mut s = Snapshot::new(c.snake.n_links, c.snake.n_links - 1);
        sim.snapshot(&mut s);
        s.link_position_m
    });
    let apart = positions[0]
        .iter()
        .zip(&positions[1])
        .flat_map(|(a, b)| (0..3).map(move |k| (a[k] - b[k]).abs()))
        .fold(0.0, f64::max);
    eprintln!("two starts 1 nm apart on the bumps: {apart:.2e} m apart after 0.3 s");
    assert!(apart < 1e-7, "{apart:e} m");
}

/// With the whole-body solve the gait on 10-mm bumps converges in the step: its centre-of-mass
/// speed over 1–3 s at 0.5 ms within 5 % of the 1-ms step's, at μ 0.5 and 1 (measured 230.1 and
/// 230.0 mm/s, 204.0 and 204.2 mm/s).
#[test]
fn the_gait_on_a_bumpy_heightfield_converges_in_the_step_with_the_whole_body_solve() {
    bumpy_gait_converges(WHOLE_BODY);
}

/// The gait on the 10-mm bumps with `law`: its speed over 1–3 s at 0.5 ms within 5 % of the 1-ms
/// step's, at μ 0.5 and 1.
fn bumpy_gait_converges(law: &str) {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("bumps.png");
    write_bumps_png(&png);
    let file = format!("terrain.heightfield.file={:?}", png.display().to_string());
    for mu in [0.5, 1.0] {
        let speeds = [1e-3, 5e-4].map(|dt| {
            let step = format!("general.timestep_secs={dt}");
            let keys = [
                &SCENE_GAIT[..],
                &[
                    file.as_str(),
                    "terrain.heightfield.size_x_m=4.0",
                    "terrain.heightfield.size_y_m=4.0",
                    "terrain.heightfield.height_m=0.01",
                    "snake.head_position_m=[0.0, 0.0, 0.011]",
                    step.as_str(),
                ],
            ]
            .concat();
            ground_figures(&scene_in(law, mu, &keys)).speed_m_per_s
        });
        eprintln!(
            "{law}, μ {mu}: speed on the bumps {:.1} / {:.1} mm/s at 1 / 0.5 ms",
            speeds[0] * 1e3,
            speeds[1] * 1e3
        );
        assert!((speeds[1] / speeds[0] - 1.0).abs() <= 0.05, "μ {mu}: {speeds:?}");
    }
}

/// The same with the per-link law, the default (measured 237.0 and 234.3 mm/s, 212.7 and 211.8
/// mm/s; the validation suite's bumps, beside the body, over 16 starts: 341 / 339 and 194 / 190).
#[test]
fn the_gait_on_a_bumpy_heightfield_converges_in_the_step() {
    bumpy_gait_converges(PER_LINK);
}

/// Prints the sideways hit's events at μ 0.5 and 1.
#[test]
#[ignore = "probe: the sideways hit at μ 0.5 and 1 (run with --ignored --nocapture)"]
fn measure_sideways_hit() {
    for (law, mu) in LAWS.into_iter().flat_map(|law| [(law, 0.5), (law, 1.0)]) {
        let c = hit(law, mu);
        let e = measure(&c, &mut simulation(&c), 1.0, mu);
        eprintln!("{law}, μ {mu}: {e:?}");
    }
}

/// The reference's largest lift (m) and landing (× m g) in the gait's 1-s ramp (Drake), and its
/// mean floor load per link over 1–3 s (× m g, head to tail).
const RAMP_REFERENCE: [(f64, f64, f64, [f64; 10]); 2] = [
    (0.5, 0.874e-3, 15.8, [0.998, 0.997, 1.000, 1.004, 1.005, 1.003, 1.000, 0.996, 0.996, 1.001]),
    (1.0, 3.55e-3, 68.1, [1.002, 0.998, 1.000, 1.004, 1.004, 1.000, 0.995, 0.992, 0.997, 1.011]),
];

/// The reference scenes' gait: a 30° wave at 0.5 Hz, 40° between joints, ramped in over 1 s.
const SCENE_GAIT: [&str; 6] = [
    "gait.kind=\"sine_wave\"",
    "gait.sine_wave.amplitude_deg=30.0",
    "gait.sine_wave.frequency_hz=0.5",
    "gait.sine_wave.phase_lag_deg=40.0",
    "gait.sine_wave.offset_deg=0.0",
    "gait.ramp_secs=1.0",
];

#[test]
fn the_gait_ramp_and_steady_undulation_stay_within_the_reference_envelope() {
    for (law, (mu, lift, peak, loads)) in LAWS.into_iter().flat_map(|law| RAMP_REFERENCE.map(|r| (law, r))) {
        let c = scene_in(law, mu, &SCENE_GAIT);
        let mut sim = simulation(&c);
        let e = measure(&c, &mut sim, 1.0, mu);
        eprintln!("{law}, μ {mu}, ramp: {e:?}");
        assert!(e.max_lift_m <= 1.5 * lift, "{law}, μ {mu}: largest lift {} mm", e.max_lift_m * 1e3);
        assert!(e.peak_over_weight <= 2.0 * peak, "{law}, μ {mu}: peak {} × m g", e.peak_over_weight);
        assert!(e.friction_over_mu_n <= 1.0 + 1e-9 && e.friction_without_contact_n == 0.0, "{law}, μ {mu}: {e:?}");
        // Steady undulation, 1–3 s: each link's mean floor load.
        let n = c.snake.n_links;
        let mut s = Snapshot::new(n, n - 1);
        let mut sum = vec![0.0; n];
        let steps = (2.0 / c.general.timestep_secs).round() as usize;
        for _ in 0..steps {
            sim.control();
            sim.snapshot(&mut s);
            for (i, total) in sum.iter_mut().enumerate() {
                *total += s.link_floor_force_n[i][2] / (s.link_mass_kg[i] * G) / steps as f64;
            }
            sim.advance().unwrap();
        }
        eprintln!("{law}, μ {mu}, mean load per link 1–3 s: {sum:.3?}");
        for (i, (load, reference)) in sum.iter().zip(loads).enumerate() {
            assert!(
                (load / reference - 1.0).abs() <= 0.05,
                "{law}, μ {mu}: link {i} carries {load} × m g, reference {reference}"
            );
        }
    }
}

/// One link on the floor pushed along its axis by a force ramped slowly through μ·m·g
/// (`[[physics.external_forces]]`): it stays put until the push reaches μ·N and slides from there.
#[test]
fn a_slowly_ramped_push_breaks_a_link_away_at_mu_n() {
    for (law, mu) in LAWS.into_iter().flat_map(|law| [(law, 0.5), (law, 1.0)]) {
        let mut c = straight_in(law, mu, &["snake.n_links=1"]);
        let mu_n = mu * c.snake.link_mass_kg * G;
        // From 0 at 0.2 s, at a quarter of μN per second, along the link's axis (+x).
        let (start, rate) = (0.2, 0.25 * mu_n);
        c.physics.external_forces = vec![ExternalForce {
            link: 0,
            direction: [1.0, 0.0, 0.0],
            start_secs: start,
            ramp_n_per_s: rate,
            force_n: 2.0 * mu_n,
            duration_secs: 0.0,
        }];
        c.validate().unwrap();
        let mut sim = simulation(&c);
        run_for(&mut sim, &c, start);
        let mut s = Snapshot::new(1, 0);
        let mut broke_at = None;
        for _ in 0..(4.4 / c.general.timestep_secs) as usize {
            let push = rate * (sim.world_mut().time_secs() - start);
            sim.control();
            sim.snapshot(&mut s);
            // Break-away: the first step faster than 1 mm/s. Sliding from t_b on, m·dv/dt =
            // rate·(t − t_b), so v = rate·(t − t_b)²/(2m): the push at t_b is the push now less
            // √(2·m·v·rate) (the validation suite's reading).
            let v = s.link_velocity_m_per_s[0][0];
            if v > 1e-3 {
                broke_at = Some(push - (2.0 * c.snake.link_mass_kg * v * rate).sqrt());
                break;
            }
            sim.advance().unwrap();
        }
        let ratio = broke_at.expect("the link broke away") / mu_n;
        eprintln!("{law}, μ {mu}: broke away at {ratio} μN");
        assert!((ratio - 1.0).abs() <= 0.01, "{law}, μ {mu}: broke away at {ratio} × μN");
    }
}

/// Motors off (torque control, PID gains 0), launched at 1 m/s sideways spinning at 2 rad/s, 2 s
/// from t = 0, every step: the energy (kinetic + potential + the floor springs' ½·k·δ²) never
/// rises by more than 1e-6 J in a step — no actuator works, so only a contact law that gives
/// energy back could raise it. (Kinetic + potential alone, the validation suite's figure, also
/// moves with the energy the floor springs hold at the step's start and end.)
#[test]
fn a_coasting_snake_never_gains_energy_in_a_step() {
    for (law, mu) in LAWS.into_iter().flat_map(|law| [(law, 0.5), (law, 1.0)]) {
        let c = straight_in(
            law,
            mu,
            &[
                "initial_state.linear_velocity_m_per_s=[0.0, 1.0, 0.0]",
                "initial_state.angular_velocity_rad_per_s=[0.0, 0.0, 2.0]",
                "control.method=\"torque\"",
                "control.pid_kp_nm_per_rad=0.0",
                "control.pid_ki_nm_per_rad_s=0.0",
                "control.pid_kd_nm_s_per_rad=0.0",
            ],
        );
        let mut sim = simulation(&c);
        let n = c.snake.n_links;
        let mut s = Snapshot::new(n, n - 1);
        let (mut previous, mut previous_el): (Option<f64>, f64) = (None, 0.0);
        let (mut rise, mut rise_el) = (f64::NEG_INFINITY, f64::NEG_INFINITY);
        for _ in 0..(2.0 / c.general.timestep_secs) as usize {
            sim.control();
            sim.snapshot(&mut s);
            let potential: f64 = (0..n).map(|i| s.link_mass_kg[i] * G * s.link_position_m[i][2]).sum();
            let e = sim.world_mut().kinetic_energy_j() + potential;
            let el = e + sim.ground().elastic_energy_j();
            if let Some(p) = previous {
                rise = rise.max(e - p);
                rise_el = rise_el.max(el - previous_el);
            }
            previous = Some(e);
            previous_el = el;
            sim.advance().unwrap();
        }
        eprintln!(
            "{law}, μ {mu}: largest rise in a step: kinetic + potential {rise:e} J, with the floor's elastic energy \
             {rise_el:e} J"
        );
        assert!(rise_el <= 1e-6, "{law}, μ {mu}: the energy rises by {rise_el:e} J in a step");
    }
}

/// `[[physics.external_forces]]`: a 1-N push for 0.1 s on a link on a frictionless floor gives it
/// F·t/m and then nothing more; bad entries are refused naming the key.
#[test]
fn an_external_force_pushes_for_its_duration_and_bad_entries_are_refused() {
    let c = straight(
        0.0,
        &[
            "snake.n_links=1",
            "physics.external_forces=[{ link = 0, direction = [0.0, 2.0, 0.0], start_secs = 0.05, ramp_n_per_s = 0.0, \
             force_n = 1.0, duration_secs = 0.1 }]",
        ],
    );
    let mut sim = simulation(&c);
    run_for(&mut sim, &c, 0.3);
    let mut s = Snapshot::new(1, 0);
    sim.control();
    sim.snapshot(&mut s);
    let expected = 1.0 * 0.1 / c.snake.link_mass_kg;
    let v = s.link_velocity_m_per_s[0];
    eprintln!("velocity {v:?}, expected {expected} along y");
    assert!((v[1] - expected).abs() <= 1e-3 * expected && v[0].abs() < 1e-6, "{v:?}");
    let entry = |field: &str| {
        let mut e = [
            "link = 0",
            "direction = [1.0, 0.0, 0.0]",
            "start_secs = 0.0",
            "ramp_n_per_s = 0.0",
            "force_n = 1.0",
            "duration_secs = 0.0",
        ];
        let name = field.split(' ').next().unwrap();
        for x in e.iter_mut() {
            if x.starts_with(name) {
                *x = field;
            }
        }
        format!("physics.external_forces=[{{ {} }}]", e.join(", "))
    };
    for (field, key) in [
        ("link = 3", "physics.external_forces[0].link"),
        ("direction = [0.0, 0.0, 0.0]", "physics.external_forces[0].direction"),
        ("start_secs = -1.0", "physics.external_forces[0].start_secs"),
        ("ramp_n_per_s = -2.0", "physics.external_forces[0].ramp_n_per_s"),
        ("force_n = nan", "physics.external_forces[0].force_n"),
        ("duration_secs = inf", "physics.external_forces[0].duration_secs"),
    ] {
        let e = default_config_with(&["snake.n_links=3".to_string(), entry(field)]).unwrap_err().to_string();
        assert!(e.contains(key), "{field}: {e}");
    }
}

/// One link dropped flat from about `drop_m` on the bare floor with the default settings but
/// `keys`: its restitution √(rebound apex / drop height), the heights of its lowest point above
/// the floor, every step from t = 0 until the apex after the first bounce.
fn dropped_link_restitution(drop_m: f64, keys: &[&str]) -> f64 {
    let mut sets: Vec<String> = vec![
        "snake.n_links=1".into(),
        "terrain.kind=\"none\"".into(),
        "gait.kind=\"none\"".into(),
        format!("snake.head_position_m=[0.0, 0.0, {}]", 0.04 + drop_m),
    ];
    sets.extend(keys.iter().map(|k| k.to_string()));
    let c = default_config_with(&sets).unwrap();
    let r = c.snake.link_radius_m;
    let mut sim = simulation(&c);
    let height = sim.world().data().qpos()[2] - r;
    let dt = c.general.timestep_secs;
    let (mut touched, mut apex) = (false, f64::NEG_INFINITY);
    for _ in 0..(1.0 / dt) as usize {
        sim.step().unwrap();
        let (z, vz) = (sim.world().data().qpos()[2] - r, sim.world().data().qvel()[2]);
        touched |= z <= 0.0;
        if touched && z > 0.0 {
            apex = apex.max(z);
            if vz < 0.0 {
                break;
            }
        }
    }
    assert!(touched && apex > 0.0, "the link never bounced ({keys:?})");
    (apex / height).sqrt()
}

/// The bounce is a setting: a link dropped flat from 0.2 m rebounds at
/// `physics.contact_restitution` within ±0.05 at 0.25 ms and 0.1 ms; at 1 ms (ω·dt = 1) one
/// impact's rebound moves with where in the step it starts, and the mean over eight drops from
/// 0.19 to 0.2075 m (a step's travel apart) is within ±0.05 of the setting and of the 0.1-ms
/// figure; for the default and two other values. Gravity during the 3-ms contact takes about
/// 0.01 off. Every figure is the one the guide's table ("Floor contact") states, to its three
/// digits.
#[test]
fn a_dropped_link_rebounds_at_the_configured_restitution() {
    rebounds_at_the_configured_restitution(PER_LINK, 1);
}

/// A short, thick link (the thesis' radius 0.08 m and the Boa preset's 0.05 m on a 0.2-m link)
/// lands flat at the configured restitution too: its end points move almost as its centre does,
/// and each carries at most half the link. At 1 ms the mean of eight drops a step's travel apart
/// is within ±0.05 of the setting and of the 0.1-ms figure, and no single drop rebounds above
/// 0.45. Scaled by the end's effective mass alone (nearly the whole link's), these drops
/// rebounded at 0.050 on average at 1 ms (0.296 at 0.1 ms), and a 5-m/s landing that began at a
/// step's end at 0.97.
#[test]
fn a_short_thick_link_rebounds_at_the_configured_restitution() {
    for radius in [0.08, 0.05] {
        let at = |dt: f64, drop_m: f64| {
            let keys = [format!("snake.link_radius_m={radius}"), format!("general.timestep_secs={dt}")];
            let keys: Vec<&str> = keys.iter().map(|s| s.as_str()).collect();
            dropped_link_restitution(drop_m, &keys)
        };
        let drops: Vec<f64> = (0..8).map(|k| at(1e-3, 0.19 + 0.0025 * k as f64)).collect();
        let mean = drops.iter().sum::<f64>() / drops.len() as f64;
        let fine = at(1e-4, 0.2);
        eprintln!("radius {radius}: 1 ms {drops:.3?} (mean {mean:.3}), 0.1 ms {fine:.3}");
        assert!((mean - 0.3).abs() <= 0.05 && (fine - 0.3).abs() <= 0.05, "radius {radius}: {mean} / {fine}");
        assert!((mean - fine).abs() <= 0.05, "radius {radius}: {mean} / {fine}");
        assert!(drops.iter().all(|&e| e <= 0.45), "radius {radius}: {drops:?}");
    }
}

/// The figures of the guide's restitution table ("Floor contact") in the row of the configured
/// restitution `e`, from column `first` on (1: the per-link law's three, 4: the whole-body
/// solve's three).
fn guide_restitution_row(page: &str, e: f64, first: usize) -> Vec<f64> {
    let row = page
        .lines()
        .find(|l| l.trim_start().starts_with(&format!("| {e} |")))
        .unwrap_or_else(|| panic!("the guide's restitution table has no row {e}"));
    row.split('|').map(str::trim).filter(|c| !c.is_empty()).skip(first).map(|c| c.parse().unwrap()).collect()
}

/// The same with the whole-body solve ("whole_body" columns of the guide's table).
#[test]
fn a_dropped_link_rebounds_at_the_configured_restitution_with_the_whole_body_solve() {
    rebounds_at_the_configured_restitution(WHOLE_BODY, 4);
}

/// The dropped link's restitution with `law` at 1 ms (mean of eight drops), 0.25 ms and 0.1 ms
/// against the setting (±0.05) and the guide's table from column `first`.
fn rebounds_at_the_configured_restitution(law: &str, first: usize) {
    let page = std::fs::read_to_string(crate::common::manifest_dir().join("guide/src/background/physics.md")).unwrap();
    let solve = format!("physics.environment_contact_solve=\"{law}\"");
    for e in [0.3, 0.5, 0.7] {
        let documented = guide_restitution_row(&page, e, first);
        assert!(documented.len() >= 3, "the guide's row {e} has no three \"{law}\" columns");
        let at = |dt: f64, drop_m: f64| {
            let keys =
                [format!("physics.contact_restitution={e}"), format!("general.timestep_secs={dt}"), solve.clone()];
            let keys: Vec<&str> = keys.iter().map(|s| s.as_str()).collect();
            dropped_link_restitution(drop_m, &keys)
        };
        let drops: Vec<f64> = (0..8).map(|k| at(1e-3, 0.19 + 0.0025 * k as f64)).collect();
        let mean = drops.iter().sum::<f64>() / drops.len() as f64;
        let measured = [mean, at(2.5e-4, 0.2), at(1e-4, 0.2)];
        eprintln!(
            "restitution {e}, {law}: 1 ms {drops:.3?} (mean {mean:.3}), 0.25 ms {:.3}, 0.1 ms {:.3}",
            measured[1], measured[2]
        );
        for ((m, doc), dt) in measured.iter().zip(&documented).zip(["1 ms (mean)", "0.25 ms", "0.1 ms"]) {
            assert!((m - doc).abs() <= 0.0005 + 1e-9, "{law}, restitution {e} at {dt}: {m}, the guide says {doc}");
            assert!((m - e).abs() <= 0.05, "{law}, restitution {e} at {dt}: measured {m}");
        }
        assert!((measured[0] - measured[2]).abs() <= 0.05, "{law}, restitution {e}: {measured:?}");
    }
}

/// How far (m) one link on the floor, pushed along its axis at 0.999 μ·m·g from t = 0 (default
/// settings, the link starting at rest on the floor), moves its centre in 1 s.
fn start_under_load_moved_m(law: &str, mu: f64) -> f64 {
    pushed_moved_m(law, mu, 0.0)
}

/// How far (m) one link on the floor, pushed along its axis at 0.999 μ·m·g from `push_from_secs`
/// on (default settings, the link starting at rest on the floor), moves its centre in the
/// push's first second.
fn pushed_moved_m(law: &str, mu: f64, push_from_secs: f64) -> f64 {
    let mut c = straight_in(law, mu, &["snake.n_links=1"]);
    let mu_n = mu * c.snake.link_mass_kg * G;
    c.physics.external_forces = vec![ExternalForce {
        link: 0,
        direction: [1.0, 0.0, 0.0],
        start_secs: push_from_secs,
        ramp_n_per_s: 0.0,
        force_n: 0.999 * mu_n,
        duration_secs: 0.0,
    }];
    c.validate().unwrap();
    let mut sim = simulation(&c);
    let dt = c.general.timestep_secs;
    run_for(&mut sim, &c, push_from_secs);
    let x0 = sim.world().data().qpos()[0];
    let mut moved: f64 = 0.0;
    for _ in 0..(1.0 / dt).round() as usize {
        sim.step().unwrap();
        moved = moved.max((sim.world().data().qpos()[0] - x0).abs());
    }
    moved
}

/// A link resting on the floor and pushed at 0.999 μN all at once holds at μ 0.5: the stick
/// force takes the push within the step it starts in (a force known before the step, as gravity
/// along a slope is), so the link moves less than 0.1 mm in the push's first second (measured
/// 0.066 mm; the whole-body solve: 0.099 mm).
#[test]
fn a_resting_link_pushed_just_below_mu_n_all_at_once_holds() {
    let moved = pushed_moved_m(PER_LINK, 0.5, 0.2);
    eprintln!("per_link, μ 0.5: moved {:.5} mm", moved * 1e3);
    assert!(moved < 1e-4, "the link moved {} mm under 0.999 μN", moved * 1e3);
}

/// The same at μ 1 does not hold within 0.1 mm (0.31 mm; the whole-body solve: 0.20 mm): the
/// friction holding the push acts one radius below the centre of mass and pitches the link; its
/// load moves to the front cap only through the rocking of the two caps' springs, which takes
/// the rear cap off the floor for a step and Σ N below the push's μN; the link starts to slide
/// at 2 mm/s and, pushed at 0.999 μN, slows at only 0.001 μ·g (stops after 0.3 s).
#[test]
#[ignore = "target not reached with \"per_link\" at μ 1: 0.31 mm (run with --ignored)"]
fn a_resting_link_pushed_just_below_mu_n_all_at_once_holds_at_mu_1() {
    let moved = pushed_moved_m(PER_LINK, 1.0, 0.2);
    eprintln!("per_link, μ 1: moved {:.5} mm", moved * 1e3);
    assert!(moved < 1e-4, "the link moved {} mm under 0.999 μN", moved * 1e3);
}

/// A run that starts under load holds: the link moves less than 0.1 mm in 1 s at μ 0.5 and 1
/// with the whole-body solve (measured 0.0065 and 0.030 mm: the first step's normal force is a
/// quarter of the weight, the link slips a few mm/s and is caught within 4 steps, its friction
/// computed from the forces acting on it in the same step, the push included).
#[test]
fn a_link_loaded_just_below_mu_n_from_the_start_holds_with_the_whole_body_solve() {
    for mu in [0.5, 1.0] {
        let moved = start_under_load_moved_m(WHOLE_BODY, mu);
        eprintln!("whole_body, μ {mu}: moved {:.4} mm", moved * 1e3);
        assert!(moved < 1e-4, "μ {mu}: the link moved {} mm under 0.999 μN", moved * 1e3);
    }
}

/// A run that starts under load holds with the per-link law at μ 0.5: the link starts at rest
/// sunk to the depth where the floor carries its weight (8.4 µm), so the friction holding the
/// push is bounded by μ of its whole weight from the first step, and it moves less than 0.1 mm
/// in 1 s (measured 0.066 mm, as a link pushed once it rests; started at its radius, with the
/// floor carrying a quarter of its weight at the first step, it slid 0.95 mm).
#[test]
fn a_link_loaded_just_below_mu_n_from_the_start_holds() {
    let moved = start_under_load_moved_m(PER_LINK, 0.5);
    eprintln!("per_link, μ 0.5: moved {:.4} mm", moved * 1e3);
    assert!(moved < 1e-4, "the link moved {} mm under 0.999 μN", moved * 1e3);
}

/// The same at μ 1 does not hold within 0.1 mm (0.31 mm, as a link pushed once it rests, see
/// [`a_resting_link_pushed_just_below_mu_n_all_at_once_holds_at_mu_1`]).
#[test]
#[ignore = "target not reached with \"per_link\" at μ 1: 0.31 mm, the push's pitch rocking (run with --ignored)"]
fn a_link_loaded_just_below_mu_n_from_the_start_holds_at_mu_1() {
    let moved = start_under_load_moved_m(PER_LINK, 1.0);
    eprintln!("per_link, μ 1: moved {:.4} mm", moved * 1e3);
    assert!(moved < 1e-4, "the link moved {} mm under 0.999 μN", moved * 1e3);
}

/// The sideways hit's largest lift (m) at the default 1-ms step and at 0.1 ms.
fn hit_lifts(law: &str, mu: f64) -> [f64; 2] {
    [1e-3, 1e-4].map(|dt| {
        let mut c = hit(law, mu);
        c.general.timestep_secs = dt;
        measure(&c, &mut simulation(&c), 1.0, mu).max_lift_m
    })
}

/// The sideways hit on the cylinders at μ 0.5 converges in the step: the largest lift at 0.1 ms
/// within 10 % of the default 1-ms step's (211 and 204 mm), and within 1/1.5 … 1.5 × the
/// reference's (Drake, its floor and obstacle damping at SimSerpent's restitution: 159 mm).
#[test]
fn a_sideways_hit_at_mu_0_5_lifts_the_same_at_1_ms_and_0_1_ms() {
    hit_lift_converges_near_the_reference(PER_LINK, 0.5, 0.159);
}

/// The sideways hit's largest lift at 1 ms and 0.1 ms with `solve` at friction `mu`: within 10 %
/// of each other and each within 1/1.5 … 1.5 × the reference's `reference_m` (Drake, its floor
/// and obstacle damping at SimSerpent's restitution).
fn hit_lift_converges_near_the_reference(solve: &str, mu: f64, reference_m: f64) {
    let lifts = hit_lifts(solve, mu);
    eprintln!("{solve}, μ {mu}: largest lift {:.1} mm at 1 ms, {:.1} mm at 0.1 ms", lifts[0] * 1e3, lifts[1] * 1e3);
    assert!((lifts[1] / lifts[0] - 1.0).abs() <= 0.10, "{lifts:?}");
    for lift in lifts {
        assert!((reference_m / 1.5..=reference_m * 1.5).contains(&lift), "{lifts:?}");
    }
}

/// At μ 1 the target is the same: within 10 % between the steps and within 1/1.5 … 1.5 × Drake's
/// lift (6.05 mm with its damping at SimSerpent's restitution, 16–23 mm with its defaults). Measured:
/// 33.6 mm at 1 ms and 32.5 mm at 0.1 ms (3 % apart: the step passes, the reference does not). The
/// lift rides on the snake's roll: the links spin about their axes sliding sideways on the floor,
/// those that hit a cylinder roll up its face, and the floor's friction stops the roll in the
/// reference (−3.8 rad/s as the snake leaves the floor) but not here (−37 rad/s), see the module
/// documentation of `sim::ground`.
#[test]
#[ignore = "target not reached: at μ 1 the lift is 33.6 / 32.5 mm at 1 / 0.1 ms against the reference's 6.05 mm (run with --ignored)"]
fn a_sideways_hit_at_mu_1_lifts_the_same_at_1_ms_and_0_1_ms() {
    hit_lift_converges_near_the_reference(PER_LINK, 1.0, 0.00605);
}

/// The sideways hit at μ 0.5 with the whole-body solve: within 10 % between 1 ms and 0.1 ms and
/// within 1/1.5 … 1.5 × the reference's 163 mm (slow: 10,000 steps at 0.1 ms).
#[test]
#[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
fn a_sideways_hit_at_mu_0_5_lifts_the_same_at_1_ms_and_0_1_ms_with_the_whole_body_solve() {
    hit_lift_converges_near_the_reference(WHOLE_BODY, 0.5, 0.163);
}

/// At μ 1 with the whole-body solve: 10.9 mm at 1 ms and 16.4 mm at 0.1 ms against the
/// reference's 5.03 mm. The centre of mass rises alike at both steps (it leaves the floor at
/// 0.356 m/s after the hit at both): the cylinders' friction stopping the links' spin drives
/// them into the floor (6.6 N·s in 7 ms) and the floor's spring gives the stored energy back;
/// the steps differ in how far a link tilts on its way up (the snake's roll rate after the hit:
/// +1.2 rad/s at 1 ms, +3.6 at 0.1 ms). The lift converges to 16.5–16.7 mm at 50 and 20 µs, so
/// 1 ms is the step off the converged law, and the converged law is 3.3 × the reference. The
/// reference differs after the hit, not during it (its floor impulse, 7.3 N·s, and the
/// cylinders' downward friction, 6.6 N·s, match these within 15 %): its Hunt–Crossley cylinder contact fades out over 6 ms more (to
/// 77 ms, ours ends at 70–71 ms) while the links rise along the cylinder's face, and its friction
/// there takes 0.86 N·s of upward momentum, so the snake leaves at about 0.19 m/s with a roll
/// rate of −0.42 rad/s. A Hunt–Crossley cylinder contact in this solve (damping ∝ penetration,
/// scaled by the impact speed so that the restitution stays the configured one) brings the
/// take-off speed to 0.26 / 0.28 m/s but not the roll (+1.1 / +4.5 rad/s).
#[test]
#[ignore = "target not reached with \"whole_body\": at μ 1 the lift is 10.9 / 16.4 mm at 1 / 0.1 ms (run with --ignored)"]
fn a_sideways_hit_at_mu_1_lifts_the_same_at_1_ms_and_0_1_ms_with_the_whole_body_solve() {
    hit_lift_converges_near_the_reference(WHOLE_BODY, 1.0, 0.00503);
}

/// The whole-body solve's forces land where the per-link law's do: every step of the sideways
/// hit on the cylinders (μ 0.5, 0.15 s from t = 0), each link's link–floor rows (vertical
/// normals) add up to its recorded floor force and its link–cylinder rows to its recorded
/// obstacle force, normal and friction, and the floor force's friction part is the friction the
/// law applies (`Ground::applied_friction_n`, less the obstacle part).
#[test]
fn the_whole_body_solve_records_its_forces_in_the_floor_and_obstacle_channels() {
    let c = hit(WHOLE_BODY, 0.5);
    let n = c.snake.n_links;
    let mut sim = simulation(&c);
    let mut s = Snapshot::new(n, n - 1);
    let (mut floor_rows, mut obstacle_rows) = (0, 0);
    for _ in 0..150 {
        sim.control();
        sim.snapshot(&mut s);
        let mut floor = vec![[0.0; 3]; n];
        let mut obstacle = vec![[0.0; 3]; n];
        for row in &s.contacts {
            // Link bodies are 1 ..= n (link_00 first); floor and cylinders belong to the world.
            let (link, sign) = match (row.body[0], row.body[1]) {
                (0, b) if (1..=n).contains(&b) => (b - 1, 1.0),
                (b, 0) if (1..=n).contains(&b) => (b - 1, -1.0),
                _ => continue,
            };
            let on_floor = row.normal[2].abs() > 0.5;
            let total = if on_floor { &mut floor[link] } else { &mut obstacle[link] };
            if on_floor {
                floor_rows += 1;
            } else {
                obstacle_rows += 1;
            }
            for (t, f) in total.iter_mut().zip(row.force_on_geom2_n) {
                *t += sign * f;
            }
        }
        let applied = sim.ground().applied_friction_n().expect("the contact law is in use").to_vec();
        for i in 0..n {
            let scale = 1.0 + s.link_floor_force_n[i][2].abs() + s.link_obstacle_force_n[i][1].abs();
            for k in 0..3 {
                assert!(
                    (floor[i][k] - s.link_floor_force_n[i][k]).abs() <= 1e-9 * scale,
                    "link {i}: floor rows {:?} against {:?}",
                    floor[i],
                    s.link_floor_force_n[i]
                );
                assert!(
                    (obstacle[i][k] - s.link_obstacle_force_n[i][k]).abs() <= 1e-9 * scale,
                    "link {i}: obstacle rows {:?} against {:?}",
                    obstacle[i],
                    s.link_obstacle_force_n[i]
                );
            }
            // Horizontal floor force = friction: the applied friction less the obstacles' part.
            let floor_friction =
                [0, 1].map(|k| applied[i][k] - s.link_obstacle_force_n[i][k] + obstacle_normal_part(&s, i, k));
            for k in 0..2 {
                assert!(
                    (s.link_floor_force_n[i][k] - floor_friction[k]).abs() <= 1e-9 * scale,
                    "link {i}: {:?} against {floor_friction:?}",
                    s.link_floor_force_n[i]
                );
            }
        }
        sim.advance().unwrap();
    }
    assert!(floor_rows > 0 && obstacle_rows > 0, "{floor_rows} floor rows, {obstacle_rows} obstacle rows");
}

/// The normal part of link i's recorded obstacle force along world axis k (Σ of its link–cylinder
/// rows' N·normal, on the link).
fn obstacle_normal_part(s: &Snapshot, i: usize, k: usize) -> f64 {
    s.contacts
        .iter()
        .filter(|r| {
            r.normal[2].abs() <= 0.5 && (r.body[0] == i + 1 || r.body[1] == i + 1) && (r.body[0] == 0 || r.body[1] == 0)
        })
        .map(|r| {
            // MuJoCo's normal points from geom 1 to geom 2: on the link it is +normal when the
            // link is geom 2.
            let sign = if r.body[1] == i + 1 { 1.0 } else { -1.0 };
            sign * r.normal_force_n * r.normal[k]
        })
        .sum()
}

/// What the gait job on a ground shows over its 3 s: the centre of mass's displacement (m),
/// its mean speed over 1–3 s (m/s), each link's mean load over 1–3 s (× m g) and the largest
/// ground force on a link in a step over 1–3 s (× m g).
#[derive(Debug)]
struct GroundFigures {
    displacement_m: [f64; 2],
    speed_m_per_s: f64,
    loads: Vec<f64>,
    peak_over_weight: f64,
}

fn ground_figures(c: &Config) -> GroundFigures {
    let n = c.snake.n_links;
    let dt = c.general.timestep_secs;
    let mut sim = simulation(c);
    let mut s = Snapshot::new(n, n - 1);
    let com = |s: &Snapshot| {
        let c = s.centre_of_mass_m();
        [c[0], c[1]]
    };
    let steps = (3.0 / dt).round() as usize;
    let from = (1.0 / dt).round() as usize;
    let (mut start, mut path) = ([0.0; 2], 0.0);
    let mut previous = [0.0; 2];
    let mut loads = vec![0.0; n];
    let mut peak: f64 = 0.0;
    for k in 0..steps {
        sim.control();
        sim.snapshot(&mut s);
        let p = com(&s);
        if k == 0 {
            start = p;
        }
        if k > from {
            path += (p[0] - previous[0]).hypot(p[1] - previous[1]);
        }
        previous = p;
        if k >= from {
            for (i, load) in loads.iter_mut().enumerate() {
                let w = s.link_mass_kg[i] * G;
                let fz = s.link_floor_force_n[i][2];
                *load += fz / w / (steps - from) as f64;
                peak = peak.max(fz / w);
            }
        }
        sim.advance().unwrap();
    }
    GroundFigures {
        displacement_m: [previous[0] - start[0], previous[1] - start[1]],
        speed_m_per_s: path / 2.0,
        loads,
        peak_over_weight: peak,
    }
}

/// The gait job (isotropic μ 0.5 and 1) on a flat heightfield 20 mm above the floor and on a
/// flat mesh terrain there equals the same job on the plane: centre-of-mass speed, displacement
/// (2 % or 1 mm; μ 0.5), each link's mean load and the largest load in a step within 2 %, at
/// 1 ms and 0.5 ms. What the ground is made of does not change the physics.
#[test]
fn a_flat_heightfield_and_a_flat_mesh_terrain_equal_the_plane() {
    flat_grounds_equal_the_plane(PER_LINK);
}

/// The same with the whole-body solve (slow: 12 runs of 3 s at twice the per-link law's cost).
#[test]
#[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
fn a_flat_heightfield_and_a_flat_mesh_terrain_equal_the_plane_with_the_whole_body_solve() {
    flat_grounds_equal_the_plane(WHOLE_BODY);
}

/// The keys of a flat heightfield and of a flat mesh terrain 20 mm above the floor, with the snake
/// of `base` raised onto them (their files written into `dir`).
fn flat_terrain_keys(dir: &std::path::Path, base: &Config) -> [Vec<String>; 2] {
    let png = dir.join("flat.png");
    crate::common::write_gray_png(&png, 64, 64, &[255u8; 64 * 64]);
    let obj = dir.join("flat.obj");
    std::fs::write(&obj, "v -2 -2 0.02\nv 2 -2 0.02\nv 2 2 0.02\nv -2 2 0.02\nf 1 2 3\nf 1 3 4\n").unwrap();
    let p = base.snake.head_position_m;
    let raised = format!("snake.head_position_m=[{}, {}, {}]", p[0], p[1], p[2] + 0.02);
    [
        vec![
            format!("terrain.heightfield.file={:?}", png.display().to_string()),
            "terrain.heightfield.height_m=0.02".to_string(),
            raised.clone(),
        ],
        vec![format!("terrain.mesh_terrain.file={:?}", obj.display().to_string()), raised],
    ]
}

/// A straight snake that starts at rest lying on level ground carries each link's weight on that
/// link from its first step with the per-link law: it starts sunk to the depth where the law's
/// floor carries it (8.4 µm with the defaults), on the plane, a flat heightfield and a flat mesh
/// terrain alike. Every link's floor load within 1e-6 of its weight at every step of the first
/// 0.2 s, and every link slower than 1 µm/s (started at its radius, the floor carried a quarter
/// of the weight at the first step and the snake fell into it).
#[test]
fn a_snake_resting_on_level_ground_carries_its_weight_from_the_first_step() {
    let dir = tempfile::tempdir().unwrap();
    let base = straight(0.5, &[]);
    let [heightfield, mesh] = flat_terrain_keys(dir.path(), &base);
    for (name, keys) in [("plane", vec![]), ("heightfield", heightfield), ("mesh terrain", mesh)] {
        let keys: Vec<&str> = keys.iter().map(String::as_str).collect();
        let c = straight(0.5, &keys);
        let mut sim = simulation(&c);
        assert!(sim.world().start_sink_m() > 8e-6 && sim.world().start_sink_m() < 9e-6, "{name}");
        let e = measure(&c, &mut sim, 0.2, 0.5);
        let speed = sim.world().data().qvel().iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        eprintln!("{name}: sink {:.3} µm, {e:?}, largest speed {speed:.2e}", sim.world().start_sink_m() * 1e6);
        assert!(e.link_load_error <= 1e-6, "{name}: a link's load differs from its weight by {}", e.link_load_error);
        assert!(speed < 1e-6, "{name}: {speed} m/s");
    }
}

fn flat_grounds_equal_the_plane(law: &str) {
    let dir = tempfile::tempdir().unwrap();
    let gait = SCENE_GAIT;
    for mu in [0.5, 1.0] {
        for dt in [1e-3, 5e-4] {
            let base = scene_in(law, mu, &gait);
            let step = format!("general.timestep_secs={dt}");
            let plane = ground_figures(&scene_in(law, mu, &[&gait[..], &[step.as_str()]].concat()));
            let [heightfield, mesh] = flat_terrain_keys(dir.path(), &base).map(|mut k| {
                k.push(step.clone());
                k
            });
            for (name, keys) in [("heightfield", &heightfield), ("mesh terrain", &mesh)] {
                let keys: Vec<&str> = keys.iter().map(String::as_str).collect();
                let f = ground_figures(&scene_in(law, mu, &[&gait[..], &keys[..]].concat()));
                eprintln!("{law}, μ {mu}, dt {dt}: {name} {f:?}\n  plane {plane:?}");
                let close = |a: f64, b: f64, tol: f64| (a - b).abs() <= tol * b.abs();
                assert!(close(f.speed_m_per_s, plane.speed_m_per_s, 0.02), "{law}, μ {mu}, dt {dt}, {name}: speed");
                // At μ 1 the displacement is chaotic in the start: the plane's own job started 1 µm
                // higher ends 1 mm away (x: −1.4 → −2.4 mm at 1 ms), as far as the heightfield's
                // (−1.9, −17.5 against −1.4, −18.7 mm); speed, loads and peaks agree within 0.1 %.
                for a in (0..2).filter(|_| mu < 1.0) {
                    let tol = (0.02 * plane.displacement_m[a].abs()).max(1e-3);
                    assert!(
                        (f.displacement_m[a] - plane.displacement_m[a]).abs() <= tol,
                        "{law}, μ {mu}, dt {dt}, {name}: displacement {a}"
                    );
                }
                for (i, (l, p)) in f.loads.iter().zip(&plane.loads).enumerate() {
                    assert!(close(*l, *p, 0.02), "{law}, μ {mu}, dt {dt}, {name}: link {i} load {l} against {p}");
                }
                assert!(
                    close(f.peak_over_weight, plane.peak_over_weight, 0.02),
                    "{law}, μ {mu}, dt {dt}, {name}: peak"
                );
            }
        }
    }
}

/// A 30-link snake of 3-kg links in steady undulation carries its weight: Σ N within 10 % of
/// it at every step at the default timestep, from the end of the gait's ramp on (default
/// servos, anisotropic floor), to 6 s, from the default start and from starts 1 and 2 µm
/// higher. Not reached with the per-link law: once a gait cycle (at 2.57 and 4.52–4.62 s from
/// the default start) the links behind the head rock off the floor for 10–20 ms while the head
/// carries up to 7 × its weight: Σ N between 0.73 and 1.43 of the weight (0.73–1.31 and
/// 0.79–1.42 from the higher starts); at 0.5-ms steps the same job stays within 0.996–1.008
/// (8 s). The damper is implicit on each point's mass for its link alone, and a heavy link
/// pressed by its neighbours through the joints carries more, so the rocking of the chain's
/// links is damped less than a link's. Whether a start runs into the cycle's event is chaotic
/// (started at its radius, 4 s: 0.991–1.016; 1 µm higher: 0.77–1.31).
#[test]
#[ignore = "target not reached with \"per_link\": Σ N 0.73–1.43 of the weight once a gait cycle at 1 ms (run with --ignored)"]
fn a_heavy_long_snake_carries_its_weight_at_every_step() {
    let (low, high) = heavy_snake_load_range(PER_LINK);
    assert!(low >= 0.9 && high <= 1.1, "Σ N between {low} and {high} of the weight");
}

/// The same with the whole-body solve: its floor damping is implicit through the whole body's
/// mobility, the links do not rock (measured: Σ N between 0.996 and 1.009 of the weight from each
/// start; slow: 3 × 6 s of 30 links).
#[test]
#[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
fn a_heavy_long_snake_carries_its_weight_at_every_step_with_the_whole_body_solve() {
    let (low, high) = heavy_snake_load_range(WHOLE_BODY);
    assert!(low >= 0.9 && high <= 1.1, "Σ N between {low} and {high} of the weight");
}

/// The smallest and largest Σ N / weight of the 30-link snake of 3-kg links from the end of the
/// ramp to 6 s, over the default start and starts 1 and 2 µm higher.
fn heavy_snake_load_range(law: &str) -> (f64, f64) {
    let (mut low, mut high) = (f64::INFINITY, 0.0_f64);
    for lift_m in [0.0, 1e-6, 2e-6] {
        let c = default_config_with(&[
            "snake.n_links=30".to_string(),
            "snake.link_mass_kg=3.0".to_string(),
            format!("physics.environment_contact_solve=\"{law}\""),
            format!("snake.head_position_m=[0.0, 0.0, {lift_m}]"),
        ])
        .unwrap();
        let n = c.snake.n_links;
        let dt = c.general.timestep_secs;
        let mut sim = simulation(&c);
        let mut s = Snapshot::new(n, n - 1);
        let ramp_steps = (c.gait.ramp_secs / dt).round() as usize;
        let (mut start_low, mut start_high) = (f64::INFINITY, 0.0_f64);
        for k in 0..(6.0 / dt).round() as usize {
            sim.control();
            sim.snapshot(&mut s);
            if k >= ramp_steps {
                let total: f64 = (0..n).map(|i| s.link_floor_force_n[i][2]).sum();
                let weight: f64 = s.link_mass_kg.iter().map(|m| m * G).sum();
                start_low = start_low.min(total / weight);
                start_high = start_high.max(total / weight);
            }
            sim.advance().unwrap();
        }
        eprintln!(
            "{law}, {lift_m} m higher: 30 links of 3 kg: Σ N between {start_low:.3} and {start_high:.3} of the weight"
        );
        (low, high) = (low.min(start_low), high.max(start_high));
    }
    (low, high)
}

/// The rebound of a straight snake (1 link, and 10 links hitting flat) launched sideways at
/// 1 m/s into a wall, frictionless (floor and wall), from its centre of mass's speed across the
/// wall before and after the hit.
fn wall_restitution(law: &str, n_links: usize, dt: f64) -> f64 {
    let links = format!("snake.n_links={n_links}");
    let step = format!("general.timestep_secs={dt}");
    let c = straight_in(
        law,
        0.0,
        &[
            &links,
            &step,
            "initial_state.linear_velocity_m_per_s=[0.0, 1.0, 0.0]",
            "terrain.walls=[{ start_m = [-2.0, 0.1], end_m = [1.0, 0.1], height_m = 0.2, thickness_m = 0.05 }]",
        ],
    );
    let mut sim = simulation(&c);
    let n = c.snake.n_links;
    let mut s = Snapshot::new(n, n.saturating_sub(1));
    let (mut before, mut after) = (0.0, 0.0);
    for _ in 0..(0.3 / dt).round() as usize {
        sim.control();
        sim.snapshot(&mut s);
        let vy = simserpent::state::centre_of_mass_m(
            s.link_mass_kg.iter().copied().zip(s.link_velocity_m_per_s.iter().copied()),
        )[1];
        before = f64::max(before, vy);
        after = f64::min(after, vy);
        sim.advance().unwrap();
    }
    -after / before
}

/// An obstacle impact rebounds at `physics.contact_restitution` (0.3 by default) within ±0.05 at
/// 1 ms, 0.25 ms and 0.1 ms steps, for one link and for a 10-link chain hitting flat (its joints
/// add mass to every contact point: the law uses the whole body's effective mass).
#[test]
fn an_obstacle_impact_rebounds_at_the_configured_restitution() {
    let mut misses = Vec::new();
    for law in LAWS {
        for n in [1, 10] {
            for dt in [1e-3, 2.5e-4, 1e-4] {
                let e = wall_restitution(law, n, dt);
                eprintln!("{law}, {n} links, dt {dt}: restitution {e:.3}");
                if (e - 0.3).abs() > 0.05 {
                    misses.push((law, n, dt, e));
                }
            }
        }
    }
    assert!(misses.is_empty(), "{misses:?}");
}

/// The largest horizontal speed (m/s) of one link at rest on the floor from t = 0 (default
/// settings, isotropic or anisotropic floor), over 0.2 s of steps, and the step where it occurs.
fn link_at_rest_largest_speed(law: &str, keys: &[&str]) -> (f64, usize) {
    let mut k = vec!["snake.n_links=1"];
    k.extend_from_slice(keys);
    let c = straight_in(law, 0.5, &k);
    let mut sim = simulation(&c);
    let mut worst = (0.0_f64, 0);
    for step in 0..(0.2 / c.general.timestep_secs).round() as usize {
        sim.step().unwrap();
        let v = sim.world().data().qvel();
        let speed = v[0].hypot(v[1]);
        if speed > worst.0 {
            worst = (speed, step);
        }
    }
    worst
}

/// A link at rest on the floor from t = 0 stays at rest with the whole-body solve: its horizontal
/// speed stays below 0.1 mm/s at every step, on the isotropic and on the anisotropic floor, at
/// 1 ms and 0.1 ms. Measured: 1.51 and 0.62 mm/s at 1 ms (isotropic, anisotropic; in the first
/// four steps), 0.023 and 0.022 mm/s at 0.1 ms. The link starts at zero penetration: rounding
/// puts one cap a hair below the floor and the other a hair above, the solve takes the first
/// only (the second's free motion reaches the floor only through gravity, which the test for a
/// point that pushes within the step leaves out), and that cap's normal force pitches the link
/// while its friction, holding the cap, pushes the link sideways. Taking both caps (gravity in
/// that test) is not enough: the law's first-step force of a cap at +0 and at −0 penetration
/// differs (0.90 against 0.13 N). Starting the link sunk to its static depth g/ω² (what the
/// reference engine does) removes the drift (below 1e-7 m/s), but then a link pushed at
/// 0.999 μN from t = 0 slips in the pitch rocking the sudden push starts (0.099 and 0.199 mm at
/// μ 0.5 and 1), which [`a_link_loaded_just_below_mu_n_from_the_start_holds_with_the_whole_body_solve`]
/// does not allow: a start in static equilibrium under the loads of t = 0 (gravity and the
/// push together) is what both need. Giving each ground point lying at rest on the first step
/// the normal force that leaves it no normal acceleration, and carrying that force on as a
/// preload of its spring, passes both (under 0.05 µm moved, under 1e-7 m/s) and leaves the
/// ramp's steps with every link off the floor at 3 and 40 (μ 0.5 and 1), but that rigid solve is
/// statically indeterminate for a chain: a straight 10-link snake at rest then keeps one link at
/// 1.93 × its weight for good. The static start needs the compliant solution (the springs'
/// least complementary energy among the loads that balance the body).
#[test]
#[ignore = "target not reached with \"whole_body\": 1.51 / 0.62 mm/s at the first steps at 1 ms, isotropic / anisotropic (run with --ignored)"]
fn a_link_at_rest_from_the_start_stays_at_rest_with_the_whole_body_solve() {
    let mut worst = Vec::new();
    for keys in [&[][..], &["ground.model=\"anisotropic\""][..]] {
        for dt in ["general.timestep_secs=0.001", "general.timestep_secs=0.0001"] {
            let mut k = keys.to_vec();
            k.push(dt);
            let (speed, step) = link_at_rest_largest_speed(WHOLE_BODY, &k);
            eprintln!("{k:?}: largest horizontal speed {:.4} mm/s at step {step}", speed * 1e3);
            worst.push((k, speed, step));
        }
    }
    assert!(worst.iter().all(|(_, speed, _)| *speed < 1e-4), "{worst:?}");
}

/// The per-link law's figures that the guide, the tests' comments and BENCHMARKS quote, printed:
/// the rebound of a link dropped flat for restitution 0.3, 0.5 and 0.7 (at 1 ms from 8 heights
/// 2.5 mm apart, so the impact starts at 8 places in a step, and their mean; at 0.25 and 0.1 ms),
/// the start under load, the link at rest, the heavy snake's Σ N and the sideways hit's lifts.
#[test]
#[ignore = "probe: the per-link law's quoted figures (run with --ignored --nocapture)"]
fn measure_the_per_link_laws_figures() {
    for e in [0.3, 0.5, 0.7] {
        let at = |dt: f64, drop_m: f64| {
            let keys = [format!("physics.contact_restitution={e}"), format!("general.timestep_secs={dt}")];
            let keys: Vec<&str> = keys.iter().map(|s| s.as_str()).collect();
            dropped_link_restitution(drop_m, &keys)
        };
        let drops: Vec<f64> = (0..8).map(|k| at(1e-3, 0.19 + 0.0025 * k as f64)).collect();
        let mean = drops.iter().sum::<f64>() / 8.0;
        eprintln!(
            "e {e}: 1 ms {drops:.3?} mean {mean:.3}; 0.25 ms {:.3}; 0.1 ms {:.3}",
            at(2.5e-4, 0.2),
            at(1e-4, 0.2)
        );
    }
    for mu in [0.5, 1.0] {
        eprintln!("start under load mu {mu}: {:.4} mm", start_under_load_moved_m(PER_LINK, mu) * 1e3);
    }
    for keys in [&[][..], &["ground.model=\"anisotropic\""][..]] {
        eprintln!("link at rest {keys:?}: {:?}", link_at_rest_largest_speed(PER_LINK, keys));
    }
    heavy_snake_load_range(PER_LINK);
    for mu in [0.5, 1.0] {
        eprintln!("hit mu {mu}: {:?}", hit_lifts(PER_LINK, mu));
    }
}

/// The snake's contacts with itself are MuJoCo's, normal force and friction from the same
/// constraint solve in its elliptic cone, so their friction is bounded by μ times the normal
/// force of the same step, as the contact law's are. The wide wave on the bare floor
/// (`simserpent::experiments::estimation::self_contact_config`) folds the body onto itself:
/// over 4 s from t = 0, every link–link row keeps |friction| ≤ μ·N, and links touch on more
/// than 5 % of the steps.
#[test]
fn link_link_contacts_keep_their_friction_within_mu_n_of_the_same_step() {
    use simserpent::config::GroundModel;
    use simserpent::experiments::estimation::self_contact_config;
    let c = self_contact_config(&Config::default(), GroundModel::Anisotropic, 0, true);
    let n = c.snake.n_links;
    let mu = c.snake.link_friction[0];
    let mut sim = simulation(&c);
    let mut s = Snapshot::new(n, n - 1);
    let steps = (4.0 / c.general.timestep_secs).round() as usize;
    let (mut touching_steps, mut worst) = (0, 0.0_f64);
    for _ in 0..steps {
        sim.control();
        sim.snapshot(&mut s);
        let mut touching = false;
        // Link bodies are 1 ..= n; the world (floor) is 0.
        for row in s.contacts.iter().filter(|r| r.body.iter().all(|b| (1..=n).contains(b))) {
            let friction = row.friction_force_n[0].hypot(row.friction_force_n[1]);
            assert!(
                friction <= mu * row.normal_force_n * (1.0 + 1e-6) + 1e-9,
                "t = {} s, links {:?}: friction {friction} N against μN = {} N",
                s.time_secs,
                row.body,
                mu * row.normal_force_n
            );
            if row.normal_force_n > 0.0 {
                touching = true;
                worst = worst.max(friction / (mu * row.normal_force_n));
            }
        }
        touching_steps += usize::from(touching);
        sim.advance().unwrap();
    }
    eprintln!("links touch on {touching_steps} of {steps} steps; largest |friction| / μN {worst:.4}");
    assert!(touching_steps as f64 > 0.05 * steps as f64, "{touching_steps} of {steps} steps");
}
