//! Proprioceptive contact-force estimation (`simserpent::estimation`) against the simulator's
//! ground truth (`Snapshot`'s per-link floor / obstacle / total contact forces).

use simserpent::config::{Config, GroundModel};
use simserpent::control::{Command, Controller, Observation};
use simserpent::estimation::{
    ContactEstimator, EstimateOutput, EstimatorInput, NewtonEulerEstimator, adjacent_joints, predicted_error_std_n,
};
use simserpent::sim::{SensorNoise, Simulation, Snapshot, World};

/// Constant joint torques.
struct ConstTorque(Vec<f64>);
impl Controller for ConstTorque {
    fn update(&mut self, _obs: &Observation, cmd: &mut Command) {
        cmd.torque_nm.copy_from_slice(&self.0);
    }
}

use simserpent::experiments::estimation::{N_LINKS, TORQUE_NM};

/// The estimation experiment's scene (`simserpent::experiments::estimation`): a 5-link snake
/// bent 30° per joint between three pegs (first-order form closure); a straightening torque
/// presses it against all three, a sustained push held by the pegs even without friction.
fn pinch_config(ground_friction: f64) -> Config {
    simserpent::experiments::estimation::pinch_config(&Config::default(), ground_friction)
}

/// One instant: the truth and the estimates from exact and from noisy sensors.
struct Sample {
    snap: Snapshot,
    exact: EstimateOutput,
    noisy: EstimateOutput,
}

/// Runs `steps` steps and calls `visit` at every step with the snapshot (forward pass at the
/// state of that step with its command) and the estimates from the fresh sensor values.
fn run(config: &Config, noise: Option<&simserpent::config::Sensors>, steps: usize, mut visit: impl FnMut(&Sample)) {
    let world = World::from_config(config).unwrap();
    let (nl, nj) = (world.n_links(), world.n_joints());
    let masses: Vec<f64> = world.index.links.iter().map(|l| l.mass_kg).collect();
    let mut sim = Simulation::with_controller(config, world, Box::new(ConstTorque(vec![TORQUE_NM; nj])));
    let mut noise = noise.map(|s| SensorNoise::new(s, config.general.seed, nl, nj));
    let mut obs = Observation::new(nl, nj);
    let mut measured = Observation::new(nl, nj);
    let mut input = EstimatorInput::new(nl);
    input.link_mass_kg.copy_from_slice(&masses);
    let mut estimator = NewtonEulerEstimator::default();
    let mut sample =
        Sample { snap: Snapshot::new(nl, nj), exact: EstimateOutput::new(nl), noisy: EstimateOutput::new(nl) };
    for _ in 0..steps {
        sim.control();
        sim.snapshot(&mut sample.snap);
        // After the forward pass the sensors describe this instant.
        sim.world().observe_true(&mut obs);
        let s = &sample.snap;
        input.fill(&obs, &s.link_quat, &s.link_position_m, &s.link_origin_m);
        estimator.estimate(&input, &mut sample.exact);
        if let Some(noise) = noise.as_mut() {
            noise.measure(&obs, &mut measured);
            input.fill(&measured, &s.link_quat, &s.link_position_m, &s.link_origin_m);
            estimator.estimate(&input, &mut sample.noisy);
        }
        visit(&sample);
        sim.advance().unwrap();
    }
}

fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

