//! Experiment `estimation`: proprioceptive contact-force estimation scored against the
//! simulator's ground truth (Boa's method, `crate::estimation`).
//!
//! The scene: a 5-link snake bent into one arc (30° per joint) between three pegs (first-order
//! form closure: one inside the bend at its apex, one outside the head link, one outside the tail
//! link). A constant torque of −0.2 N·m on every joint tries to straighten it and presses it
//! against the three pegs: a sustained push, held by the pegs even without ground friction.
//!
//! Cases: (a) no ground friction, exact sensors: the estimate's horizontal part is the obstacle
//! force, checked within 2 % RMS per pushing link, and the estimated contact point along the link
//! within 5 mm of the true one once the pinch has settled; (b) ground friction 0.5, exact sensors: the
//! estimate is the total external force (ground + obstacles), checked within 2 % RMS per link;
//! (c) as (b) with Gaussian noise on the accelerometers and joint force sensors (the stds of the
//! base config, bias, walk, quantisation and hold off so the prediction applies): the error's
//! spread per link and axis is checked against sqrt(m²σ_a² + k·σ_f²) within 4 standard errors of
//! a sample std.
//!
//! Every step: control, forward pass (so contacts, forces and sensors all describe that
//! instant), fresh sensor values, measurement models, estimate, score. Each case writes
//! `estimation_<case>.csv` (time, per link estimate, true total and true obstacle force) and
//! plots of estimate against truth (`plots/estimation_<case>_link_<i>.png/.svg`).
//!
//! Users plug in their own estimator through [`score_estimator`].

use super::report::{Check, Section, sig};
use super::{Context, ExperimentError};
use crate::config::{Config, ControlMethod, GaitKind, GroundModel, SensorModel, TerrainKind};
use crate::control::{Command, Controller, Observation};
use crate::estimation::{
    ContactEstimator, EstimateOutput, EstimationScore, EstimatorInput, LinkSample, MotionScore, NewtonEulerEstimator,
    adjacent_joints, predicted_error_std_n,
};
use crate::run::RunError;
use crate::sim::{LoopPlan, Observer, SensorNoise, SimError, Simulation, Snapshot, StepView, World};
use std::io::Write;
use std::path::Path;

/// Links of the scene.
pub const N_LINKS: usize = 5;
/// Straightening torque on every joint (N·m).
pub const TORQUE_NM: f64 = -0.2;
/// Force magnitude (N) from which a contact with a peg counts as present (truth and estimate).
pub const DETECTION_THRESHOLD_N: f64 = 0.1;

/// Constant joint torques.
struct ConstTorque(Vec<f64>);

impl Controller for ConstTorque {
    fn update(&mut self, _obs: &Observation, cmd: &mut Command) {
        for (c, t) in cmd.torque_nm.iter_mut().zip(&self.0) {
            *c = *t;
        }
    }
}

/// The scene on top of `base`, with the given ground friction coefficient.
pub fn pinch_config(base: &Config, ground_friction: f64) -> Config {
    let mut c = base.clone();
    c.snake.n_links = N_LINKS;
    c.snake.head_position_m = [0.0; 3];
    c.snake.head_rotation_deg = [0.0; 3];
    c.snake.torque_range_nm = [-3.0, 3.0];
    c.terrain.kind = TerrainKind::FormClosure;
    c.terrain.form_closure.order = 1;
    c.terrain.obstacle_friction = [0.0; 3];
    c.gait.kind = GaitKind::FormClosure;
    c.gait.form_closure.pattern_deg = vec![30.0; N_LINKS - 1];
    c.gait.ramp_secs = 0.0;
    c.control.method = ControlMethod::Torque;
    c.ground.model = GroundModel::Isotropic;
    c.snake.ground_friction = [ground_friction, 0.0, 0.0];
    c.snake.link_friction = [ground_friction, 0.0, 0.0];
    c.sensors.noise_enabled = false;
    // The step loop's estimator (floor separation, contact flags) runs too; with exact sensors
    // its threshold is the experiment's.
    c.estimation.enabled = true;
    c.estimation.detection_threshold_n = DETECTION_THRESHOLD_N;
    c
}

/// The time series of one scored run.
#[derive(Debug, Clone, Default)]
pub struct Trace {
    /// Link masses (kg).
    pub link_mass_kg: Vec<f64>,
    /// Time of each sample (s).
    pub time_s: Vec<f64>,
    /// Per sample, per link: estimate, true total external force, true obstacle force (N).
    pub estimate_n: Vec<Vec<[f64; 3]>>,
    pub truth_total_n: Vec<Vec<[f64; 3]>>,
    pub truth_obstacle_n: Vec<Vec<[f64; 3]>>,
    /// Per sample, per link: the estimate from exact sensors (N; equals `estimate_n` without noise).
    pub exact_estimate_n: Vec<Vec<[f64; 3]>>,
    /// Per sample, per link: distance along the link axis (m) between the estimated contact point
    /// and the true obstacle contact point, when both exist.
    pub contact_point_error_m: Vec<Vec<Option<f64>>>,
    /// Per sample, per link: the step loop's contact flag (`Observation::contacts`, floor
    /// separated), empty when estimation is off.
    pub contact_flag: Vec<Vec<bool>>,
    /// Per sample: the time (s) of the sensor values the contact flag comes from
    /// (`Observation::sensor_time_secs`: the last complete model evaluation, one step before the
    /// sample's instant), so a flag is scored against the truth of the instant it describes.
    pub contact_flag_time_s: Vec<f64>,
}

impl Trace {
    /// Per sample: the step loop's contact flags that describe this sample's instant (the flags
    /// whose sensor time is the sample's time; `None` where no recorded flag does, e.g. at the
    /// last instant).
    pub fn aligned_contact_flags(&self) -> Vec<Option<&[bool]>> {
        let mut j = 0;
        self.time_s
            .iter()
            .map(|&t| {
                while j < self.contact_flag_time_s.len() && self.contact_flag_time_s[j] < t - 1e-9 {
                    j += 1;
                }
                (j < self.contact_flag_time_s.len() && (self.contact_flag_time_s[j] - t).abs() <= 1e-9)
                    .then(|| self.contact_flag.get(j).map(Vec::as_slice))
                    .flatten()
            })
            .collect()
    }
}

/// Runs `config` for `steps` steps with a constant torque on every joint and scores
/// `estimator` against the true external force per link (ground + obstacles + other links).
/// The sensor values the estimator sees are measured with `config.sensors`; the link poses come
/// from the simulator. Also runs the built-in [`NewtonEulerEstimator`] on exact sensors (the
/// trace's `exact_estimate_n`). Allocates (it keeps the trace), so it is no step-loop code.
pub fn score_estimator(
    config: &Config,
    torque_nm: f64,
    steps: usize,
    estimator: &mut dyn ContactEstimator,
) -> Result<(EstimationScore, Trace), ExperimentError> {
    config.validate().map_err(|e| RunError::Sim(e.into()))?;
    let world = World::from_config(config).map_err(RunError::Sim)?;
    let (nl, nj) = (world.n_links(), world.n_joints());
    let masses: Vec<f64> = world.index.links.iter().map(|l| l.mass_kg).collect();
    let mut sim = Simulation::with_typed_controller(config, world, ConstTorque(vec![torque_nm; nj]));
    let mut input = EstimatorInput::new(nl);
    input.link_mass_kg.copy_from_slice(&masses);
    let mut scorer = Scorer {
        estimator,
        noise: SensorNoise::new(&config.sensors, config.general.seed, nl, nj),
        obs: Observation::new(nl, nj),
        measured: Observation::new(nl, nj),
        input,
        out: EstimateOutput::new(nl),
        exact: EstimateOutput::new(nl),
        reference: NewtonEulerEstimator::default(),
        score: EstimationScore::new(nl, DETECTION_THRESHOLD_N),
        trace: Trace { link_mass_kg: masses, ..Trace::default() },
    };
    if steps > 0 {
        // Instants 0 ..= steps − 1, each recorded (a forward pass, so the sensors describe it).
        let plan = LoopPlan { steps: steps as u64 - 1, record_every_n_steps: 1 };
        sim.run(plan, &mut [&mut scorer, &mut crate::interrupt::Poll::new("an estimation case")])
            .map_err(RunError::Sim)?;
    }
    Ok((scorer.score, scorer.trace))
}

