//! Experiment `hoal`: obstacle-aided locomotion with force feedback.
//!
//! A 10-link snake on SimSerpent's stick–slip floor with *isotropic* Coulomb friction (where
//! lateral undulation barely moves on a bare floor) among random peg fields of three densities,
//! several seeds each. On every field:
//!
//! - each closed-loop controller of [`CLOSED_LOOP`] (`control::ObstacleAided`, the wave with
//!   hybrid position/force feedback; `control::Rail`, the floor-drift wave switching to
//!   follow-the-leader on the contact estimates) with its own default
//!   settings, fed the contact estimates of the step loop (measured sensors, default noise);
//! - the same controllers fed the simulator's true contacts, and with their contact terms off;
//! - the open-loop sine wave for every amplitude × phase lag of a sweep (same frequency, same
//!   duration, same fields); per density the wave with the highest median speed is "the best
//!   open-loop gait". The sweep has waves running toward the tail (δ > 0, ordinary lateral
//!   undulation) and toward the head (δ < 0): on an isotropic floor a snake drifts the way its
//!   wave runs, so the waves running toward the head are the open loop's best forward gaits;
//! - the best open-loop wave of each density again on as many fields it was not chosen on (the
//!   best of many medians over few fields overstates a wave: these runs show by how much);
//! - every wave of the sweep and every closed loop (estimated contacts) once on the bare floor,
//!   without pegs, to show what the pegs add to or take from each gait.
//!
//! Forward speed: the centre of mass's advance along +x (the snake starts straight along +x,
//! the field lies ahead of and around it) from the end of the ramp-in to the end, per second.
//! A run jams when for 5 s its centre of mass gets no more than 2 cm beyond the farthest point
//! it had reached (after the ramp-in).
//!
//! The runs among pegs are chaotic (a last-bit change of a controller's targets moves single
//! fields by tens of mm/s), so the table gives, beside the closed loop's and the best open
//! loop's medians, a 90 % bootstrap interval of the median over the fields ([`median_interval`]).
//!
//! The runs are in memory (no run folders): each records its centre of mass every 50 steps
//! and, for the estimated-contact runs, the estimated and true obstacle forces.

use super::report::{Check, Section, sig};
use super::{Context, ExperimentError};
use crate::config::{Config, ContactSource, ControllerKind, GaitKind, GroundModel};
use crate::run::RunError;
use crate::sim::{LoopPlan, Observer, SimError, Simulation, StepView, World};
use crate::state::Snapshot;
use std::path::Path;

/// Peg densities (name, pegs per m²).
pub const DENSITIES: [(&str, f64); 3] = [("sparse", 1.5), ("medium", 3.0), ("dense", 4.5)];
/// The reference field without pegs (the bare floor): `Case::density` past `DENSITIES`. Every
/// open-loop wave and every closed loop (estimated contacts) runs on it once, so the report
/// shows what the pegs add to (or take from) each gait.
const BARE: usize = DENSITIES.len();

/// Pegs per m² of `Case::density` (0 for `BARE`).
fn pegs_per_m2(density: usize) -> f64 {
    DENSITIES.get(density).map_or(0.0, |d| d.1)
}
/// The field: peg centres in this rectangle (m), at least `SPACING_M` apart.
const REGION_MIN_M: [f64; 2] = [-2.2, -1.0];
const REGION_MAX_M: [f64; 2] = [4.0, 1.0];
const SPACING_M: f64 = 0.3;
/// The open-loop sweep, amplitude up to 80° (the joints reach ±90°).
/// (Why these twelve: in wider sweeps amplitudes of 20–35° and lags of ±90° and +60° were never
/// best, on the bare floor 65°–80° with δ = −45° drift fastest (69–71 mm/s), and on 120 fields
/// outside hoal's seeds every δ = −30° wave runs backward (medians −1 to −34 mm/s, 98–106 jams of
/// 120) while δ = −75° jams least (65°/−75°: 31 mm/s, 2 jams of 120; the `obstacle_aided`
/// default).)
const AMPLITUDES_DEG: [f64; 3] = [50.0, 65.0, 80.0];
const PHASE_LAGS_DEG: [f64; 4] = [-75.0, -60.0, -45.0, 30.0];
/// The closed-loop controllers compared (config value, name).
pub const CLOSED_LOOP: [(ControllerKind, &str); 2] =
    [(ControllerKind::ObstacleAided, "obstacle_aided"), (ControllerKind::Rail, "rail")];