#[test]
fn without_friction_the_estimated_obstacle_force_matches_the_truth_within_2_percent_rms() {
    let config = pinch_config(0.0);
    // Per link: sum of squared horizontal errors and of squared true obstacle forces, over the
    // steps in which the link pushes against a peg (≥ 0.1 N).
    let mut err_sq = [0.0; N_LINKS];
    let mut truth_sq = [0.0; N_LINKS];
    let mut pushing_steps = [0usize; N_LINKS];
    let mut max_floor_friction_n: f64 = 0.0;
    run(&config, None, 2000, |s| {
        for i in 0..N_LINKS {
            let floor = s.snap.link_floor_force_n[i];
            max_floor_friction_n = max_floor_friction_n.max(floor[0].hypot(floor[1]));
            let truth = s.snap.link_obstacle_force_n[i];
            let est = s.exact.link_force_n[i];
            // Without friction the floor only pushes up: the horizontal estimate is the obstacles'
            // force, the vertical one the floor's.
            assert!((est[2] - floor[2] - truth[2]).abs() < 1e-3 * floor[2].abs().max(1.0), "link {i} vertical");
            if norm(truth) >= 0.1 {
                pushing_steps[i] += 1;
                err_sq[i] += (est[0] - truth[0]).powi(2) + (est[1] - truth[1]).powi(2);
                truth_sq[i] += truth[0].powi(2) + truth[1].powi(2);
            }
        }
    });
    // Frictionless floor contacts still carry ~1e-5 N sideways (the solver's tolerance): four
    // orders of magnitude below the pushes.
    assert!(max_floor_friction_n < 1e-3, "floor friction should be off: {max_floor_friction_n} N");
    // The pegs hold the head, the apex (link 2) and the tail.
    for i in [0, 2, 4] {
        assert!(pushing_steps[i] > 1500, "link {i} pushed in only {} of 2000 steps", pushing_steps[i]);
        let relative = (err_sq[i] / truth_sq[i]).sqrt();
        assert!(relative < 0.02, "link {i}: RMS error {:.3} % of the RMS obstacle force", 100.0 * relative);
    }
}

#[test]
fn with_friction_the_estimate_matches_the_total_external_force() {
    let config = pinch_config(0.5);
    let mut err_sq = [0.0; N_LINKS];
    let mut truth_sq = [0.0; N_LINKS];
    let mut max_floor_friction_n: f64 = 0.0;
    let mut total_err_sq = 0.0;
    let mut total_sq = 0.0;
    run(&config, None, 2000, |s| {
        let mut total_truth = [0.0; 3];
        for i in 0..N_LINKS {
            let floor = s.snap.link_floor_force_n[i];
            max_floor_friction_n = max_floor_friction_n.max(floor[0].hypot(floor[1]));
            // Ground reaction + obstacles + other links = every contact on the link.
            let truth = s.snap.link_contact_force_n[i];
            let split: Vec<f64> = (0..3)
                .map(|k| {
                    floor[k]
                        + s.snap.link_obstacle_force_n[i][k]
                        + s.snap.link_self_contact_force_n[i][k]
                        + s.snap.link_other_contact_force_n[i][k]
                })
                .collect();
            assert!((0..3).all(|k| (split[k] - truth[k]).abs() < 1e-9), "the split adds up to the total");
            let est = s.exact.link_force_n[i];
            err_sq[i] += (0..3).map(|k| (est[k] - truth[k]).powi(2)).sum::<f64>();
            truth_sq[i] += norm(truth).powi(2);
            (0..3).for_each(|k| total_truth[k] += truth[k]);
        }
        total_err_sq += (0..3).map(|k| (s.exact.total_force_n[k] - total_truth[k]).powi(2)).sum::<f64>();
        total_sq += norm(total_truth).powi(2);
    });
    assert!(max_floor_friction_n > 0.05, "friction should act: {max_floor_friction_n} N");
    for i in 0..N_LINKS {
        let relative = (err_sq[i] / truth_sq[i]).sqrt();
        assert!(relative < 0.02, "link {i}: RMS error {:.3} % of the RMS external force", 100.0 * relative);
    }
    assert!((total_err_sq / total_sq).sqrt() < 0.02, "total push");
}