/// Scores an estimator at every recorded instant of the step loop.
struct Scorer<'a> {
    estimator: &'a mut dyn ContactEstimator,
    noise: SensorNoise,
    obs: Observation,
    measured: Observation,
    input: EstimatorInput,
    out: EstimateOutput,
    exact: EstimateOutput,
    reference: NewtonEulerEstimator,
    score: EstimationScore,
    trace: Trace,
}

impl Observer<SimError> for Scorer<'_> {
    fn on_record(&mut self, view: &StepView<'_>, snap: &Snapshot) -> Result<(), SimError> {
        let nl = snap.link_position_m.len();
        // After the record's forward pass the sensors describe this instant.
        view.world.observe_true(&mut self.obs);
        self.noise.measure(&self.obs, &mut self.measured);
        let input = &mut self.input;
        input.fill(&self.obs, &snap.link_quat, &snap.link_position_m, &snap.link_origin_m);
        self.reference.estimate(input, &mut self.exact);
        input.fill(&self.measured, &snap.link_quat, &snap.link_position_m, &snap.link_origin_m);
        self.estimator.estimate(input, &mut self.out);
        let (out, trace) = (&self.out, &mut self.trace);
        self.score.add(&out.link_force_n, &snap.link_contact_force_n);
        trace.time_s.push(snap.time_secs);
        trace.contact_flag.push(view.observation.contacts.contact.clone());
        trace.contact_flag_time_s.push(view.observation.sensor_time_secs);
        trace.estimate_n.push(out.link_force_n.clone());
        trace.exact_estimate_n.push(self.exact.link_force_n.clone());
        trace.truth_total_n.push(snap.link_contact_force_n.clone());
        trace.truth_obstacle_n.push(snap.link_obstacle_force_n.clone());
        trace.contact_point_error_m.push(
            (0..nl)
                .map(|i| {
                    let (est, truth) = (out.link_contact_point_m[i]?, snap.link_obstacle_point_m[i]?);
                    // Both measured along the link axis (the link frame's x axis) from the centre of mass.
                    let r = &input.link_rotation[i];
                    let c = snap.link_position_m[i];
                    let along = |p: [f64; 3]| (0..3).map(|k| (p[k] - c[k]) * r[k][0]).sum::<f64>();
                    Some((along(est) - along(truth)).abs())
                })
                .collect(),
        );
        Ok(())
    }
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> ExperimentError + '_ {
    move |source| ExperimentError::Io { what: "write", path: path.to_path_buf(), source }
}

/// Writes the trace as CSV and plots estimate against truth per link (x and y components).
fn write_trace(ctx: &Context, case: &str, trace: &Trace) -> Result<(), ExperimentError> {
    let path = ctx.folder.join(format!("estimation_{case}.csv"));
    let mut w = std::io::BufWriter::new(std::fs::File::create(&path).map_err(io(&path))?);
    let n = trace.estimate_n.first().map_or(0, Vec::len);
    let mut header = String::from("time_s");
    for i in 0..n {
        for what in ["estimate", "true_total", "true_obstacle"] {
            for axis in ["x", "y", "z"] {
                header.push_str(&format!(",link_{i:02}_{what}_{axis}_n"));
            }
        }
    }
    writeln!(w, "{header}").map_err(io(&path))?;
    for (k, t) in trace.time_s.iter().enumerate() {
        write!(w, "{t}").map_err(io(&path))?;
        for i in 0..n {
            for v in [trace.estimate_n[k][i], trace.truth_total_n[k][i], trace.truth_obstacle_n[k][i]] {
                write!(w, ",{},{},{}", v[0], v[1], v[2]).map_err(io(&path))?;
            }
        }
        writeln!(w).map_err(io(&path))?;
    }
    w.flush().map_err(io(&path))?;
    let plots = ctx.folder.join("plots");
    std::fs::create_dir_all(&plots).map_err(io(&plots))?;
    for i in 0..n {
        let col = |series: &Vec<Vec<[f64; 3]>>, axis: usize| series.iter().map(|row| row[i][axis]).collect::<Vec<_>>();
        let series = vec![
            ("estimate x".to_string(), col(&trace.estimate_n, 0)),
            ("true total x".to_string(), col(&trace.truth_total_n, 0)),
            ("true obstacle x".to_string(), col(&trace.truth_obstacle_n, 0)),
            ("estimate y".to_string(), col(&trace.estimate_n, 1)),
            ("true total y".to_string(), col(&trace.truth_total_n, 1)),
            ("true obstacle y".to_string(), col(&trace.truth_obstacle_n, 1)),
        ];
        crate::plot::plot_time_series(
            &plots,
            &format!("estimation_{case}_link_{i:02}"),
            &format!("{case}: link {i}, external force"),
            "force (N)",
            &trace.time_s,
            &series,
        )
        .map_err(|e| ExperimentError::Data(format!("plot: {e}")))?;
    }
    Ok(())
}

/// RMS of the horizontal error against the true obstacle force, relative to the RMS obstacle
/// force, over the samples in which the link pushes (truth ≥ the detection threshold).
fn obstacle_relative_rms(trace: &Trace, link: usize) -> (f64, usize) {
    let (mut err, mut truth, mut n) = (0.0, 0.0, 0);
    for (e, t) in trace.estimate_n.iter().zip(&trace.truth_obstacle_n) {
        let (e, t) = (e[link], t[link]);
        if t[0].hypot(t[1]).hypot(t[2]) >= DETECTION_THRESHOLD_N {
            err += (e[0] - t[0]).powi(2) + (e[1] - t[1]).powi(2);
            truth += t[0].powi(2) + t[1].powi(2);
            n += 1;
        }
    }
    ((err / truth.max(f64::MIN_POSITIVE)).sqrt(), n)
}

/// Relative RMS error against the true total force over all samples.
fn total_relative_rms(trace: &Trace, link: usize) -> f64 {
    let (mut err, mut truth) = (0.0, 0.0);
    for (e, t) in trace.estimate_n.iter().zip(&trace.truth_total_n) {
        err += (0..3).map(|k| (e[link][k] - t[link][k]).powi(2)).sum::<f64>();
        truth += (0..3).map(|k| t[link][k].powi(2)).sum::<f64>();
    }
    (err / truth.max(f64::MIN_POSITIVE)).sqrt()
}

/// Obstacle contact detection of one link over a trace (see [`detection`]).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Detection {
    /// Observable pushes flagged.
    pub hits: usize,
    /// Observable pushes not flagged.
    pub misses: usize,
    /// Flags without a push.
    pub false_alarms: usize,
    /// Pushes that no estimator can see (below the floor's static friction).
    pub hidden: usize,
    /// The sum of those pushes' excess over μ·N (N).
    pub hidden_excess_sum_n: f64,
}