/// Position servos of every run (as in the `oal` experiment: the default 5 N·m/rad and ±3 N·m
/// cannot press the body on a peg harder than a few newtons).
const SERVO_KP_NM_PER_RAD: f64 = 20.0;
const SERVO_KV_NM_S_PER_RAD: f64 = 0.2;
const TORQUE_LIMIT_NM: f64 = 10.0;
/// Every run: frequency (Hz).
const FREQUENCY_HZ: f64 = 0.5;
/// Record every this many steps.
pub const RECORD_EVERY: u64 = 50;
/// The jam definition: less than this progress within this window.
const JAM_WINDOW_SECS: f64 = 5.0;
const JAM_PROGRESS_M: f64 = 0.02;
/// The least median speed that counts as advancing (mm/s).
const MIN_SPEED_MM_PER_S: f64 = 1.0;

/// What a case runs.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Variant {
    /// The closed-loop controller `CLOSED_LOOP[k]` with the given contacts.
    Closed(usize, ContactSource),
    /// The closed-loop controller `CLOSED_LOOP[k]` with its contact terms switched off
    /// (`obstacle_aided.contact_feedback = false`, `rail.use_contacts = false`): what the
    /// contacts add.
    Blind(usize),
    /// The open-loop sine wave (amplitude, phase lag; degrees).
    Open(f64, f64),
}

/// One case: field (density index, seed) and variant.
#[derive(Debug, Clone, Copy)]
struct Case {
    density: usize,
    seed: u64,
    variant: Variant,
}

/// What a run recorded.
#[derive(Debug, Clone, Default)]
struct Trace {
    time_secs: Vec<f64>,
    com_m: Vec<[f64; 2]>,
    /// Sum over the links of the horizontal obstacle force magnitude (N): estimated, true.
    estimated_n: Vec<f64>,
    true_n: Vec<f64>,
    forces: bool,
}

impl Observer<SimError> for Trace {
    fn on_record(&mut self, view: &StepView<'_>, snap: &Snapshot) -> Result<(), SimError> {
        let com = snap.centre_of_mass_m();
        self.time_secs.push(snap.time_secs);
        self.com_m.push([com[0], com[1]]);
        if self.forces {
            let est = &view.observation.contacts;
            let estimated: f64 =
                if est.active { est.obstacle_force_n.iter().map(|f| f[0].hypot(f[1])).sum() } else { 0.0 };
            let truth: f64 = snap.link_obstacle_force_n.iter().map(|f| f[0].hypot(f[1])).sum();
            self.estimated_n.push(estimated);
            self.true_n.push(truth);
        }
        Ok(())
    }
}

/// The run's forward speed (m/s along +x, [`forward_speed_m_per_s`]) and whether it jammed
/// ([`path_jammed`]), after `from_secs`.
fn speed_and_jam(trace: &Trace, from_secs: f64) -> (f64, bool) {
    let path = trace.path();
    (forward_speed_m_per_s(&path, from_secs), path_jammed(&path, from_secs))
}

impl Trace {
    /// The centre of mass's path along x: (time (s), x (m)) per recorded sample.
    fn path(&self) -> Vec<(f64, f64)> {
        self.time_secs.iter().zip(&self.com_m).map(|(t, c)| (*t, c[0])).collect()
    }
}

/// hoal's forward speed (m/s along +x) of a centre-of-mass path of (time (s), x (m)) samples:
/// its advance from the first sample at or after `from_secs` to the last, per second.
pub fn forward_speed_m_per_s(path: &[(f64, f64)], from_secs: f64) -> f64 {
    let start = path.iter().position(|s| s.0 >= from_secs - 1e-9).unwrap_or(0);
    let end = path.len().saturating_sub(1);
    let span = path[end].0 - path[start].0;
    if span <= 0.0 { 0.0 } else { (path[end].1 - path[start].1) / span }
}

/// hoal's jam rule on a path of (time (s), x (m)) samples: after `from_secs`, a window of
/// `JAM_WINDOW_SECS` in which the farthest forward position reached grows by less than
/// `JAM_PROGRESS_M`.
pub fn path_jammed(path: &[(f64, f64)], from_secs: f64) -> bool {
    let start = path.iter().position(|s| s.0 >= from_secs - 1e-9).unwrap_or(0);
    let mut best = Vec::with_capacity(path.len());
    let mut b = f64::NEG_INFINITY;
    for s in path {
        b = b.max(s.1);
        best.push(b);
    }
    let mut later = start;
    for i in start..path.len() {
        while later < path.len() && path[later].0 < path[i].0 + JAM_WINDOW_SECS - 1e-9 {
            later += 1;
        }
        if later >= path.len() {
            break;
        }
        if best[later] - best[i] < JAM_PROGRESS_M {
            return true;
        }
    }
    false
}