#[test]
fn the_contact_point_is_where_the_peg_touches_the_link() {
    // Without friction, once the pinch has settled (last second of 2 s), the estimated point lies
    // on the link axis where the true (force-weighted) contact point projects onto it.
    let config = pinch_config(0.0);
    let mut worst_m: f64 = 0.0;
    let mut checked = 0;
    run(&config, None, 2000, |s| {
        if s.snap.time_secs < 1.0 {
            return;
        }
        for i in [0, 2, 4] {
            let (Some(truth), Some(est)) = (s.snap.link_obstacle_point_m[i], s.exact.link_contact_point_m[i]) else {
                panic!("link {i}: no contact point at t = {}", s.snap.time_secs);
            };
            // Link axis: the link frame's x axis through the centre of mass.
            let q = s.snap.link_quat[i];
            let r = simserpent::estimation::quat_to_matrix(q);
            let axis = [r[0][0], r[1][0], r[2][0]];
            let c = s.snap.link_position_m[i];
            let along = |p: [f64; 3]| (0..3).map(|k| (p[k] - c[k]) * axis[k]).sum::<f64>();
            worst_m = worst_m.max((along(truth) - along(est)).abs());
            checked += 1;
        }
    });
    assert!(checked > 2000);
    assert!(worst_m < 0.005, "contact point off by {worst_m} m along the link");
}

#[test]
fn with_noise_the_estimation_error_has_the_predicted_spread() {
    // Independent Gaussian noise σ_a on each accelerometer axis and σ_f on each force-sensor
    // axis: each world axis of a link's error has std sqrt(m²σ_a² + k·σ_f²) (k adjacent joints;
    // derivation in `simserpent::estimation`). With n samples the sample std's relative standard
    // error is 1/sqrt(2(n−1)) ≈ 1.3 % for n = 3000; allow 4 standard errors per link and axis.
    let config = pinch_config(0.5);
    let mut sensors = config.sensors.clone();
    sensors.noise_enabled = true;
    sensors.accelerometer.std = 0.3;
    sensors.joint_force.std = 0.2;
    let masses: Vec<f64> = World::from_config(&config).unwrap().index.links.iter().map(|l| l.mass_kg).collect();
    let n = 3000;
    let mut sum = [[0.0; 3]; N_LINKS];
    let mut sum_sq = [[0.0; 3]; N_LINKS];
    run(&config, Some(&sensors), n, |s| {
        for i in 0..N_LINKS {
            for k in 0..3 {
                let e = s.noisy.link_force_n[i][k] - s.exact.link_force_n[i][k];
                sum[i][k] += e;
                sum_sq[i][k] += e * e;
            }
        }
    });
    let nf = n as f64;
    for i in 0..N_LINKS {
        let predicted = predicted_error_std_n(masses[i], adjacent_joints(i, N_LINKS), 0.3, 0.2);
        for k in 0..3 {
            let mean = sum[i][k] / nf;
            let std = ((sum_sq[i][k] - nf * mean * mean) / (nf - 1.0)).sqrt();
            let se = predicted / (2.0 * (nf - 1.0)).sqrt();
            assert!((std - predicted).abs() < 4.0 * se, "link {i} axis {k}: std {std} predicted {predicted}");
            assert!(mean.abs() < 4.0 * predicted / nf.sqrt(), "link {i} axis {k}: mean error {mean}");
        }
    }
}