/// Obstacle contact detection: a contact is present when the true obstacle force reaches the
/// threshold; it is detected when the step loop's estimator flags it at the same instant (the
/// flag whose sensor values describe the instant: [`Trace::aligned_contact_flags`]; an instant
/// no flag describes is not scored) (`Observation::contacts`:
/// the floor's share — support and friction up to μ·N while the link sticks — removed from the
/// external force, the rest above `estimation.detection_threshold_n`). A present contact is
/// observable when the link's true horizontal external force exceeds `mu`·N (N its true vertical
/// force) by at least `threshold_n` (the in-loop threshold): a sticking floor can hold any
/// horizontal force up to μ·N, so a weaker push is indistinguishable from floor friction (with
/// `mu` = 0 every push is observable).
pub fn detection(trace: &Trace, link: usize, mu: f64, threshold_n: f64) -> Detection {
    let mut d = Detection::default();
    let mut previous_n = f64::NAN;
    let flags = trace.aligned_contact_flags();
    for ((flags, t), total) in flags.iter().zip(&trace.truth_obstacle_n).zip(&trace.truth_total_n) {
        let f = total[link];
        // The support of this instant enters the next one's bound (below) even when unscored.
        let Some(flags) = flags else {
            previous_n = f[2];
            continue;
        };
        let present = t[link][0].hypot(t[link][1]).hypot(t[link][2]) >= DETECTION_THRESHOLD_N;
        let detected = flags.get(link).copied().unwrap_or(false);
        // The floor's hold is bounded by μ times a normal force of this or the previous instant
        // (the floor's friction bound comes from an earlier model evaluation than the one the
        // sensors describe: `estimation::motion`), so a push is observable only beyond the
        // larger of the two.
        let support_n = f[2].max(if previous_n.is_nan() { f[2] } else { previous_n }).max(0.0);
        previous_n = f[2];
        let excess = f[0].hypot(f[1]) - mu * support_n;
        let observable = mu == 0.0 || excess >= threshold_n;
        match (detected, present, observable) {
            (true, true, true) => d.hits += 1,
            (false, true, true) => d.misses += 1,
            (_, true, false) => {
                d.hidden += 1;
                d.hidden_excess_sum_n += excess;
            }
            (true, false, _) => d.false_alarms += 1,
            (false, false, _) => {}
        }
    }
    d
}

/// Why detection in the static pinch with friction and noisy sensors is hard, in numbers (a
/// sentence for the report): a sticking link's floor can hold any horizontal force up to μ·N, so
/// only the excess of the link's external force over μ·N shows a peg. Over the run's second half
/// and the links a peg pushes: the mean of that excess (true forces), the noise's spread of the
/// horizontal estimate (estimate − exact-sensor estimate), and the in-loop threshold.
fn static_friction_margin(trace: &Trace, mu: f64, threshold_n: f64) -> String {
    let settled = trace.time_s.len() / 2;
    let (mut excess, mut noise_sq, mut n) = (0.0, 0.0, 0usize);
    for k in settled..trace.time_s.len() {
        for i in 0..trace.truth_total_n[k].len() {
            let o = trace.truth_obstacle_n[k][i];
            if o[0].hypot(o[1]) < DETECTION_THRESHOLD_N {
                continue;
            }
            let t = trace.truth_total_n[k][i];
            excess += t[0].hypot(t[1]) - mu * t[2].max(0.0);
            let (e, x) = (trace.estimate_n[k][i], trace.exact_estimate_n[k][i]);
            noise_sq += (e[0] - x[0]).powi(2) + (e[1] - x[1]).powi(2);
            n += 1;
        }
    }
    if n == 0 {
        return String::new();
    }
    let (excess, noise) = (excess / n as f64, (noise_sq / n as f64).sqrt());
    format!(
        " Static friction with noisy sensors (case friction_noise): where a peg pushes, the link's horizontal \
         external force exceeds what the sticking floor could hold (μ·N) by {} N on average (second half), the noise's \
         spread of the horizontal estimate is {} N per step and the in-loop threshold is {threshold_n} N{}",
        sig(excess),
        sig(noise),
        if excess < threshold_n {
            ": the excess lies below the threshold, so no per-step detector can tell that push from floor friction \
             (below μ·N static friction is indeterminate): this case's detection is reported as not observable."
        } else {
            "."
        }
    )
}