/// The field of `density` pegs per m² and `seed` on top of `base`: the estimation experiment's
/// peg-field scene (10 links, default sine wave, default noise, estimation on) with the
/// isotropic floor and this experiment's region and spacing.
pub fn field_config(base: &Config, density: f64, seed: u64) -> Config {
    let mut c = super::estimation::peg_field_config(base, GroundModel::Isotropic, seed, 1.0);
    let area = (REGION_MAX_M[0] - REGION_MIN_M[0]) * (REGION_MAX_M[1] - REGION_MIN_M[1]);
    c.terrain.pegboard.region_min_m = REGION_MIN_M;
    c.terrain.pegboard.region_max_m = REGION_MAX_M;
    c.terrain.pegboard.spacing_m = SPACING_M;
    c.terrain.pegboard.count = (density * area).round() as usize;
    c.gait.kind = GaitKind::SineWave;
    c.gait.sine_wave.frequency_hz = FREQUENCY_HZ;
    c.gait.sine_wave.offset_deg = 0.0;
    c.control.position_kp_nm_per_rad = SERVO_KP_NM_PER_RAD;
    c.control.position_kv_nm_s_per_rad = SERVO_KV_NM_S_PER_RAD;
    c.snake.torque_range_nm = [-TORQUE_LIMIT_NM, TORQUE_LIMIT_NM];
    c
}

/// The config of `case`: closed-loop controllers with their own default settings.
fn case_config(base: &Config, case: &Case, duration_secs: f64) -> Config {
    let mut c = field_config(base, pegs_per_m2(case.density), case.seed);
    c.general.duration_secs = duration_secs;
    match case.variant {
        Variant::Closed(k, source) => {
            c.control.controller = CLOSED_LOOP[k].0;
            c.obstacle_aided.contacts = source;
            c.rail.contacts = source;
            // The true-contact runs need no estimator.
            c.estimation.enabled = source == ContactSource::Estimated;
        }
        Variant::Blind(k) => {
            c.control.controller = CLOSED_LOOP[k].0;
            c.obstacle_aided.contact_feedback = false;
            c.rail.use_contacts = false;
            // The same run as with estimated contacts but for the switch.
            c.obstacle_aided.contacts = ContactSource::Estimated;
            c.rail.contacts = ContactSource::Estimated;
            c.estimation.enabled = true;
        }
        Variant::Open(amplitude, lag) => {
            c.control.controller = ControllerKind::Gait;
            c.gait.sine_wave.amplitude_deg = amplitude;
            c.gait.sine_wave.phase_lag_deg = lag;
            c.estimation.enabled = false;
        }
    }
    c
}

/// Runs one case in memory.
fn run_case(config: &Config, forces: bool) -> Result<Trace, ExperimentError> {
    crate::interrupt::check(|| "before a hoal case".into()).map_err(RunError::Sim)?;
    config.validate().map_err(|e| RunError::Sim(e.into()))?;
    let world = World::from_config(config).map_err(RunError::Sim)?;
    let mut sim = Simulation::new(config, world);
    let steps = (config.general.duration_secs / config.general.timestep_secs).round() as u64;
    let capacity = (steps / RECORD_EVERY + 2) as usize;
    let mut trace = Trace {
        time_secs: Vec::with_capacity(capacity),
        com_m: Vec::with_capacity(capacity),
        estimated_n: Vec::with_capacity(if forces { capacity } else { 0 }),
        true_n: Vec::with_capacity(if forces { capacity } else { 0 }),
        forces,
    };
    let mut poll = crate::interrupt::Poll::new("a hoal case");
    sim.run(LoopPlan { steps, record_every_n_steps: RECORD_EVERY }, &mut [&mut trace, &mut poll])
        .map_err(RunError::Sim)?;
    Ok(trace)
}

/// One run of `config` (a [`field_config`] with a controller) as the experiment scores it: the
/// forward speed (m/s along +x after the ramp-in) and whether it jammed. For tuning tools that
/// score controllers on the experiment's fields.
pub fn score_run(config: &Config) -> Result<(f64, bool), ExperimentError> {
    let trace = run_case(config, false)?;
    let ramp_secs = config.gait.ramp_secs;
    Ok(speed_and_jam(&trace, ramp_secs))
}

/// The median of the finite values (NaN when there is none): hoal's medians, shared with the
/// tools that score its fields (`tools/hoal_eval.rs`, `tools/hoal_oracle.rs`).
pub fn median(values: &[f64]) -> f64 {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    if v.len() % 2 == 1 { v[m] } else { 0.5 * (v[m - 1] + v[m]) }
}

/// Resamples of [`median_interval`].
const BOOTSTRAP_RESAMPLES: usize = 2000;