#[test]
#[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
fn the_estimation_experiment_writes_data_and_plots_and_counts_every_case() {
    let dir = tempfile::tempdir().unwrap();
    let outcome = simserpent::experiments::run_experiment("estimation", &Config::default(), dir.path(), true).unwrap();
    let checks: Vec<_> = outcome.report.checks().collect();
    // Pinch: 3 pushing links × (force, contact point) + 5 links (friction) + 5 links × 3 axes
    // (noise) + detection in each of the 3 cases; motion: 2 floors × 3 noise levels × 4, and
    // with identified friction 2 floors × (4 + 2 identification checks); self-contact: 2 floors
    // × 3. A detection that static friction hides is reported as not observable, not checked.
    let hidden: Vec<_> = outcome.report.not_observable().collect();
    let below = |c: &&&simserpent::experiments::Check| c.name.contains("below the floor's static friction");
    assert_eq!(checks.len() + hidden.iter().filter(|c| !below(c)).count(), 26 + 3 + 24 + 12 + 6);
    assert!(
        hidden
            .iter()
            .all(|c| c.name.contains("detected") && c.not_observable.as_ref().is_some_and(|w| w.contains("μ·N")))
    );
    // The pinch's force, point and noise checks pass (the Newton–Euler estimate is exact).
    let failed: Vec<_> = checks
        .iter()
        .filter(|c| !c.passed && !c.name.contains("detected") && !c.name.starts_with("motion"))
        .map(|c| (&c.name, c.measured))
        .collect();
    assert!(failed.is_empty(), "{failed:#?}");
    // Detection under static friction is a check of its own (with SimSerpent's own friction on
    // floor and pegs 99.8 % are detected; with MuJoCo's friction on them, 0.3 %).
    let friction =
        checks.iter().chain(&hidden).find(|c| c.name.starts_with("friction: obstacle contacts detected")).unwrap();
    assert!(friction.measured.is_finite() || friction.not_observable.is_some(), "{friction:?}");
    // The headline says all passed exactly when every check passed (some motion checks miss).
    assert_eq!(outcome.report.all_passed(), checks.iter().all(|c| c.passed));
    let text = std::fs::read_to_string(outcome.folder.join("report.md")).unwrap();
    let passed = checks.iter().filter(|c| c.passed).count();
    assert!(text.contains(&format!("**{passed} of {} checks passed.**", checks.len())));
    for case in ["no_friction", "friction", "friction_noise"] {
        assert!(outcome.folder.join(format!("estimation_{case}.csv")).is_file());
        assert!(outcome.folder.join(format!("plots/estimation_{case}_link_00.png")).is_file());
    }
    // Every row of the motion table has the header's columns (a quoted field may hold a comma).
    let motion = std::fs::read_to_string(outcome.folder.join("estimation_motion.csv")).unwrap();
    let columns =
        |line: &str| 1 + line.split('"').step_by(2).map(|outside| outside.matches(',').count()).sum::<usize>();
    let mut lines = motion.lines();
    let header = columns(lines.next().unwrap());
    for line in lines {
        assert_eq!(columns(line), header, "{line}");
    }
    assert!(outcome.folder.join("estimation_mu_identified.csv").is_file());
    assert!(outcome.folder.join("plots/estimation_friction_isotropic.png").is_file());
}

/// `estimation.friction = "identify"`: the floor's Coulomb coefficient, from the prior 0.3, on
/// the 10-link snake with the default sine wave and the default sensor noise.
fn identified_friction(model: GroundModel, pegs: usize, seconds: f64) -> ([f64; 3], [f64; 3]) {
    use simserpent::experiments::estimation::{peg_field_config, score_in_motion_with_friction};
    let mut config = peg_field_config(&Config::default(), model, 0, 1.0);
    config.terrain.pegboard.count = pegs;
    config.estimation.friction = simserpent::config::FloorFrictionSource::Identify;
    let truth = simserpent::estimation::FloorShare::from_config(&config).coefficients();
    let steps = (seconds / config.general.timestep_secs).round() as u64;
    let (_, friction) = score_in_motion_with_friction(&config, steps).unwrap();
    (friction.last().unwrap().1, truth)
}

#[test]
fn identified_friction_converges_to_the_configured_mu_on_a_bare_floor() {
    // Isotropic μ = 0.5: within 2 % after 3 s (measured: 0.3 %).
    let (mu, truth) = identified_friction(GroundModel::Isotropic, 0, 3.0);
    assert!((mu[0] - truth[0]).abs() <= 0.02 * truth[0], "{mu:?} vs {truth:?}");
}

#[test]
fn identified_friction_converges_to_the_configured_mu_in_the_peg_field() {
    // Anisotropic (axial 0.1, lateral 1.0) among 14 pegs, 10 s: within 10 % (measured: axial
    // 0.0968, lateral 0.9875).
    let (mu, truth) = identified_friction(GroundModel::Anisotropic, 14, 10.0);
    for k in [0, 2] {
        assert!((mu[k] - truth[k]).abs() <= 0.10 * truth[k], "{mu:?} vs {truth:?}");
    }
}