/// Runs the experiment.
pub fn run(ctx: &Context, base: &Config) -> Result<Section, ExperimentError> {
    let duration_secs = if ctx.quick { 1.0 } else { 3.0 };
    let mut section =
        Section { heading: "Contact-force estimation from joint force/torque sensors".into(), ..Default::default() };
    let mut rows = Vec::new();
    let header: Vec<String> = [
        "case",
        "link",
        "RMSE vs total (N)",
        "bias x (N)",
        "bias y (N)",
        "rel. RMS vs obstacle",
        "hits",
        "misses",
        "false alarms",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();

    let a_n = base.sensors.accelerometer.std;
    let f_n = base.sensors.joint_force.std;
    let mut static_margin_note = None;
    for (case, friction, noisy) in
        [("no_friction", 0.0, false), ("friction", 0.5, false), ("friction_noise", 0.5, true)]
    {
        let mut config = pinch_config(base, friction);
        if noisy {
            config.sensors.noise_enabled = true;
            let white = |std: f64| SensorModel {
                std,
                bias: 0.0,
                bias_random_walk_per_sqrt_s: 0.0,
                resolution: 0.0,
                rate_hz: 0.0,
            };
            config.sensors.accelerometer = white(a_n);
            config.sensors.joint_force = white(f_n);
            config.sensors.joint_torque = white(0.0);
            // Noisy sensors: the in-loop detection threshold above the noise (σ ≈ 0.15 N per axis).
            config.sensors.noise_enabled = true;
            config.estimation.detection_threshold_n = base.estimation.detection_threshold_n.max(0.5);
        }
        let steps = (duration_secs / config.general.timestep_secs).round() as usize;
        let (score, trace) = score_estimator(&config, TORQUE_NM, steps, &mut NewtonEulerEstimator::default())?;
        write_trace(ctx, case, &trace)?;
        for i in 0..N_LINKS {
            let bias = score.bias_n(i);
            let (rel_obstacle, pushing) = obstacle_relative_rms(&trace, i);
            // The table counts every push (μ = 0: none hidden by static friction).
            let d = detection(&trace, i, 0.0, 0.0);
            let (hits, misses, false_alarms) = (d.hits, d.misses, d.false_alarms);
            rows.push(vec![
                case.to_string(),
                i.to_string(),
                sig(score.rmse_norm_n(i)),
                sig(bias[0]),
                sig(bias[1]),
                if pushing > 0 { format!("{:.3} %", 100.0 * rel_obstacle) } else { "no push".into() },
                hits.to_string(),
                misses.to_string(),
                false_alarms.to_string(),
            ]);
            match case {
                "no_friction" if pushing > 0 => {
                    section.checks.push(Check::at_most(
                        &format!("no friction, link {i}: RMS error of the obstacle force / RMS obstacle force"),
                        rel_obstacle,
                        0.02,
                        "",
                    ));
                    // The contact point, once the pinch has settled (second half of the run; the
                    // estimate neglects the link's angular acceleration).
                    let settled = trace.contact_point_error_m.len() / 2;
                    let worst = trace.contact_point_error_m[settled..]
                        .iter()
                        .map(|row| row[i].unwrap_or(f64::INFINITY))
                        .fold(0.0, f64::max);
                    section.checks.push(Check::at_most(
                        &format!("no friction, link {i}: contact point along the link, largest error after settling"),
                        worst,
                        0.005,
                        "m",
                    ));
                }
                "friction" => section.checks.push(Check::at_most(
                    &format!("friction, link {i}: RMS error / RMS true total external force"),
                    total_relative_rms(&trace, i),
                    0.02,
                    "",
                )),
                "friction_noise" => {
                    // Error against the exact-sensor estimate: the noise's part only.
                    let n = trace.time_s.len() as f64;
                    let predicted = predicted_error_std_n(trace.link_mass_kg[i], adjacent_joints(i, N_LINKS), a_n, f_n);
                    for axis in 0..3 {
                        let errors: Vec<f64> = trace
                            .estimate_n
                            .iter()
                            .zip(&trace.exact_estimate_n)
                            .map(|(e, x)| e[i][axis] - x[i][axis])
                            .collect();
                        let mean = errors.iter().sum::<f64>() / n;
                        let std = (errors.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
                        section.checks.push(Check::relative(
                            &format!("noise, link {i} axis {}: error std vs sqrt(m²σa² + kσf²)", ["x", "y", "z"][axis]),
                            std,
                            predicted,
                            4.0 / (2.0 * (n - 1.0)).sqrt(),
                            "N",
                        ));
                    }
                }
                _ => {}
            }
        }
        // Detection is a check of every case (with friction too): a report that passes while
        // contacts go unseen would be wrong. It is scored where a push is observable at all: a
        // sticking floor holds any horizontal force up to μ·N, so a peg's push shows only where
        // the link's horizontal external force exceeds μ·N by the in-loop threshold.
        let threshold_n = config.estimation.detection_threshold_n;
        let (mut hits, mut misses, mut hidden, mut excess_sum) = (0usize, 0usize, 0usize, 0.0);
        for i in 0..N_LINKS {
            let d = detection(&trace, i, friction, threshold_n);
            hits += d.hits;
            misses += d.misses;
            hidden += d.hidden;
            excess_sum += d.hidden_excess_sum_n;
        }
        let name = format!("{case}: obstacle contacts detected (hits / (hits + misses), observable pushes)");
        let target = if case == "no_friction" { 0.99 } else { 0.95 };
        let rate = hits as f64 / (hits + misses) as f64;
        let why = format!(
            "on {hidden} of the {} link-steps where a peg pushes, the link's horizontal external force exceeds \
             what the sticking floor can hold (μ·N, μ = {friction}) by less than the in-loop threshold {threshold_n} N \
             (by {} N on average): below the floor's static friction a push cannot be told from floor friction by \
             any estimator of forces",
            hidden + hits + misses,
            sig(excess_sum / hidden.max(1) as f64)
        );
        if hits + misses > 0 {
            section.checks.push(Check::at_least(&name, rate, target, ""));
            if hidden > 0 {
                let share = hidden as f64 / (hidden + hits + misses) as f64;
                let mut c = Check::at_least(
                    &format!("{case}: obstacle contacts detected, pushes below the floor's static friction"),
                    share,
                    target,
                    "",
                )
                .not_observable(&format!("{} % of the pushes: {why}", sig(100.0 * share)));
                c.expected = format!("detected ≥ {}", sig(target));
                section.checks.push(c);
            }
        } else {
            section.checks.push(Check::at_least(&name, f64::NAN, target, "").not_observable(&why));
        }
        if noisy {
            static_margin_note =
                Some(static_friction_margin(&trace, friction, config.estimation.detection_threshold_n));
        }
    }
    section.tables.push((header, rows));
    run_motion(ctx, base, &mut section)?;
    section.text = format!(
        "A {N_LINKS}-link snake bent 30° per joint between three pegs (first-order form closure), every joint \
         driven with {TORQUE_NM} N·m so that it presses against all three. {duration_secs} s per case, \
         timestep {} s. Estimator: Newton per link, f_ext = m·R·acc − R_i·s_i + R_(i+1)·s_(i+1) \
         (`simserpent::estimation`). Noise case: σ_a = {a_n} m/s² per accelerometer axis, σ_f = {f_n} N per \
         force-sensor axis (white; `sensors.accelerometer.std`, `sensors.joint_force.std`). Detection threshold \
         {DETECTION_THRESHOLD_N} N above what the floor's friction can supply, μ·m·g (true obstacle \
         force vs horizontal estimate). Data: `estimation_<case>.csv`; \
         plots: `plots/estimation_<case>_link_<i>.png`.{}",
        base.general.timestep_secs,
        static_margin_note.unwrap_or_default()
    );
    let seeds = motion_seeds(ctx);
    section.text.push_str(&format!(
        "\n\nIn motion: a {MOTION_LINKS}-link snake with the default gait through a random peg field, {} s per run, \
         peg layouts and sensor noise from seeds {}, scored at every step and per seed (table: one row per seed, \
         then the seeds pooled; a missed target is marked MISS). Each check is a target on its worst seed. Targets \
         with the default noise and without: detection ≥ {} %, false alarms ≤ {} %, force RMSE ≤ {} % of the RMS \
         obstacle force, contact points within 1 cm on ≥ {} %; twice the default noise: {} / {} / {} / {} %. False \
         force: on link-steps without any true obstacle force, the share with more than one link's weight m·g of \
         estimated obstacle force (more than a floor with μ ≤ 1 can hold the link sideways with, so it cannot be \
         misplaced floor friction) and the largest. Data: `estimation_motion.csv`.",
        if ctx.quick { 2 } else { 10 },
        seed_list(&seeds),
        100.0 * MOTION_TARGETS.detection,
        100.0 * MOTION_TARGETS.false_alarms,
        100.0 * MOTION_TARGETS.force_rmse,
        100.0 * MOTION_TARGETS.points_within,
        100.0 * MOTION_TARGETS_2X_NOISE.detection,
        100.0 * MOTION_TARGETS_2X_NOISE.false_alarms,
        100.0 * MOTION_TARGETS_2X_NOISE.force_rmse,
        100.0 * MOTION_TARGETS_2X_NOISE.points_within,
    ));
    run_self_contacts(ctx, base, &mut section)?;
    Ok(section)
}

// ---------------------------------------------------------------------------------------------
// Separation in motion: a 10-link snake undulating through a peg field.

/// Links of the peg-field scene.
pub const MOTION_LINKS: usize = 10;

/// The peg-field scene on top of `base`: a `MOTION_LINKS`-link snake with the default sine wave
/// (position servos), SimSerpent's stick–slip floor with the given ground model, a random peg
/// field around and ahead of the body (layout from `seed`), the default sensor noise scaled by
/// `noise_scale` (0 = off), and contact estimation in the loop (head IMU + encoders).
pub fn peg_field_config(base: &Config, ground: GroundModel, seed: u64, noise_scale: f64) -> Config {
    let mut c = base.clone();
    let defaults = Config::default();
    c.general.seed = seed;
    c.snake = defaults.snake.clone();
    c.snake.n_links = MOTION_LINKS;
    c.physics.floor_friction = crate::config::FloorFriction::StickSlip;
    c.ground.model = ground;
    c.ground.surfaces.clear();
    c.gait = defaults.gait.clone();
    c.control = defaults.control.clone();
    c.terrain.kind = TerrainKind::None;
    c.terrain.pegboard.layout = crate::config::PegLayout::Random;
    c.terrain.pegboard.peg_radius_m = 0.05;
    c.terrain.pegboard.spacing_m = 0.35;
    c.terrain.pegboard.region_min_m = [-2.2, -0.45];
    c.terrain.pegboard.region_max_m = [1.5, 0.45];
    c.terrain.pegboard.count = 14;
    c.terrain.pegboard.skip_pegs_on_snake = true;
    c.sensors = defaults.sensors.clone();
    c.sensors.noise_enabled = noise_scale > 0.0;
    for m in [
        &mut c.sensors.accelerometer,
        &mut c.sensors.gyro,
        &mut c.sensors.joint_angle,
        &mut c.sensors.joint_velocity,
        &mut c.sensors.actuator_torque,
        &mut c.sensors.joint_force,
        &mut c.sensors.joint_torque,
    ] {
        m.std *= noise_scale;
    }
    c.estimation = base.estimation.clone();
    c.estimation.enabled = true;
    c
}

/// Scores the step loop's contact estimates (`Observation::contacts`) at every instant against
/// the truth of the instant their sensor values describe: the sensors are those of the last
/// complete model evaluation, one step before the instant (`Observation::sensor_time_secs`), so
/// each estimate is scored against the previous instant's truth (the floor contact forces
/// change by about 1 N from one step to the next, so a one-step misalignment alone would cost
/// about 1 N RMS).
struct MotionScorer {
    score: MotionScore,
    /// Self-contacts: their true and estimated flags, per link-step.
    self_tally: SelfContactTally,
    /// The floor coefficients the estimator used (forward, backward, lateral), every 0.1 s.
    friction: Vec<(f64, [f64; 3])>,
    /// The previous recorded instant's truth: time, and per link the sample without estimate.
    previous_time_secs: f64,
    previous: Vec<LinkSample>,
    /// The previous instant's truth: per link whether another link pushes it (≥ the threshold).
    previous_self: Vec<bool>,
}

/// Self-contacts over the link-steps of a run: how many had a true self-contact (another link's
/// horizontal push of at least the detection threshold), how many of those the estimator flagged
/// as self-contact, how many it flagged without one, and the false forces (obstacle force above a
/// link's weight without any true obstacle contact) on links with a true self-contact.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SelfContactTally {
    pub link_steps: u64,
    pub present: u64,
    pub detected: u64,
    pub false_flags: u64,
    pub false_forces_touching: u64,
}

impl SelfContactTally {
    fn add(&mut self, present: bool, flagged: bool, false_force: bool) {
        self.link_steps += 1;
        self.present += u64::from(present);
        self.detected += u64::from(present && flagged);
        self.false_flags += u64::from(!present && flagged);
        self.false_forces_touching += u64::from(present && false_force);
    }

    fn merge(&mut self, o: &SelfContactTally) {
        self.link_steps += o.link_steps;
        self.present += o.present;
        self.detected += o.detected;
        self.false_flags += o.false_flags;
        self.false_forces_touching += o.false_forces_touching;
    }
}

impl Observer<SimError> for MotionScorer {
    fn on_record(&mut self, view: &StepView<'_>, snap: &Snapshot) -> Result<(), SimError> {
        let est = &view.observation.contacts;
        let n = snap.link_position_m.len();
        if self.previous.len() != n {
            self.previous = vec![LinkSample::default(); n];
            self.previous_self = vec![false; n];
            self.previous_time_secs = f64::NAN;
        }
        let aligned = est.active && (view.observation.sensor_time_secs - self.previous_time_secs).abs() < 1e-9;
        if est.active && self.friction.last().is_none_or(|(t, _)| snap.time_secs >= t + 0.1 - 1e-9) {
            self.friction.push((snap.time_secs, est.floor_friction));
        }
        for i in 0..n {
            if aligned && i < est.n_links() {
                let mut sample = self.previous[i];
                sample.estimated_obstacle_n = est.obstacle_force_n[i];
                sample.detected = est.contact[i];
                sample.estimated_point_along_m = est.contact_point_along_m[i];
                self.score.add(&sample);
                let e = est.obstacle_force_n[i];
                self.self_tally.add(
                    self.previous_self[i],
                    est.self_contact[i],
                    sample.true_obstacle_n == [0.0; 3] && e[0].hypot(e[1]) > self.score.false_force_threshold_n,
                );
            }
            let axis3 = crate::state::x_axis(snap.link_quat[i]);
            let h = axis3[0].hypot(axis3[1]).max(1e-12);
            let c = snap.link_self_contact_force_n[i];
            self.previous_self[i] = c[0].hypot(c[1]) >= self.score.threshold_n;
            self.previous[i] = LinkSample {
                true_obstacle_n: snap.link_obstacle_force_n[i],
                true_point_along_m: snap.link_obstacle_point_m[i].map(|p| snap.along_link_axis_m(i, p)),
                axis: [axis3[0] / h, axis3[1] / h, 0.0],
                ..LinkSample::default()
            };
        }
        self.previous_time_secs = snap.time_secs;
        Ok(())
    }
}

/// Runs `config` (with `[estimation] enabled`) for `steps` steps and scores the in-loop
/// estimates against the truth at every instant (threshold: `estimation.detection_threshold_n`;
/// contact point scored where the true lateral force exceeds 1 N, tolerance 1 cm).
pub fn score_in_motion(config: &Config, steps: u64) -> Result<MotionScore, ExperimentError> {
    Ok(score_in_motion_with_friction(config, steps)?.0)
}

/// The floor's Coulomb coefficients (forward, backward, lateral) over time: (time, coefficients).
pub type FrictionSeries = Vec<(f64, [f64; 3])>;

/// [`score_in_motion`], and the floor's Coulomb coefficients (forward, backward, lateral) the
/// estimator used every 0.1 s (time, coefficients): `[ground]`'s, or with
/// `estimation.friction = "identify"` the identified ones.
pub fn score_in_motion_with_friction(
    config: &Config,
    steps: u64,
) -> Result<(MotionScore, FrictionSeries), ExperimentError> {
    let (score, friction, _) = score_in_motion_full(config, steps)?;
    Ok((score, friction))
}

/// [`score_in_motion_with_friction`] and the run's self-contacts ([`SelfContactTally`]).
pub fn score_in_motion_full(
    config: &Config,
    steps: u64,
) -> Result<(MotionScore, FrictionSeries, SelfContactTally), ExperimentError> {
    config.validate().map_err(|e| RunError::Sim(e.into()))?;
    let world = World::from_config(config).map_err(RunError::Sim)?;
    let mut sim = Simulation::new(config, world);
    let mut scorer = MotionScorer {
        score: MotionScore::for_targets(config),
        self_tally: SelfContactTally::default(),
        friction: Vec::new(),
        previous_time_secs: f64::NAN,
        previous: Vec::new(),
        previous_self: Vec::new(),
    };
    let plan = LoopPlan { steps, record_every_n_steps: 1 };
    sim.run(plan, &mut [&mut scorer, &mut crate::interrupt::Poll::new("an estimation case")]).map_err(RunError::Sim)?;
    Ok((scorer.score, scorer.friction, scorer.self_tally))
}

/// Relative error of identified coefficients against the true ones, over the coefficients the
/// ground model distinguishes (isotropic: μ; anisotropic: axial, lateral; directional: all three).
pub fn friction_relative_error(model: GroundModel, identified: [f64; 3], truth: [f64; 3]) -> f64 {
    let used: &[usize] = match model {
        GroundModel::Isotropic | GroundModel::Viscous => &[0],
        GroundModel::Anisotropic => &[0, 2],
        GroundModel::Directional => &[0, 1, 2],
    };
    used.iter().map(|&k| ((identified[k] - truth[k]) / truth[k]).abs()).fold(0.0, f64::max)
}

fn pct(x: f64) -> String {
    if x.is_nan() { "n/a".into() } else { format!("{:.1} %", 100.0 * x) }
}

/// The targets of one motion case: detection at least, false alarms at most, relative force
/// RMSE at most, contact points within 1 cm at least.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionTargets {
    pub detection: f64,
    pub false_alarms: f64,
    pub force_rmse: f64,
    pub points_within: f64,
}