/// A 90 % percentile-bootstrap interval of the median of `values` (the 5th and 95th percentiles
/// of the medians of `BOOTSTRAP_RESAMPLES` resamples drawn with replacement): where the median
/// of as many other fields would probably fall. The resamples come from a fixed-seed SplitMix64
/// stream, so the same values give the same interval. NaN for no finite values.
fn median_interval(values: &[f64]) -> (f64, f64) {
    let v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    let mut state: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut next = || {
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    };
    let mut sample = vec![0.0; v.len()];
    let mut medians: Vec<f64> = (0..BOOTSTRAP_RESAMPLES)
        .map(|_| {
            for x in sample.iter_mut() {
                *x = v[(next() % v.len() as u64) as usize];
            }
            median(&sample)
        })
        .collect();
    medians.sort_by(f64::total_cmp);
    let at = |q: f64| medians[((q * (BOOTSTRAP_RESAMPLES - 1) as f64).round() as usize).min(BOOTSTRAP_RESAMPLES - 1)];
    (at(0.05), at(0.95))
}

/// A median and its 90 % bootstrap interval, in mm/s from m/s: "47.5 (31.0–52.1)".
fn median_with_interval(values_m_per_s: &[f64]) -> String {
    let (lo, hi) = median_interval(values_m_per_s);
    format!("{} ({}–{})", sig(1000.0 * median(values_m_per_s)), sig(1000.0 * lo), sig(1000.0 * hi))
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> ExperimentError + '_ {
    move |source| ExperimentError::Io { what: "write", path: path.to_path_buf(), source }
}

fn plot_error(e: crate::plot::PlotError) -> ExperimentError {
    ExperimentError::Data(format!("plot: {e}"))
}