/// The estimation targets (`MOTION_TARGETS`: detection, false alarms, force RMSE, contact points
/// within 1 cm) on one peg-field run of 10 s with the default settings and sensor noise, as
/// `simserpent experiment estimation --seeds SEED --floor FLOOR` scores it: the figures that miss.
fn estimation_misses(model: GroundModel, seed: u64) -> Vec<String> {
    use simserpent::experiments::estimation::{MOTION_TARGETS, peg_field_config, score_in_motion};
    let config = peg_field_config(&Config::default(), model, seed, 1.0);
    let steps = (10.0 / config.general.timestep_secs).round() as u64;
    let s = score_in_motion(&config, steps).unwrap();
    let names = ["detection", "false alarms", "force RMSE", "points within 1 cm"];
    let values = [s.detection_rate(), s.false_alarm_rate(), s.relative_force_rmse(), s.point_within_rate()];
    MOTION_TARGETS
        .misses(&s)
        .iter()
        .zip(names.iter().zip(values))
        .filter(|(missed, _)| **missed)
        .map(|(_, (name, value))| format!("{model:?} seed {seed}: {name} {:.1} %", 100.0 * value))
        .collect()
}

#[test]
fn estimation_targets_hold_per_seed_on_a_held_out_peg_field() {
    // Seed 300, the first of the seeds the estimator was not developed on (300-309), on both
    // floors (measured: points within 1 cm 96.3 % anisotropic, 99.6 % isotropic).
    let mut misses = estimation_misses(GroundModel::Anisotropic, 300);
    misses.extend(estimation_misses(GroundModel::Isotropic, 300));
    assert!(misses.is_empty(), "{misses:#?}");
}

/// Every held-out seed (300-309) on both floors: 20 runs of 10 s, which `simserpent experiment
/// estimation --seeds 300-309` also checks (measured: points within 1 cm 96.3-99.0 % anisotropic,
/// 97.1-99.7 % isotropic, every other target held on every seed).
#[test]
#[ignore = "slow: 20 ten-second runs; `simserpent experiment estimation --seeds 300-309` checks the same (run with --ignored)"]
fn estimation_targets_hold_per_seed_on_all_held_out_peg_fields() {
    let mut misses = Vec::new();
    for model in [GroundModel::Anisotropic, GroundModel::Isotropic] {
        for seed in 300..310 {
            misses.extend(estimation_misses(model, seed));
        }
    }
    assert!(misses.is_empty(), "{misses:#?}");
}

/// The wide wave on a bare floor (`simserpent::experiments::estimation::self_contact_config`)
/// folds the body onto itself: links touch other links and no obstacle exists. Scored over
/// `seconds`, with the estimator's self-contact separation on or off.
fn folded_body(
    separate: bool,
    seconds: f64,
) -> (simserpent::estimation::MotionScore, simserpent::experiments::estimation::SelfContactTally) {
    use simserpent::experiments::estimation::{score_in_motion_full, self_contact_config};
    let config = self_contact_config(&Config::default(), GroundModel::Anisotropic, 0, separate);
    let steps = (seconds / config.general.timestep_secs).round() as u64;
    let (score, _, tally) = score_in_motion_full(&config, steps).unwrap();
    (score, tally)
}

#[test]
fn links_pressed_together_by_a_wide_wave_are_self_contacts_not_obstacles() {
    let (on, tally) = folded_body(true, 4.0);
    let (off, _) = folded_body(false, 4.0);
    // The wave folds the body: other links push on a tenth of the link-steps (10-s runs on the
    // anisotropic floor, seeds 0-9: 10.3-10.8 %).
    assert!(tally.present as f64 > 0.05 * tally.link_steps as f64, "{tally:?}");
    // The estimator finds those pushes as self-contacts (10-s runs: 99.7-99.9 %).
    let flagged = tally.detected as f64 / tally.present as f64;
    assert!(flagged >= 0.8, "{tally:?}");
    // and no longer as obstacles: obstacle forces above a link's weight on at most 5 % of the
    // link-steps (the estimation targets' false alarms; 10-s runs: 1.3-1.4 %; without the
    // separation 10.7-11.2 %).
    assert!(on.false_force_rate() <= 0.05, "{on:?}");
    assert!(off.false_force_rate() > 2.0 * on.false_force_rate(), "{off:?} vs {on:?}");
}