/// The estimation targets with the default sensor noise and without.
pub const MOTION_TARGETS: MotionTargets =
    MotionTargets { detection: 0.95, false_alarms: 0.05, force_rmse: 0.15, points_within: 0.95 };
/// With twice the default noise: a graceful decline.
pub const MOTION_TARGETS_2X_NOISE: MotionTargets =
    MotionTargets { detection: 0.90, false_alarms: 0.10, force_rmse: 0.25, points_within: 0.80 };

impl MotionTargets {
    /// Which of the four figures of `s` miss their target: detection, false alarms, force RMSE,
    /// points (an undefined figure — no contact to score — is no miss).
    pub fn misses(&self, s: &MotionScore) -> [bool; 4] {
        [
            s.detection_rate() < self.detection,
            s.false_alarm_rate() > self.false_alarms,
            s.relative_force_rmse() > self.force_rmse,
            s.point_within_rate() < self.points_within,
        ]
    }
}

/// "3" / "300–309" (consecutive) / "1, 5, 9".
fn seed_list(seeds: &[u64]) -> String {
    match (seeds.first(), seeds.last()) {
        (Some(a), Some(b)) if seeds.len() > 2 && seeds.windows(2).all(|w| w[1] == w[0] + 1) => format!("{a}–{b}"),
        _ => seeds.iter().map(u64::to_string).collect::<Vec<_>>().join(", "),
    }
}

/// The peg-field runs' seeds: `--seeds`, or 0–9 (quick: 0).
fn motion_seeds(ctx: &Context) -> Vec<u64> {
    ctx.seeds.clone().unwrap_or_else(|| if ctx.quick { vec![0] } else { (0..10).collect() })
}