/// The experiment.
pub fn run(ctx: &Context, base: &Config) -> Result<Section, ExperimentError> {
    use rayon::prelude::*;
    let (duration_secs, seeds) = if ctx.quick { (10.0, 2u64) } else { (15.0, 10u64) };
    let ramp_secs = field_config(base, 1.0, 0).gait.ramp_secs;
    let mut sweep = Vec::new();
    for a in AMPLITUDES_DEG {
        for d in PHASE_LAGS_DEG {
            sweep.push(Variant::Open(a, d));
        }
    }
    let mut variants = sweep.clone();
    for k in 0..CLOSED_LOOP.len() {
        variants.push(Variant::Closed(k, ContactSource::Estimated));
        variants.push(Variant::Closed(k, ContactSource::True));
        variants.push(Variant::Blind(k));
    }
    let mut cases = Vec::new();
    for density in 0..DENSITIES.len() {
        for seed in 0..seeds {
            for &variant in &variants {
                cases.push(Case { density, seed, variant });
            }
        }
    }
    // The bare floor: the sweep and the closed loops with estimated contacts, once each.
    for &variant in
        variants.iter().filter(|v| matches!(v, Variant::Open(..) | Variant::Closed(_, ContactSource::Estimated)))
    {
        cases.push(Case { density: BARE, seed: 0, variant });
    }
    let total = cases.len();
    let done = std::sync::atomic::AtomicUsize::new(0);
    let traces: Vec<Result<Trace, ExperimentError>> = ctx.pool.install(|| {
        cases
            .par_iter()
            .map(|case| {
                crate::interrupt::check(|| "before a hoal case".into()).map_err(RunError::Sim)?;
                let forces = matches!(case.variant, Variant::Closed(_, ContactSource::Estimated));
                let result = run_case(&case_config(base, case, duration_secs), forces);
                let n = done.fetch_add(1, std::sync::atomic::Ordering::SeqCst) + 1;
                if ctx.progress && (n.is_multiple_of(20) || n == total) {
                    eprintln!("experiment {}: {n} of {total} runs done", ctx.name);
                }
                result
            })
            .collect()
    });
    let traces: Vec<Trace> = traces.into_iter().collect::<Result<_, _>>()?;
    let (speed, jam): (Vec<f64>, Vec<bool>) = traces.iter().map(|t| speed_and_jam(t, ramp_secs)).unzip();
    let index = |density: usize, seed: u64, variant: Variant| {
        cases.iter().position(|c| c.density == density && c.seed == seed && c.variant == variant)
    };
    // (The bare floor has seed 0 only: the other seeds find no case.)
    let speeds_of = |d: usize, variant: Variant| -> Vec<f64> {
        (0..seeds).filter_map(|s| index(d, s, variant)).map(|k| speed[k]).collect()
    };
    let jams_of =
        |d: usize, variant: Variant| (0..seeds).filter_map(|s| index(d, s, variant)).filter(|k| jam[*k]).count();

    // The best open-loop wave per density.
    let mut best = [(Variant::Open(0.0, 0.0), f64::NEG_INFINITY); DENSITIES.len()];
    let mut sweep_rows = Vec::new();
    for (d, (dname, _)) in DENSITIES.iter().enumerate() {
        for &v in &sweep {
            let m = median(&speeds_of(d, v));
            if let Variant::Open(a, l) = v {
                sweep_rows.push(vec![
                    dname.to_string(),
                    sig(a),
                    sig(l),
                    sig(1000.0 * m),
                    format!("{} of {seeds}", jams_of(d, v)),
                    sig(1000.0 * median(&speeds_of(BARE, v))),
                ]);
            }
            if m > best[d].1 {
                best[d] = (v, m);
            }
        }
    }

    // The best wave again, on fields the sweep did not choose it on (seeds `seeds..2·seeds`): the
    // best of many medians over few fields overstates the wave (selection), and these fields
    // show by how much.
    let held_out: Vec<Case> = (0..DENSITIES.len())
        .flat_map(|density| (seeds..2 * seeds).map(move |seed| Case { density, seed, variant: best[density].0 }))
        .collect();
    let held_out_runs: Vec<(f64, bool)> = ctx.pool.install(|| {
        held_out
            .par_iter()
            .map(|case| {
                crate::interrupt::check(|| "before a hoal case".into()).map_err(RunError::Sim)?;
                let t = run_case(&case_config(base, case, duration_secs), false)?;
                Ok(speed_and_jam(&t, ramp_secs))
            })
            .collect::<Result<_, ExperimentError>>()
    })?;
    let held_out_of = |d: usize| -> Vec<(f64, bool)> {
        held_out.iter().zip(&held_out_runs).filter(|(c, _)| c.density == d).map(|(_, r)| *r).collect()
    };

    // Per-run table.
    let csv_path = ctx.folder.join("hoal_runs.csv");
    let mut csv = String::from(
        "density,pegs_per_m2,seed,controller,contacts,amplitude_deg,phase_lag_deg,forward_speed_m_per_s,jammed\n",
    );
    for (k, case) in cases.iter().enumerate() {
        let (name, contacts, amplitude, lag) = match case.variant {
            Variant::Closed(c, ContactSource::Estimated) => {
                (CLOSED_LOOP[c].1, "estimated", String::new(), String::new())
            }
            Variant::Closed(c, ContactSource::True) => (CLOSED_LOOP[c].1, "true", String::new(), String::new()),
            Variant::Blind(c) => (CLOSED_LOOP[c].1, "off", String::new(), String::new()),
            Variant::Open(a, d) => ("open_loop", "", a.to_string(), d.to_string()),
        };
        let (dname, dens) = DENSITIES.get(case.density).copied().unwrap_or(("bare", 0.0));
        csv.push_str(&format!(
            "{dname},{dens},{},{name},{contacts},{amplitude},{lag},{},{}\n",
            case.seed, speed[k], jam[k]
        ));
    }
    for (case, (v, j)) in held_out.iter().zip(&held_out_runs) {
        let Variant::Open(a, l) = case.variant else { continue };
        let (dname, dens) = DENSITIES[case.density];
        csv.push_str(&format!("{dname},{dens},{},open_loop_held_out,,{a},{l},{v},{j}\n", case.seed));
    }
    std::fs::write(&csv_path, csv).map_err(io(&csv_path))?;

    let mut rows = Vec::new();
    let mut checks = Vec::new();
    let plots = ctx.folder.join("plots");
    std::fs::create_dir_all(&plots).map_err(io(&plots))?;
    let estimated = |k: usize| Variant::Closed(k, ContactSource::Estimated);
    let truth = |k: usize| Variant::Closed(k, ContactSource::True);
    for (d, (dname, dens)) in DENSITIES.iter().enumerate() {
        let best = best[d];
        let Variant::Open(best_a, best_l) = best.0 else { unreachable!("the sweep holds open-loop waves only") };
        let open = speeds_of(d, best.0);
        let m_open = median(&open);
        let held = held_out_of(d);
        let held = format!(
            "{} ({} of {} jammed)",
            sig(1000.0 * median(&held.iter().map(|r| r.0).collect::<Vec<f64>>())),
            held.iter().filter(|r| r.1).count(),
            held.len()
        );
        for (k, (_, cname)) in CLOSED_LOOP.iter().enumerate() {
            let (est, tru) = (speeds_of(d, estimated(k)), speeds_of(d, truth(k)));
            let (m_est, m_true) = (median(&est), median(&tru));
            let m_blind = median(&speeds_of(d, Variant::Blind(k)));
            rows.push(vec![
                format!("{dname} ({dens} pegs/m²)"),
                format!("`{cname}`"),
                seeds.to_string(),
                median_with_interval(&est),
                sig(1000.0 * m_true),
                sig(1000.0 * m_blind),
                format!("{} (A {best_a}°, δ {best_l}°)", median_with_interval(&open)),
                if m_open > 0.0 { sig(m_est / m_open) } else { "open loop does not advance".to_string() },
                format!("{} of {seeds}", jams_of(d, estimated(k))),
                format!("{} of {seeds}", jams_of(d, best.0)),
                held.clone(),
            ]);
            // Twice the best open-loop median; when that does not advance (≤ 0), the closed loop
            // must at least advance by MIN_SPEED_MM_PER_S.
            checks.push(Check::at_least(
                &format!("`{cname}`, {dname}: median speed, estimated contacts (≥ 2 × best open loop's, and > 0)"),
                1000.0 * m_est,
                (2000.0 * m_open).max(MIN_SPEED_MM_PER_S),
                "mm/s",
            ));
        }

        // Plots: speed per seed, the paths of seed 0 over its pegs, estimate against truth.
        let x: Vec<f64> = (0..seeds).map(|s| s as f64).collect();
        let mut lines = Vec::new();
        for (k, (_, cname)) in CLOSED_LOOP.iter().enumerate() {
            for (variant, what) in [(estimated(k), "estimated"), (truth(k), "true")] {
                lines.push((
                    format!("{cname}, {what} contacts"),
                    speeds_of(d, variant).iter().map(|v| 1000.0 * v).collect::<Vec<f64>>(),
                ));
            }
        }
        lines.push((format!("best open loop (A {best_a}°, δ {best_l}°)"), open.iter().map(|v| 1000.0 * v).collect()));
        crate::plot::plot_lines(
            &plots,
            &format!("hoal_speed_{dname}"),
            &format!("{dname} peg field ({dens} pegs/m²): forward speed per seed"),
            "seed",
            "forward speed (mm/s)",
            &x,
            &lines,
        )
        .map_err(plot_error)?;
        let field = case_config(base, &Case { density: d, seed: 0, variant: best.0 }, duration_secs);
        let pegs: Vec<([f64; 2], f64)> = crate::model::generate(&field)
            .map_err(|e| ExperimentError::Data(format!("peg field {dname} seed 0: {e}")))?
            .obstacles
            .iter()
            .map(|c| (c.center_m, c.radius_m))
            .collect();
        let path_of = |variant: Variant, label: String| {
            index(d, 0, variant).map(|k| {
                let t = &traces[k];
                (label, t.com_m.iter().map(|c| c[0]).collect(), t.com_m.iter().map(|c| c[1]).collect())
            })
        };
        let mut paths: Vec<(String, Vec<f64>, Vec<f64>)> = Vec::new();
        for (k, (_, cname)) in CLOSED_LOOP.iter().enumerate() {
            paths.extend(path_of(estimated(k), format!("{cname}, estimated contacts")));
        }
        paths.extend(path_of(best.0, "best open loop".to_string()));
        crate::plot::plot_paths_over_circles(
            &plots,
            &format!("hoal_paths_{dname}"),
            &format!("{dname} peg field ({dens} pegs/m²), seed 0: centre-of-mass paths"),
            &paths,
            &pegs,
        )
        .map_err(plot_error)?;
        for (k, (_, cname)) in CLOSED_LOOP.iter().enumerate() {
            if let Some(i) = index(d, 0, estimated(k)) {
                let t = &traces[i];
                crate::plot::plot_time_series(
                    &plots,
                    &format!("hoal_estimate_{cname}_{dname}"),
                    &format!("{cname}, {dname} field, seed 0: obstacle force on the body (sum over links of |f_xy|)"),
                    "force (N)",
                    &t.time_secs,
                    &[("estimated".to_string(), t.estimated_n.clone()), ("true".to_string(), t.true_n.clone())],
                )
                .map_err(plot_error)?;
            }
        }
    }
    for (k, (_, cname)) in CLOSED_LOOP.iter().enumerate() {
        let all = |variant: Variant| -> Vec<f64> { (0..DENSITIES.len()).flat_map(|d| speeds_of(d, variant)).collect() };
        let (all_est, all_true) = (all(estimated(k)), all(truth(k)));
        let jams: usize = (0..DENSITIES.len()).map(|d| jams_of(d, estimated(k))).sum();
        let (m_est, m_true) = (median(&all_est), median(&all_true));
        checks.push(Check::at_most(
            &format!("`{cname}`: jams (no progress for 5 s), estimated contacts, share of runs"),
            jams as f64 / all_est.len().max(1) as f64 * 100.0,
            10.0,
            "%",
        ));
        // This says how much the estimates cost; it says nothing about advancing (both medians
        // may be ≤ 0): the speed checks above do.
        checks.push(Check::at_most(
            &format!("`{cname}`: median speed, estimated contacts against true contacts (|difference| / true)"),
            (m_est - m_true).abs() / m_true.abs() * 100.0,
            20.0,
            "%",
        ));
        rows.push(vec![
            "all fields".to_string(),
            format!("`{cname}`"),
            (DENSITIES.len() as u64 * seeds).to_string(),
            sig(1000.0 * m_est),
            sig(1000.0 * m_true),
            sig(1000.0 * median(&all(Variant::Blind(k)))),
            String::new(),
            String::new(),
            format!("{jams} of {}", all_est.len()),
            String::new(),
            String::new(),
        ]);
    }
    // The bare floor: what each closed loop does without pegs, against the fastest wave there.
    let (bare_best, bare_best_speed) = sweep
        .iter()
        .map(|&v| (v, median(&speeds_of(BARE, v))))
        .fold((Variant::Open(0.0, 0.0), f64::NEG_INFINITY), |b, x| if x.1 > b.1 { x } else { b });
    if let Variant::Open(a, l) = bare_best {
        for (k, (_, cname)) in CLOSED_LOOP.iter().enumerate() {
            let m = median(&speeds_of(BARE, estimated(k)));
            rows.push(vec![
                "bare floor (no pegs), seed 0".to_string(),
                format!("`{cname}`"),
                "1".to_string(),
                sig(1000.0 * m),
                String::new(),
                String::new(),
                format!("{} (A {a}°, δ {l}°)", sig(1000.0 * bare_best_speed)),
                if bare_best_speed > 0.0 { sig(m / bare_best_speed) } else { String::new() },
                format!("{} of 1", jams_of(BARE, estimated(k))),
                format!("{} of 1", jams_of(BARE, bare_best)),
                String::new(),
            ]);
        }
    }
    let all_passed = checks.iter().all(|c| c.passed);
    let failed = checks.iter().filter(|c| !c.passed).count();
    let headline = if all_passed {
        "Every check passed.".to_string()
    } else {
        format!("**{failed} of {} checks failed** (table and checks below).", checks.len())
    };
    let area = (REGION_MAX_M[0] - REGION_MIN_M[0]) * (REGION_MAX_M[1] - REGION_MIN_M[1]);
    let oa = &base.obstacle_aided;
    let press = if oa.force_gain_rad_per_n_s > 0.0 {
        "press on pegs that push forward, yield at pegs that resist"
    } else {
        "yield at pegs that resist; pressing on pegs that push forward is off, `force_gain_rad_per_n_s = 0`"
    };
    let section = Section {
        heading: "Obstacle-aided locomotion with force feedback".into(),
        text: format!(
            "{headline}\n\n10 links (0.2 m, 0.3 kg), stick–slip floor with isotropic Coulomb friction μ = {mu}, position \
             servos kp {SERVO_KP_NM_PER_RAD} N·m/rad, kv {SERVO_KV_NM_S_PER_RAD} N·m·s/rad, ±{TORQUE_LIMIT_NM} N·m (as in `oal`), default sensor noise. Random peg fields (peg radius 0.05 m, centres ≥ {SPACING_M} m apart, in x ∈ \
             [{x0}, {x1}] m, y ∈ [{y0}, {y1}] m = {area} m², none on the starting snake) at {densities}; seeds 0..{seeds} \
             (the same fields for every controller). {duration_secs} s per run, wave frequency {FREQUENCY_HZ} Hz, ramp-in \
             {ramp_secs} s. Closed loop: `control.controller = \"obstacle_aided\"` (its wave {oa_a}°/{oa_l}°, running toward the \
             head, 0.5 Hz, with a hybrid position/force law at the contacts: {press}) and \
             `\"rail\"` (starts in the floor-drift wave running toward the head and switches on the contact estimates to \
             follow-the-leader, where the body follows the head's path and the head turns toward the pegs it touches, and \
             back{rail_jam}), each with its default settings, fed the \
             step loop's contact estimates (measured sensors, head IMU + encoders) or the simulator's true contacts, and with its \
             contact terms switched off (`obstacle_aided.contact_feedback = false`, `rail.use_contacts = false`: what the \
             contacts add). Open loop: \
             the sine wave for A ∈ {AMPLITUDES_DEG:?}° × δ ∈ {PHASE_LAGS_DEG:?}° (δ < 0: the wave runs toward the head; on an \
             isotropic floor the snake drifts the way its wave runs, so these are the open loop's forward gaits); per density \
             the wave with the highest median speed is the best open-loop gait; it runs again on as many fields it was not \
             chosen on (seeds {seeds}..{held_end}: the best of many medians over few fields overstates a wave). Every wave and every closed loop \
             (estimated contacts) also runs once on the bare floor (no pegs, seed 0's sensor noise), to show what the pegs \
             add to or take from each gait. Forward speed: the centre of mass's advance \
             along +x from the end of the ramp-in to the end, per second. A jam: a 5-s window after the ramp-in in which the \
             farthest forward position reached grows by less than {JAM_PROGRESS_M} m. Every run's speed and jam flag are in \
             hoal_runs.csv; plots/: hoal_paths_<density> (centre-of-mass paths of seed 0 over its pegs: each closed loop \
             with estimated contacts, and the best open loop), hoal_speed_<density> (speed per seed), \
             hoal_estimate_<controller>_<density> (seed 0: the estimated against the true obstacle force on the body; the \
             estimate describes the sensors of one step earlier).",
            mu = field_config(base, 1.0, 0).snake.ground_friction[0],
            oa_a = sig(oa.amplitude_deg),
            oa_l = sig(oa.phase_lag_deg),
            rail_jam = if base.rail.jam_switch { "; a jam also switches" } else { "" },
            held_end = 2 * seeds,
            x0 = REGION_MIN_M[0],
            x1 = REGION_MAX_M[0],
            y0 = REGION_MIN_M[1],
            y1 = REGION_MAX_M[1],
            area = sig(area),
            densities = DENSITIES.iter().map(|(n, d)| format!("{d} pegs/m² ({n})")).collect::<Vec<_>>().join(", "),
        ),
        tables: vec![
            (
                [
                    "field",
                    "controller",
                    "seeds",
                    "median speed, estimated contacts (mm/s; 90 % bootstrap interval over the fields)",
                    "median speed, true contacts (mm/s)",
                    "median speed, contact terms off (mm/s)",
                    "best open loop median (mm/s; 90 % bootstrap interval)",
                    "ratio estimated / open loop",
                    "jams, estimated contacts",
                    "jams, best open loop",
                    "best open loop on held-out fields: median (mm/s), jams",
                ]
                .map(String::from)
                .to_vec(),
                rows,
            ),
            (
                ["field", "open loop A (°)", "δ (°)", "median speed (mm/s)", "jams", "bare floor, seed 0 (mm/s)"]
                    .map(String::from)
                    .to_vec(),
                sweep_rows,
            ),
        ],
        checks,
    };
    Ok(section)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn trace(xs: &[f64], dt: f64) -> Trace {
        Trace {
            time_secs: (0..xs.len()).map(|k| k as f64 * dt).collect(),
            com_m: xs.iter().map(|x| [*x, 0.0]).collect(),
            ..Trace::default()
        }
    }

    #[test]
    fn speed_and_jams_from_the_centre_of_mass_path() {
        // 0.01 m/s for 20 s: 0.05 m per 5 s, no jam.
        let moving: Vec<f64> = (0..=200).map(|k| 0.001 * k as f64).collect();
        let t = trace(&moving, 0.1);
        let (speed, jam) = speed_and_jam(&t, 1.0);
        assert!((speed - 0.01).abs() < 1e-12);
        assert!(!jam);
        // Stops at 8 s for 6 s, then goes on: a jam.
        let stuck: Vec<f64> = (0..=200).map(|k| 0.001 * (k.min(80) + (k.max(140) - 140)) as f64).collect();
        assert!(speed_and_jam(&trace(&stuck, 0.1), 1.0).1);
        assert_eq!(median(&[3.0, 1.0, 2.0, 10.0]), 2.5);
    }

    #[test]
    fn the_median_interval_brackets_the_median_within_the_values_and_is_repeatable() {
        // One value repeated: no spread.
        assert_eq!(median_interval(&[0.05; 10]), (0.05, 0.05));
        // Ten spread values: the interval holds the median, lies within the values, is not
        // degenerate, and is the same on every call (fixed-seed resampling).
        let v = [-0.04, 0.01, 0.03, 0.045, 0.05, 0.052, 0.06, 0.07, 0.09, 0.2];
        let (lo, hi) = median_interval(&v);
        let m = median(&v);
        assert!(lo < m && m < hi, "{lo} < {m} < {hi}");
        assert!(
            lo >= 0.01 && hi <= 0.09,
            "the 5–95 % medians of 10 resampled values stay inside the 2nd..9th: {lo}, {hi}"
        );
        assert_eq!(median_interval(&v), (lo, hi));
        // Non-finite speeds are left out, as in the median.
        assert_eq!(median_interval(&[f64::NAN, 0.02, 0.02]), (0.02, 0.02));
        assert!(median_interval(&[]).0.is_nan());
        assert_eq!(median_with_interval(&[0.05; 3]), format!("{} ({}–{})", sig(50.0), sig(50.0), sig(50.0)));
    }
}