#[test]
fn the_static_pinch_flags_every_push_that_exceeds_the_floors_static_friction() {
    // Ground friction 0.5, exact sensors: the end links hit their pegs at 0.135-0.137 s with
    // pushes up to 2.5 N beyond μ·N (three steps each). Scored against the instant its sensor
    // values describe, the step loop's flag is on at each of them.
    use simserpent::experiments::estimation::{detection, pinch_config, score_estimator};
    let config = pinch_config(&Config::default(), 0.5);
    let (_, trace) = score_estimator(&config, TORQUE_NM, 300, &mut NewtonEulerEstimator::default()).unwrap();
    let threshold = config.estimation.detection_threshold_n;
    let per_link: Vec<_> = (0..N_LINKS).map(|i| detection(&trace, i, 0.5, threshold)).collect();
    let (hits, misses) = per_link.iter().fold((0, 0), |(h, m), d| (h + d.hits, m + d.misses));
    assert_eq!(misses, 0, "{per_link:?}");
    assert!(hits >= 6, "{per_link:?}");
}

/// A user's estimator: reports no force at all.
struct Blind;
impl ContactEstimator for Blind {
    fn estimate(&mut self, _input: &EstimatorInput, out: &mut EstimateOutput) {
        out.link_force_n.iter_mut().for_each(|f| *f = [0.0; 3]);
        out.total_force_n = [0.0; 3];
    }
}

#[test]
fn a_users_estimator_is_scored_the_same_way() {
    use simserpent::experiments::estimation::{pinch_config, score_estimator};
    let config = pinch_config(&Config::default(), 0.5);
    let (score, trace) = score_estimator(&config, TORQUE_NM, 200, &mut Blind).unwrap();
    for i in 0..N_LINKS {
        // Its error is the truth itself: RMSE = RMS of the true force, bias = −mean truth, and
        // every contact is a miss.
        let rms = (trace.truth_total_n.iter().map(|t| norm(t[i]).powi(2)).sum::<f64>() / 200.0).sqrt();
        assert!((score.rmse_norm_n(i) - rms).abs() < 1e-9 * rms.max(1.0));
        let mean_x = trace.truth_total_n.iter().map(|t| t[i][0]).sum::<f64>() / 200.0;
        assert!((score.bias_n(i)[0] + mean_x).abs() < 1e-9);
        assert_eq!(score.hits[i] + score.false_alarms[i], 0);
        assert!(score.misses[i] > 0);
    }
}