/// The motion section: ground models × noise levels × seeds, scored and checked per seed.
fn run_motion(ctx: &Context, base: &Config, section: &mut Section) -> Result<(), ExperimentError> {
    let duration_secs = if ctx.quick { 2.0 } else { 10.0 };
    let seeds = motion_seeds(ctx);
    let header: Vec<String> = [
        "floor",
        "noise",
        "seed",
        "obstacle link-steps",
        "detection",
        "false alarms",
        "force RMSE / RMS",
        "RMS obstacle force (N)",
        "points scored",
        "point within 1 cm",
        "mean point error (cm)",
        "free link-steps",
        "false force (> m·g)",
        "largest false force (N)",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let mut rows = Vec::new();
    let csv_path = ctx.folder.join("estimation_motion.csv");
    let mut csv = String::from(
        "floor,noise,seed,hits,misses,false_alarms,correct_rejections,error_sq_sum_n2,truth_sq_sum_n2,points,points_within,points_missing,point_error_sum_m,free_link_steps,false_forces,false_force_max_n,false_force_sq_sum_n2\n",
    );
    const FLOORS: [(&str, GroundModel); 2] =
        [("anisotropic", GroundModel::Anisotropic), ("isotropic", GroundModel::Isotropic)];
    const NOISES: [(&str, f64); 3] = [("off", 0.0), ("default", 1.0), ("2x default", 2.0)];
    let floors: Vec<usize> = (0..FLOORS.len()).filter(|&f| ctx.floor.is_none_or(|m| m == FLOORS[f].1)).collect();
    // Every run first, in parallel on the experiment's threads (each is independent); then the
    // tables in the fixed order floor × noise × seed, so the figures do not depend on the threads.
    // Per run: floor, noise scale (None: default noise with μ identified), seed.
    let mut runs: Vec<(usize, Option<usize>, u64)> = Vec::new();
    for &f in &floors {
        for n in 0..NOISES.len() {
            runs.extend(seeds.iter().map(|&seed| (f, Some(n), seed)));
        }
    }
    for &f in &floors {
        runs.extend(seeds.iter().map(|&seed| (f, None, seed)));
    }
    let results: Vec<(MotionScore, FrictionSeries)> = {
        use rayon::prelude::*;
        ctx.pool.install(|| {
            runs.par_iter()
                .map(|&(f, noise, seed)| {
                    let mut config = peg_field_config(base, FLOORS[f].1, seed, noise.map_or(1.0, |n| NOISES[n].1));
                    if noise.is_none() {
                        config.estimation.friction = crate::config::FloorFrictionSource::Identify;
                    }
                    let steps = (duration_secs / config.general.timestep_secs).round() as u64;
                    score_in_motion_with_friction(&config, steps)
                })
                .collect::<Result<_, _>>()
        })?
    };
    let result_of = |f: usize, noise: Option<usize>, seed: u64| -> &(MotionScore, FrictionSeries) {
        let k = runs.iter().position(|r| *r == (f, noise, seed)).expect("every run was made");
        &results[k]
    };
    // One case (floor × noise): a row per seed and the pooled row, every missed target marked;
    // the checks take each target's worst seed, so one missing seed fails the case.
    let mut case = |floor_name: &str, noise_name: &str, noise: Option<usize>, f: usize, targets: &MotionTargets| {
        let mut total: Option<MotionScore> = None;
        let per_seed: Vec<(u64, MotionScore)> =
            seeds.iter().map(|&seed| (seed, result_of(f, noise, seed).0.clone())).collect();
        for (seed, s) in &per_seed {
            csv.push_str(&format!(
                // The noise column is quoted: "default, μ identified" holds a comma.
                "{floor_name},\"{noise_name}\",{seed},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
                s.hits,
                s.misses,
                s.false_alarms,
                s.correct_rejections,
                s.error_sq_sum,
                s.truth_sq_sum,
                s.points,
                s.points_within,
                s.points_missing,
                s.point_error_sum_m,
                s.free_link_steps,
                s.false_forces,
                s.false_force_max_n,
                s.false_force_sq_sum
            ));
            rows.push(motion_row(floor_name, noise_name, &seed.to_string(), s, targets));
            match total.as_mut() {
                Some(t) => t.merge(s),
                None => total = Some(s.clone()),
            }
        }
        if let Some(t) = total {
            rows.push(motion_row(floor_name, noise_name, &format!("pooled ({})", seeds.len()), &t, targets));
        }
        let label = format!("motion, {floor_name} floor, noise {noise_name}");
        push_motion_checks(&mut section.checks, &label, &per_seed, targets);
    };
    for &f in &floors {
        let floor_name = FLOORS[f].0;
        for (n, &(noise_name, scale)) in NOISES.iter().enumerate() {
            let targets = if scale > 1.0 { &MOTION_TARGETS_2X_NOISE } else { &MOTION_TARGETS };
            case(floor_name, noise_name, Some(n), f, targets);
        }
        case(floor_name, "default, μ identified", None, f, &MOTION_TARGETS);
    }
    // The floor's friction identified online (default noise), against the known one.
    let mut friction_csv = String::from("floor,seed,time_s,mu_forward,mu_backward,mu_lateral\n");
    for &f in &floors {
        let (floor_name, model) = FLOORS[f];
        let (mut worst_end, mut worst_late) = (0.0f64, 0.0f64);
        // The first seed's coefficients over time and the true ones.
        let mut plot_series: Option<(u64, FrictionSeries, [f64; 3])> = None;
        for &seed in &seeds {
            let mut config = peg_field_config(base, model, seed, 1.0);
            config.estimation.friction = crate::config::FloorFrictionSource::Identify;
            let truth = crate::estimation::FloorShare::from_config(&config).coefficients();
            let friction = &result_of(f, None, seed).1;
            for (t, mu) in friction {
                friction_csv.push_str(&format!("{floor_name},{seed},{t},{},{},{}\n", mu[0], mu[1], mu[2]));
            }
            let end = friction.last().map_or(f64::NAN, |(_, mu)| friction_relative_error(model, *mu, truth));
            // The largest error over the run's second half: the identification has settled.
            let late = friction
                .iter()
                .filter(|(t, _)| *t >= 0.5 * duration_secs)
                .map(|(_, mu)| friction_relative_error(model, *mu, truth))
                .fold(0.0, f64::max);
            worst_end = worst_end.max(end);
            worst_late = worst_late.max(late);
            if plot_series.is_none() {
                plot_series = Some((seed, friction.clone(), truth));
            }
        }
        let label = format!("motion, {floor_name} floor, noise default, μ identified");
        section.checks.push(Check::at_most(
            &format!("{label}: identified μ at the end, largest relative error over seeds and coefficients"),
            worst_end,
            FRICTION_TOLERANCE,
            "",
        ));
        section.checks.push(Check::at_most(
            &format!("{label}: identified μ over the run's second half, largest relative error"),
            worst_late,
            FRICTION_TOLERANCE,
            "",
        ));
        if let Some((seed, friction, truth)) = plot_series {
            let time: Vec<f64> = friction.iter().map(|(t, _)| *t).collect();
            let mu: Vec<[f64; 3]> = friction.iter().map(|(_, mu)| *mu).collect();
            let plots = ctx.folder.join("plots");
            std::fs::create_dir_all(&plots).map_err(io(&plots))?;
            let mut series = Vec::new();
            let names: &[(usize, &str)] = match model {
                GroundModel::Anisotropic => &[(0, "axial"), (2, "lateral")],
                _ => &[(0, "μ")],
            };
            for &(k, name) in names {
                series.push((format!("identified {name}"), mu.iter().map(|m| m[k]).collect::<Vec<_>>()));
                series.push((format!("true {name}"), vec![truth[k]; time.len()]));
            }
            crate::plot::plot_time_series(
                &plots,
                &format!("estimation_friction_{floor_name}"),
                &format!("identified floor friction, {floor_name} floor, seed {seed}"),
                "Coulomb coefficient",
                &time,
                &series,
            )
            .map_err(|e| ExperimentError::Data(format!("plot: {e}")))?;
        }
    }
    let friction_path = ctx.folder.join("estimation_mu_identified.csv");
    std::fs::write(&friction_path, friction_csv).map_err(io(&friction_path))?;
    std::fs::write(&csv_path, csv).map_err(io(&csv_path))?;
    section.tables.push((header, rows));
    Ok(())
}

/// The wide wave of the self-contact case: amplitude (degrees), phase lag between joints
/// (degrees), frequency (Hz). On the default position servos it folds the 10-link body onto
/// itself (links i and i + 2 or i + 3 touch).
pub const WIDE_WAVE_DEG_DEG_HZ: (f64, f64, f64) = (80.0, 30.0, 0.5);

/// The self-contact scene on top of `base`: the peg-field scene ([`peg_field_config`]) without
/// pegs (a bare floor of the given ground model), the wide wave [`WIDE_WAVE_DEG_DEG_HZ`] on the
/// default position servos, the default sensor noise, and self-contacts separated or not
/// (`estimation.self_contacts`).
pub fn self_contact_config(base: &Config, ground: GroundModel, seed: u64, separate: bool) -> Config {
    let mut c = peg_field_config(base, ground, seed, 1.0);
    c.terrain.pegboard.layout = crate::config::PegLayout::None;
    let w = &mut c.gait.sine_wave;
    (w.amplitude_deg, w.phase_lag_deg, w.frequency_hz) = WIDE_WAVE_DEG_DEG_HZ;
    w.offset_deg = 0.0;
    c.estimation.self_contacts = separate;
    c
}

/// The self-contact section: the wide wave on a bare floor, per floor and seed, with the
/// estimator's self-contact separation on and off; checks on the separated runs' worst seed.
fn run_self_contacts(ctx: &Context, base: &Config, section: &mut Section) -> Result<(), ExperimentError> {
    let duration_secs = if ctx.quick { 2.0 } else { 10.0 };
    let seeds = motion_seeds(ctx);
    const FLOORS: [(&str, GroundModel); 2] =
        [("anisotropic", GroundModel::Anisotropic), ("isotropic", GroundModel::Isotropic)];
    let floors: Vec<usize> = (0..FLOORS.len()).filter(|&f| ctx.floor.is_none_or(|m| m == FLOORS[f].1)).collect();
    let mut runs: Vec<(usize, bool, u64)> = Vec::new();
    for &f in &floors {
        for separate in [true, false] {
            runs.extend(seeds.iter().map(|&seed| (f, separate, seed)));
        }
    }
    let results: Vec<(MotionScore, SelfContactTally)> = {
        use rayon::prelude::*;
        ctx.pool.install(|| {
            runs.par_iter()
                .map(|&(f, separate, seed)| {
                    let config = self_contact_config(base, FLOORS[f].1, seed, separate);
                    let steps = (duration_secs / config.general.timestep_secs).round() as u64;
                    score_in_motion_full(&config, steps).map(|(score, _, tally)| (score, tally))
                })
                .collect::<Result<_, _>>()
        })?
    };
    let header: Vec<String> = [
        "floor",
        "self-contacts",
        "seed",
        "link-steps touching another link",
        "of them flagged self-contact",
        "self-contact flags without one",
        "obstacle false alarms",
        "false force (> m·g)",
        "of the false forces on touching links",
        "largest false force (N)",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let mut rows = Vec::new();
    let mut csv = String::from(
        "floor,self_contacts,seed,link_steps,self_present,self_detected,self_false_flags,false_alarms,correct_rejections,free_link_steps,false_forces,false_forces_touching,false_force_max_n\n",
    );
    let row = |floor: &str, separate: bool, seed: &str, s: &MotionScore, t: &SelfContactTally| {
        vec![
            floor.to_string(),
            if separate { "separated" } else { "not separated" }.to_string(),
            seed.to_string(),
            pct(t.present as f64 / t.link_steps as f64),
            pct(t.detected as f64 / t.present as f64),
            t.false_flags.to_string(),
            pct(s.false_alarm_rate()),
            format!("{} ({})", pct(s.false_force_rate()), s.false_forces),
            pct(t.false_forces_touching as f64 / s.false_forces as f64),
            sig(s.false_force_max_n),
        ]
    };
    for &f in &floors {
        let floor_name = FLOORS[f].0;
        for separate in [true, false] {
            let mut pooled: Option<(MotionScore, SelfContactTally)> = None;
            let mut per_seed = Vec::new();
            for &seed in &seeds {
                let k = runs.iter().position(|r| *r == (f, separate, seed)).expect("every run was made");
                let (s, t) = &results[k];
                csv.push_str(&format!(
                    "{floor_name},{separate},{seed},{},{},{},{},{},{},{},{},{},{}\n",
                    t.link_steps,
                    t.present,
                    t.detected,
                    t.false_flags,
                    s.false_alarms,
                    s.correct_rejections,
                    s.free_link_steps,
                    s.false_forces,
                    t.false_forces_touching,
                    s.false_force_max_n
                ));
                rows.push(row(floor_name, separate, &seed.to_string(), s, t));
                match pooled.as_mut() {
                    Some((ps, pt)) => {
                        ps.merge(s);
                        pt.merge(t);
                    }
                    None => pooled = Some((s.clone(), *t)),
                }
                per_seed.push((seed, s.clone(), *t));
            }
            if let Some((s, t)) = pooled {
                rows.push(row(floor_name, separate, &format!("pooled ({})", seeds.len()), &s, &t));
            }
            if !separate {
                continue;
            }
            let label = format!("self-contact, {floor_name} bare floor, wide wave");
            let worst = |value: &dyn Fn(&MotionScore, &SelfContactTally) -> f64, high_is_bad: bool| {
                per_seed.iter().map(|(seed, s, t)| (*seed, value(s, t))).filter(|(_, v)| !v.is_nan()).fold(
                    (None, f64::NAN),
                    |acc: (Option<u64>, f64), (seed, v)| {
                        let worse = acc.0.is_none() || if high_is_bad { v > acc.1 } else { v < acc.1 };
                        if worse { (Some(seed), v) } else { acc }
                    },
                )
            };
            let n = per_seed.len();
            let name = |what: &str, seed: Option<u64>| match seed {
                Some(s) => format!("{label}: {what}, worst of {n} seeds (seed {s})"),
                None => format!("{label}: {what}, no seed had any to score"),
            };
            let (seed, v) = worst(&|s, _| s.false_force_rate(), true);
            section.checks.push(Check::at_most(
                &name("obstacle false force (> m·g, of free link-steps)", seed),
                v,
                MOTION_TARGETS.false_alarms,
                "",
            ));
            let (seed, v) = worst(&|s, _| s.false_alarm_rate(), true);
            section.checks.push(Check::at_most(
                &name("obstacle false alarms (of free link-steps)", seed),
                v,
                MOTION_TARGETS.false_alarms,
                "",
            ));
            let (seed, v) = worst(&|_, t| t.detected as f64 / t.present as f64, false);
            section.checks.push(Check::at_least(
                &name("self-contacts flagged (of link-steps another link pushes)", seed),
                v,
                SELF_CONTACT_DETECTION,
                "",
            ));
        }
    }
    let path = ctx.folder.join("estimation_self_contact.csv");
    std::fs::write(&path, csv).map_err(io(&path))?;
    section.tables.push((header, rows));
    let (a, lag, f) = WIDE_WAVE_DEG_DEG_HZ;
    section.text.push_str(&format!(
        "\n\nSelf-contact: the same {MOTION_LINKS}-link snake on a bare floor (no pegs) with a wide wave \
         (A = {a}°, δ = {lag}°, {f} Hz) on the default position servos, which folds the body onto itself; default \
         sensor noise, {duration_secs} s per run, seeds {}, the estimator with self-contacts separated \
         (`estimation.self_contacts = true`, the default) and, for comparison, without (every force beyond the \
         floor's an obstacle's). No obstacle exists, so every obstacle flag is a false alarm and every obstacle \
         force a false force. Targets on the separated runs' worst seed: false force and false alarms ≤ {} %, \
         self-contacts flagged on ≥ {} % of the link-steps another link pushes with at least the detection \
         threshold. Data: `estimation_self_contact.csv`.",
        seed_list(&seeds),
        100.0 * MOTION_TARGETS.false_alarms,
        100.0 * SELF_CONTACT_DETECTION,
    ));
    Ok(())
}

/// Self-contact case: the share of link-steps another link pushes (at least the detection
/// threshold) that the estimator must flag as self-contact.
pub const SELF_CONTACT_DETECTION: f64 = 0.8;

/// Largest relative error of the identified floor friction that the experiment accepts.
pub const FRICTION_TOLERANCE: f64 = 0.10;

/// One row of the motion table: floor, noise, seed (or "pooled"), then the score's figures, a
/// missed target marked "MISS".
fn motion_row(floor_name: &str, noise_name: &str, seed: &str, t: &MotionScore, targets: &MotionTargets) -> Vec<String> {
    let miss = targets.misses(t);
    let mark = |text: String, missed: bool| if missed { format!("{text} MISS") } else { text };
    vec![
        floor_name.to_string(),
        noise_name.to_string(),
        seed.to_string(),
        (t.hits + t.misses).to_string(),
        mark(pct(t.detection_rate()), miss[0]),
        mark(pct(t.false_alarm_rate()), miss[1]),
        mark(pct(t.relative_force_rmse()), miss[2]),
        sig(t.truth_rms_n()),
        t.points.to_string(),
        mark(pct(t.point_within_rate()), miss[3]),
        sig(100.0 * t.mean_point_error_m()),
        t.free_link_steps.to_string(),
        format!("{} ({})", pct(t.false_force_rate()), t.false_forces),
        sig(t.false_force_max_n),
    ]
}

/// The four checks of one motion case against its targets, each on its worst seed (a seed
/// without contacts to score is left out of that figure; with none at all the check fails).
fn push_motion_checks(checks: &mut Vec<Check>, label: &str, per_seed: &[(u64, MotionScore)], t: &MotionTargets) {
    // (seed, value) of the worst seed for a figure, higher = worse when `high_is_bad`.
    let worst = |value: fn(&MotionScore) -> f64, high_is_bad: bool| -> (Option<u64>, f64) {
        let mut out = (None, f64::NAN);
        for (seed, s) in per_seed {
            let v = value(s);
            if v.is_nan() {
                continue;
            }
            let worse = out.0.is_none() || if high_is_bad { v > out.1 } else { v < out.1 };
            if worse {
                out = (Some(*seed), v);
            }
        }
        out
    };
    let n = per_seed.len();
    let name = |what: &str, seed: Option<u64>| match seed {
        Some(s) => format!("{label}: {what}, worst of {n} seeds (seed {s})"),
        None => format!("{label}: {what}, no seed had any to score"),
    };
    let (s, v) = worst(MotionScore::detection_rate, false);
    checks.push(Check::at_least(&name("obstacle contacts detected (of present link-steps)", s), v, t.detection, ""));
    let (s, v) = worst(MotionScore::false_alarm_rate, true);
    checks.push(Check::at_most(&name("false alarms (of free link-steps)", s), v, t.false_alarms, ""));
    let (s, v) = worst(MotionScore::relative_force_rmse, true);
    checks.push(Check::at_most(&name("obstacle-force RMSE / RMS obstacle force", s), v, t.force_rmse, ""));
    let (s, v) = worst(MotionScore::point_within_rate, false);
    checks.push(Check::at_least(&name("contact points within 1 cm (lateral force > 1 N)", s), v, t.points_within, ""));
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A static trace of two links: link 0 pushed by a peg (true obstacle force 1 N), its
    /// horizontal external force 1.6 N on a normal force of 3 N; link 1 free. The estimate is the
    /// exact one plus ±0.1 N alternating along x.
    fn pinch_trace(steps: usize) -> Trace {
        let mut t = Trace::default();
        for k in 0..steps {
            let noise = if k % 2 == 0 { 0.1 } else { -0.1 };
            let total = vec![[1.6, 0.0, 3.0], [0.5, 0.0, 3.0]];
            t.time_s.push(k as f64 * 0.001);
            t.truth_obstacle_n.push(vec![[1.0, 0.0, 0.0], [0.0; 3]]);
            t.exact_estimate_n.push(total.clone());
            t.estimate_n.push(total.iter().map(|f| [f[0] + noise, f[1], f[2]]).collect());
            t.truth_total_n.push(total);
        }
        t
    }

    #[test]
    fn static_friction_margin_is_the_excess_over_mu_n_where_a_peg_pushes() {
        let t = pinch_trace(10);
        // μ = 0.5: excess 1.6 − 1.5 = 0.1 N on the pushed link only; noise rms 0.1 N.
        let note = static_friction_margin(&t, 0.5, 0.8);
        assert!(note.contains("by 0.1000 N"), "{note}");
        assert!(note.contains("is 0.1000 N per step"), "{note}");
        assert!(note.contains("not observable"), "{note}");
        // With μ = 0.1 the excess (1.3 N) clears the threshold: no claim that it is hidden.
        let note = static_friction_margin(&t, 0.1, 0.8);
        assert!(note.contains("by 1.300 N"), "{note}");
        assert!(!note.contains("not observable"), "{note}");
    }

    #[test]
    fn a_flag_is_scored_against_the_instant_its_sensors_describe() {
        // The step loop's flag at record k comes from the sensors of instant k − 1: a push at
        // instants 3 and 4 flagged at records 4 and 5 is two hits, not a miss and a hit.
        let mut t = pinch_trace(8);
        for (k, row) in t.truth_obstacle_n.iter_mut().enumerate() {
            row[0] = if k == 3 || k == 4 { [1.0, 0.0, 0.0] } else { [0.0; 3] };
        }
        t.contact_flag = (0..8).map(|k| vec![k == 4 || k == 5, false]).collect();
        t.contact_flag_time_s = (0..8).map(|k| t.time_s[k.max(1) - 1]).collect();
        let d = detection(&t, 0, 0.0, 0.0);
        assert_eq!((d.hits, d.misses, d.false_alarms), (2, 0, 0));
        // The last instant has no flag that describes it: not scored.
        assert!(t.aligned_contact_flags()[7].is_none());
    }

    #[test]
    fn a_push_below_static_friction_is_not_observable_and_not_a_miss() {
        // The pushed link's horizontal external force (1.6 N) exceeds μ·N (1.5 N at μ 0.5) by
        // 0.1 N: with the in-loop threshold 0.8 N it is hidden, not missed; at μ 0.1 (excess
        // 1.3 N) it is observable, and an unflagged push is a miss.
        let mut t = pinch_trace(10);
        t.contact_flag = vec![vec![false, false]; 10];
        t.contact_flag_time_s = t.time_s.clone();
        let d = detection(&t, 0, 0.5, 0.8);
        assert_eq!((d.hits, d.misses, d.hidden), (0, 0, 10));
        assert!((d.hidden_excess_sum_n / 10.0 - 0.1).abs() < 1e-9);
        let d = detection(&t, 0, 0.1, 0.8);
        assert_eq!((d.hits, d.misses, d.hidden), (0, 10, 0));
        // Without friction every push is observable.
        assert_eq!(detection(&t, 0, 0.0, 0.0).misses, 10);
        // No pushed link: nothing to say.
        let mut free = t.clone();
        for row in &mut free.truth_obstacle_n {
            row[0] = [0.0; 3];
        }
        assert!(static_friction_margin(&free, 0.5, 0.8).is_empty());
    }
}