/// Where the false forces and the misses of the peg-field runs come from, per seed: each
/// link-step's estimated obstacle force split into the external-force estimate's error and the
/// floor share's error, and whether the true floor force itself exceeds μ·N of the same step.
#[test]
#[ignore = "probe: the causes of the estimation misses per seed (SEEDS=300-309 FLOOR=isotropic, --ignored --nocapture)"]
fn measure_causes_of_estimation_misses() {
    use simserpent::sim::{LoopPlan, Observer, SimError, StepView};
    #[derive(Clone, Copy, Default)]
    struct Truth {
        total: [f64; 3],
        floor: [f64; 3],
        obstacle: [f64; 3],
        z: f64,
        /// The true obstacle point along the link (m), and the link's horizontal axis.
        point_along_m: Option<f64>,
        axis: [f64; 3],
        /// The true floor force's horizontal part one instant earlier.
        floor_before: [f64; 3],
    }
    #[derive(Default)]
    struct Probe {
        mu_max: f64,
        weight_n: f64,
        threshold_n: f64,
        prev_t: f64,
        prev: Vec<Truth>,
        /// False forces: (time, link, est obstacle, ext error, floor error, true |F_h|/(μ N), true N, est N, z,
        /// cos(est floor_h, true floor_h), cos(true floor_h, true floor_h one instant earlier)).
        phantoms: Vec<[f64; 11]>,
        /// Misses: (time, link, true obstacle, est obstacle, ext error, floor error, true |F_h|/(μ N)).
        misses: Vec<[f64; 7]>,
        /// Contact points scored per second of the run: (scored, within 1 cm).
        points_by_second: [(u64, u64); 10],
        /// The same by the true lateral force: 1-2, 2-3, 3-5, 5-10, above 10 N.
        points_by_force: [(u64, u64); 5],
    }
    impl Observer<SimError> for Probe {
        fn on_record(&mut self, view: &StepView<'_>, snap: &Snapshot) -> Result<(), SimError> {
            let h = |v: [f64; 3]| v[0].hypot(v[1]);
            let d = |a: [f64; 3], b: [f64; 3]| (a[0] - b[0]).hypot(a[1] - b[1]);
            let est = &view.observation.contacts;
            let n = snap.link_position_m.len();
            if self.prev.len() != n {
                self.prev = vec![Truth::default(); n];
                self.prev_t = f64::NAN;
            }
            if est.active && (view.observation.sensor_time_secs - self.prev_t).abs() < 1e-9 {
                for i in 0..n {
                    let t = self.prev[i];
                    let e_obs = h(est.obstacle_force_n[i]);
                    let ext_err = d(est.external_force_n[i], t.total);
                    let floor_err = d(est.floor_force_n[i], t.floor);
                    let over = h(t.floor) / (self.mu_max * t.floor[2].max(1e-9));
                    let cos = |a: [f64; 3], b: [f64; 3]| (a[0] * b[0] + a[1] * b[1]) / (h(a) * h(b)).max(1e-12);
                    if t.obstacle == [0.0; 3] && e_obs > self.weight_n {
                        self.phantoms.push([
                            self.prev_t,
                            i as f64,
                            e_obs,
                            ext_err,
                            floor_err,
                            over,
                            t.floor[2],
                            est.floor_force_n[i][2],
                            t.z,
                            cos(est.floor_force_n[i], t.floor),
                            cos(t.floor, t.floor_before),
                        ]);
                    }
                    let lateral = (t.axis[0] * t.obstacle[1] - t.axis[1] * t.obstacle[0]).abs();
                    if let (true, Some(truth)) = (lateral > 1.0, t.point_along_m) {
                        let within = est.contact_point_along_m[i].is_some_and(|p| (p - truth).abs() <= 0.01);
                        let by_force = [2.0, 3.0, 5.0, 10.0].iter().filter(|&&edge| lateral >= edge).count();
                        for bin in [
                            &mut self.points_by_second[(self.prev_t as usize).min(9)],
                            &mut self.points_by_force[by_force],
                        ] {
                            bin.0 += 1;
                            bin.1 += u64::from(within);
                        }
                    }
                    if h(t.obstacle) >= self.threshold_n && !est.contact[i] {
                        self.misses.push([self.prev_t, i as f64, h(t.obstacle), e_obs, ext_err, floor_err, over]);
                    }
                }
            }
            for i in 0..n {
                let floor_before = self.prev[i].floor;
                let a = simserpent::state::x_axis(snap.link_quat[i]);
                let ah = a[0].hypot(a[1]).max(1e-12);
                self.prev[i] = Truth {
                    floor_before,
                    point_along_m: snap.link_obstacle_point_m[i].map(|p| snap.along_link_axis_m(i, p)),
                    axis: [a[0] / ah, a[1] / ah, 0.0],
                    total: snap.link_contact_force_n[i],
                    floor: snap.link_floor_force_n[i],
                    obstacle: snap.link_obstacle_force_n[i],
                    z: snap.link_position_m[i][2],
                };
            }
            self.prev_t = snap.time_secs;
            Ok(())
        }
    }
    let seeds: Vec<u64> = match std::env::var("SEEDS").ok().as_deref().and_then(|s| s.split_once('-')) {
        Some((a, b)) => (a.parse().unwrap()..=b.parse().unwrap()).collect(),
        None => vec![300],
    };
    let model = match std::env::var("FLOOR").as_deref() {
        Ok("anisotropic") => GroundModel::Anisotropic,
        _ => GroundModel::Isotropic,
    };
    for seed in seeds {
        let mut config = simserpent::experiments::estimation::peg_field_config(&Config::default(), model, seed, 1.0);
        if std::env::var("IDENTIFY").is_ok() {
            config.estimation.friction = simserpent::config::FloorFrictionSource::Identify;
        }
        let mu = config.snake.ground_friction;
        let mut probe = Probe {
            mu_max: mu.iter().fold(0.0f64, |a, &b| a.max(b)),
            weight_n: config.snake.link_mass_kg * 9.81,
            threshold_n: config.estimation.detection_threshold_n,
            ..Probe::default()
        };
        let world = World::from_config(&config).unwrap();
        let mut sim = Simulation::new(&config, world);
        let steps = (10.0 / config.general.timestep_secs).round() as u64;
        sim.run(LoopPlan { steps, record_every_n_steps: 1 }, &mut [&mut probe]).unwrap();
        let ph = &probe.phantoms;
        let in_ramp = ph.iter().filter(|p| p[0] < config.gait.ramp_secs).count();
        let ext_dominated = ph.iter().filter(|p| p[3] > p[4]).count();
        let over_mu = ph.iter().filter(|p| p[5] > 1.05).count();
        let against = ph.iter().filter(|p| p[9] < 0.0).count();
        let flipped = ph.iter().filter(|p| p[10] < 0.0).count();
        let big = ph.iter().filter(|p| p[2] > 5.0 * probe.weight_n).count();
        let worst = ph.iter().max_by(|a, b| a[2].total_cmp(&b[2]));
        eprintln!(
            "seed {seed} {model:?}: false forces > m·g: {} ({in_ramp} in the ramp), external-estimate error larger than \
             floor-share error on {ext_dominated}, true floor friction > 1.05 μN on {over_mu}, estimated floor \
             friction against the true one on {against}, true floor friction reversed since the previous instant on \
             {flipped}, > 5 m·g on {big}; worst {worst:?}",
            ph.len()
        );
        let m = &probe.misses;
        let m_ramp = m.iter().filter(|p| p[0] < config.gait.ramp_secs).count();
        let m_small = m.iter().filter(|p| p[2] < 2.0 * probe.threshold_n).count();
        let m_over = m.iter().filter(|p| p[6] > 1.05).count();
        eprintln!(
            "seed {seed}: misses {} ({m_ramp} in the ramp, {m_small} with true force < 2×threshold, {m_over} with true \
             floor friction > 1.05 μN)",
            m.len()
        );
        let bins: Vec<String> = probe
            .points_by_second
            .iter()
            .map(|(n, w)| format!("{:.1} % of {n}", 100.0 * *w as f64 / (*n).max(1) as f64))
            .collect();
        eprintln!("seed {seed}: contact points within 1 cm per second of the run: {}", bins.join(", "));
        let bins: Vec<String> = ["1-2 N", "2-3 N", "3-5 N", "5-10 N", "> 10 N"]
            .iter()
            .zip(probe.points_by_force)
            .map(|(range, (n, w))| format!("{range}: {:.1} % of {n}", 100.0 * w as f64 / n.max(1) as f64))
            .collect();
        eprintln!("seed {seed}: contact points within 1 cm by true lateral force: {}", bins.join(", "));
    }
}

#[test]
fn seeds_and_floor_are_options_of_the_estimation_experiment_only() {
    use simserpent::experiments::{ExperimentError, ExperimentOptions, run_experiment_with};
    let dir = tempfile::tempdir().unwrap();
    let with = |seeds: Option<Vec<u64>>, floor: Option<GroundModel>| ExperimentOptions {
        seeds,
        floor,
        ..ExperimentOptions::default()
    };
    let err = run_experiment_with("collision", &Config::default(), dir.path(), &with(Some(vec![3]), None)).unwrap_err();
    assert!(matches!(&err, ExperimentError::Option(m) if m.contains("`collision` takes neither")), "{err}");
    let err =
        run_experiment_with("estimation", &Config::default(), dir.path(), &with(None, Some(GroundModel::Viscous)))
            .unwrap_err();
    assert!(matches!(&err, ExperimentError::Option(m) if m.contains("isotropic or an anisotropic")), "{err}");
    let err = run_experiment_with("estimation", &Config::default(), dir.path(), &with(Some(vec![]), None)).unwrap_err();
    assert!(matches!(err, ExperimentError::Option(_)));
    // Nothing was written for a refused option.
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}
