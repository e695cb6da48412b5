//! An oracle bound for obstacle-aided locomotion: how fast can *any* controller that switches between the sine
//! waves of experiment `hoal`'s sweep go on hoal's peg fields?
//!
//! Run with:
//!
//! ```text
//! cargo run --release --example hoal_oracle -- [--seeds 0-9] [--window-secs 2[,1,4...]] [--blend-secs 0.25]
//!     [--duration-secs 15] [--amplitudes 50,65,80] [--lags=-60,-45,-30,30] [--densities sparse,medium,dense]
//!     [--lookahead] [--no-sweep] [--sweep-csv hoal_runs.csv] [--dump FILE.csv] [--replay 0,1e-9]
//!     [--check] [--threads 2]
//! ```
//!
//! `--window-secs` takes a list: one oracle run per field and window length (the sweep is shared).
//! Each finished run is also reported on stderr, so an interrupted study keeps its results.
//! `--sweep-csv` takes the sweep from the `hoal_runs.csv` of a full `simserpent experiment hoal`
//! run (the same runs: hoal scores them with `score_run`'s code) instead of running it again;
//! `--no-sweep` skips it (no ratios then). The default wave family has δ = −30° where hoal's
//! sweep has δ = −75° (the recorded oracle results used it), so with a `hoal_runs.csv` of
//! hoal's sweep pass `--lags=-75,-60,-45,30`.
//!
//! `--dump FILE.csv` writes one row per oracle window: field, window, start time, the wave that
//! ran before, what the snake *sensed* over the window before (its controller's view: per link
//! the mean estimated obstacle force in the world's x and y, its mean magnitude and the fraction
//! of steps with a contact flag; the head's position, displacement and mean and last heading),
//! the links' true positions at the window's start (privileged, for analysis), every wave's gain
//! over the window (m, from the same saved state) and the wave chosen; and `FILE.pegs.csv`, each
//! field's pegs (density, seed, x, y, radius). With `--dump` the oracle's runs have the contact
//! estimator on (it reads the sensors and moves nothing: the runs and schedules are the same).
//! `python/examples/wave_choice_study.py` asks of these rows whether a controller could predict
//! the oracle's choices (BENCHMARKS.md, "Obstacle-aided locomotion").
//!
//! `--replay EPS[,EPS...]` runs each field's oracle schedule again from the start, once per ε,
//! in one plain run without foresight, with every wave's amplitude scaled by (1 + ε). ε = 0
//! reproduces the oracle's run exactly (a check of the machinery); a tiny ε (1e-9: a billionth
//! of the amplitude) asks whether the schedule is worth anything once the run is not exactly the
//! one it was chosen on, i.e. whether a controller that somehow knew the schedule in advance
//! would still gain, or the oracle's gain is foresight of how this exact run plays out.
//!
//! For every field (hoal's `field_config`: density × seed, the same scene, sensor noise and
//! servos; `score_run`'s scoring: the centre of mass's advance along +x after the 1-s ramp-in,
//! per second, and the jam rule, 5 s without 2 cm of new progress) it runs:
//!
//! - **the sweep**: every wave of the family (amplitude A × phase lag δ, hoal's 12 waves by
//!   default, 0.5 Hz) as a plain open-loop run (`hoal::score_run`, exactly hoal's runs). Per
//!   density the wave with the best median is "the best single wave" (in-sample, as in hoal), and
//!   per field the best of the waves is "the hindsight best single wave" of that field;
//! - **the greedy oracle**: a run with perfect foresight. The run is cut into windows of
//!   `--window-secs` W after the ramp-in (the first window also holds the ramp, so the oracle
//!   chooses the wave the snake ramps in with too; the last window may be shorter). At the start
//!   of each window the whole simulation (engine state, controller, sensor-noise streams, ground
//!   model: `Simulation::save`) is saved; every wave of the family is run from that same state
//!   to the window's end; the wave whose centre of mass gains most along +x over the window
//!   wins, and the run continues from the winner's end state (kept with `Simulation::save`, so
//!   nothing is simulated twice). With `--lookahead` a wave's value is its gain over its window
//!   plus the best gain of any wave over the next window (so the oracle sees two windows ahead;
//!   it still commits only the first; with n waves a window costs n·(1 + n) simulated windows
//!   instead of n).
//!
//! **How the oracle switches waves.** Its controller (`SwitchedWave` below, a `Controller` of its
//! own, as `examples/custom_controller.rs` plugs one in) evaluates hoal's wave
//! φ_j(t) = r(t)·A·sin(2πf·t − j·δ) (the library's `control::SineWave`, the same ramp r(t));
//! the time argument runs on through a switch (the phase ωt is continuous; only A and δ change).
//! Changing δ moves the target of joint j by j·Δδ of phase at once, so the targets are blended
//! over `--blend-secs` τ: φ_j = (1 − s)·φ_j^old + s·φ_j^new with s = smoothstep((t − t_switch)/τ)
//! (τ = 0: a jump). The blend is part of the window in which the oracle judges the new wave, so
//! a switch's cost counts against it. With one wave and no switch the controller's targets are
//! bit for bit the gait's, and `--check` verifies that the whole machinery (save/restore at
//! every window, the step loop taken apart) reproduces `hoal::score_run` exactly for every wave.
//!
//! Prints per density: each field's best single wave and hindsight best wave (with the sweep),
//! each field's oracle speed, jam and schedule of waves, and the oracle's median, jams and its
//! ratios to the best single wave and to hoal's 2× target. Speeds in mm/s.
//!
//! Measured (BENCHMARKS.md): seeds 0–9, W = 2 s, oracle medians
//! 153.8 / 217.6 / 119.8 mm/s (sparse / medium / dense) against the best single waves' 62.3 /
//! 52.2 / 34.8. The oracle costs 12 plain 15-s runs per field and window length.

use simserpent::config::{Config, ControlMethod, ControllerKind, GaitKind};
use simserpent::control::{Command, Controller, JointTrajectory, Observation, Pid, SineWave};
use simserpent::experiments::hoal::{
    DENSITIES, RECORD_EVERY, field_config, forward_speed_m_per_s as forward_speed, median, path_jammed as jammed,
    score_run,
};
use simserpent::sim::{Simulation, SimulationState, World};
use simserpent::state::Snapshot;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

/// One wave of the family: amplitude and phase lag (degrees).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Wave {
    amplitude_deg: f64,
    lag_deg: f64,
}

/// hoal's sine wave, switchable between waves with a blend (see the module docs).
#[derive(Clone)]
struct SwitchedWave {
    old: SineWave,
    new: SineWave,
    switch_secs: f64,
    blend_secs: f64,
    method: ControlMethod,
    pids: Vec<Pid>,
    dt_secs: f64,
    old_rad: Vec<f64>,
    old_rate: Vec<f64>,
    new_rad: Vec<f64>,
    new_rate: Vec<f64>,
    /// What the controller sensed in the current window (only with `--dump`).
    sense: Option<WindowSense>,
}

/// What a causal controller senses over one window (for `--dump`: a wave-choice learner's
/// inputs): per link the mean estimated obstacle force (world x, y) and its mean magnitude,
/// the fraction of steps with a contact flag; the head's pose.
#[derive(Clone, Default)]
struct WindowSense {
    steps: u64,
    force_n: Vec<[f64; 2]>,
    force_abs_n: Vec<f64>,
    contact_steps: Vec<u64>,
    head_start_m: Option<[f64; 2]>,
    head_m: [f64; 2],
    yaw_sum: [f64; 2],
    yaw_rad: f64,
}

impl WindowSense {
    fn new(n_links: usize) -> Self {
        Self {
            force_n: vec![[0.0; 2]; n_links],
            force_abs_n: vec![0.0; n_links],
            contact_steps: vec![0; n_links],
            ..Self::default()
        }
    }

    fn add(&mut self, obs: &Observation) {
        let yaw = simserpent::state::yaw_rad(obs.head_quat);
        self.yaw_rad = yaw;
        self.yaw_sum[0] += yaw.cos();
        self.yaw_sum[1] += yaw.sin();
        self.head_m = [obs.head_position_m[0], obs.head_position_m[1]];
        self.head_start_m.get_or_insert(self.head_m);
        self.steps += 1;
        let c = &obs.contacts;
        if c.active {
            for i in 0..self.force_n.len().min(c.obstacle_force_n.len()) {
                let f = c.obstacle_force_n[i];
                self.force_n[i][0] += f[0];
                self.force_n[i][1] += f[1];
                self.force_abs_n[i] += f[0].hypot(f[1]);
                self.contact_steps[i] += u64::from(c.contact[i]);
            }
        }
    }

    /// The CSV fields of this window, then a fresh window.
    fn close_window(&mut self) -> String {
        let n = self.steps.max(1) as f64;
        let start = self.head_start_m.unwrap_or(self.head_m);
        let mut out = format!(
            "{:.5},{:.5},{:.5},{:.5},{:.5},{:.5}",
            self.head_m[0],
            self.head_m[1],
            self.head_m[0] - start[0],
            self.head_m[1] - start[1],
            self.yaw_sum[1].atan2(self.yaw_sum[0]),
            self.yaw_rad
        );
        for i in 0..self.force_n.len() {
            use std::fmt::Write;
            let _ = write!(
                out,
                ",{:.4},{:.4},{:.4},{:.4}",
                self.force_n[i][0] / n,
                self.force_n[i][1] / n,
                self.force_abs_n[i] / n,
                self.contact_steps[i] as f64 / n
            );
        }
        let links = self.force_n.len();
        *self = Self::new(links);
        out
    }
}

fn sine(config: &Config, wave: Wave) -> SineWave {
    SineWave {
        amplitude_rad: wave.amplitude_deg.to_radians(),
        frequency_hz: config.gait.sine_wave.frequency_hz,
        phase_lag_rad: wave.lag_deg.to_radians(),
        offset_rad: config.gait.sine_wave.offset_deg.to_radians(),
        ramp_secs: config.gait.ramp_secs,
    }
}

fn same(a: &SineWave, b: &SineWave) -> bool {
    a.amplitude_rad == b.amplitude_rad && a.phase_lag_rad == b.phase_lag_rad
}

impl SwitchedWave {
    fn new(config: &Config, n_joints: usize, wave: Wave, blend_secs: f64) -> Self {
        let w = sine(config, wave);
        Self {
            old: w,
            new: w,
            switch_secs: 0.0,
            blend_secs,
            method: config.control.method,
            pids: vec![simserpent::control::joint_pid(config); n_joints],
            dt_secs: config.general.timestep_secs,
            old_rad: vec![0.0; n_joints],
            old_rate: vec![0.0; n_joints],
            new_rad: vec![0.0; n_joints],
            new_rate: vec![0.0; n_joints],
            sense: None,
        }
    }

    /// With `on`, the controller also sums up what it senses per window ([`WindowSense`]).
    fn sensing(mut self, on: bool) -> Self {
        let n_links = self.new_rad.len() + 1;
        self.sense = on.then(|| WindowSense::new(n_links));
        self
    }

    /// From `t_secs` on, blend from the wave now running to `wave`.
    fn switch_to(&mut self, config: &Config, wave: Wave, t_secs: f64) {
        let w = sine(config, wave);
        if same(&w, &self.new) && t_secs >= self.switch_secs + self.blend_secs {
            self.old = w;
            return;
        }
        self.old = self.new;
        self.new = w;
        self.switch_secs = t_secs;
    }
}

impl Controller for SwitchedWave {
    fn reset(&mut self) {
        self.pids.iter_mut().for_each(Pid::reset);
    }

    fn update(&mut self, obs: &Observation, cmd: &mut Command) {
        let t = obs.time_secs;
        if let Some(sense) = &mut self.sense {
            sense.add(obs);
        }
        self.new.targets(t, &mut self.new_rad, &mut self.new_rate);
        let u = if self.blend_secs > 0.0 { (t - self.switch_secs) / self.blend_secs } else { 1.0 };
        if !same(&self.old, &self.new) && u < 1.0 {
            // s = smoothstep(u), ds/dt.
            let u = u.max(0.0);
            let s = u * u * (3.0 - 2.0 * u);
            let ds = 6.0 * u * (1.0 - u) / self.blend_secs;
            self.old.targets(t, &mut self.old_rad, &mut self.old_rate);
            for j in 0..self.new_rad.len() {
                let (a, b) = (self.old_rad[j], self.new_rad[j]);
                self.new_rad[j] = (1.0 - s) * a + s * b;
                self.new_rate[j] = (1.0 - s) * self.old_rate[j] + s * self.new_rate[j] + ds * (b - a);
            }
        }
        for (j, pid) in self.pids.iter_mut().enumerate() {
            simserpent::control::command_joint(
                self.method,
                cmd,
                j,
                self.new_rad[j],
                self.new_rate[j],
                obs,
                pid,
                self.dt_secs,
            );
        }
    }
}

/// The centre of mass every `RECORD_EVERY` steps: (time (s), x (m)).
type Trace = Vec<(f64, f64)>;

/// Runs `sim` to global step `end_step` (exclusive of that instant's control), recording as hoal
/// does.
fn run_to(
    sim: &mut Simulation<SwitchedWave>,
    end_step: u64,
    snap: &mut Snapshot,
    trace: &mut Trace,
) -> anyhow::Result<()> {
    while sim.steps() < end_step {
        sim.control();
        if sim.steps().is_multiple_of(RECORD_EVERY) {
            sim.snapshot(snap);
            trace.push((snap.time_secs, snap.centre_of_mass_m()[0]));
        }
        sim.advance()?;
    }
    Ok(())
}

/// Records the run's last instant as hoal does (the step loop's instant `steps`).
fn record_last_instant(sim: &mut Simulation<SwitchedWave>, snap: &mut Snapshot, trace: &mut Trace) {
    sim.control();
    if sim.steps().is_multiple_of(RECORD_EVERY) {
        sim.snapshot(snap);
        trace.push((snap.time_secs, snap.centre_of_mass_m()[0]));
    }
}

/// The state of `sim` and its centre of mass's x. The state is saved first: the forward pass
/// that the centre of mass needs would change what the next step's sensing and ground model
/// read (MuJoCo's data after a step describe the step's start), so the run continues from the
/// saved state, as if the centre of mass had not been read.
fn save_with_x(sim: &mut Simulation<SwitchedWave>, snap: &mut Snapshot) -> (SimulationState<SwitchedWave>, f64) {
    let state = sim.save();
    sim.snapshot(snap);
    (state, snap.centre_of_mass_m()[0])
}

struct Options {
    seeds: Vec<u64>,
    densities: Vec<usize>,
    /// Window lengths to run the oracle with (s).
    windows_secs: Vec<f64>,
    blend_secs: f64,
    duration_secs: f64,
    waves: Vec<Wave>,
    lookahead: bool,
    /// Replay each oracle schedule with every amplitude scaled by (1 + ε), per ε.
    replay: Vec<f64>,
    sweep: bool,
    /// Read the sweep from this `hoal_runs.csv` of `simserpent experiment hoal` instead of running it.
    sweep_csv: Option<std::path::PathBuf>,
    /// Write every oracle window's sensed inputs and every wave's gain to this CSV.
    dump: Option<std::path::PathBuf>,
    check: bool,
    threads: usize,
}

/// The result of the oracle on one field.
struct OracleRun {
    speed_m_per_s: f64,
    jammed: bool,
    /// Index into the family, per window.
    schedule: Vec<usize>,
    /// `--dump` rows: per window the sensed inputs of the window before and every wave's gain.
    rows: Vec<String>,
    /// `--replay`: per ε, the schedule replayed without foresight.
    replays: Vec<Replay>,
}

/// An oracle schedule replayed from the start with the amplitudes scaled by (1 + ε).
#[derive(Clone, Copy)]
struct Replay {
    speed_m_per_s: f64,
    jammed: bool,
    /// The first recorded instant at which the centre of mass's x differs from the oracle's
    /// run by more than `DIVERGED_M` (None: never within the run).
    diverged_secs: Option<f64>,
}

/// How far the replay's centre of mass (along x) may drift from the oracle's before the two
/// runs count as different.
const DIVERGED_M: f64 = 0.01;

/// The best gain over the window [from, to] of any wave from the state `sim` is in.
fn best_next_gain(
    sim: &mut Simulation<SwitchedWave>,
    config: &Config,
    opts: &Options,
    start_x: f64,
    end_step: u64,
    snap: &mut Snapshot,
) -> anyhow::Result<f64> {
    let saved = sim.save();
    let t = sim.world().time_secs();
    let mut best = f64::NEG_INFINITY;
    let mut scratch = Trace::new();
    for wave in &opts.waves {
        sim.restore(&saved)?;
        sim.controller_mut().switch_to(config, *wave, t);
        scratch.clear();
        run_to(sim, end_step, snap, &mut scratch)?;
        sim.snapshot(snap);
        best = best.max(snap.centre_of_mass_m()[0] - start_x);
    }
    sim.restore(&saved)?;
    Ok(best)
}

/// The greedy oracle on `config`'s field (only the waves `family` are tried).
fn oracle(config: &Config, opts: &Options, family: &[Wave], window_secs: f64) -> anyhow::Result<OracleRun> {
    config.validate()?;
    let world = World::from_config(config)?;
    let n_joints = world.n_joints();
    let (nl, nj) = (world.n_links(), world.n_joints());
    let sensing = opts.dump.is_some();
    let controller = SwitchedWave::new(config, n_joints, family[0], opts.blend_secs).sensing(sensing);
    let mut sim = Simulation::with_typed_controller(config, world, controller);
    let mut snap = Snapshot::new(nl, nj);
    let dt = config.general.timestep_secs;
    let ramp_secs = config.gait.ramp_secs;
    let total = (config.general.duration_secs / dt).round() as u64;
    let ramp_step = (ramp_secs / dt).round() as u64;
    let window = ((window_secs / dt).round() as u64).max(1);
    // Window ends (global steps); the first window also holds the ramp.
    let mut ends = Vec::new();
    let mut e = ramp_step;
    while e < total {
        e = (e + window).min(total);
        ends.push(e);
    }
    let mut trace = Trace::new();
    let mut schedule = Vec::new();
    let mut prev_x = 0.0;
    let mut rows = Vec::new();
    for (w, &end) in ends.iter().enumerate() {
        let mut sensed = sim.controller_mut().sense.as_mut().map(WindowSense::close_window).unwrap_or_default();
        let saved = sim.save();
        if sensing {
            // Privileged (not sensed, for analysis only): the links' true positions.
            use std::fmt::Write;
            sim.snapshot(&mut snap);
            for p in &snap.link_position_m {
                let _ = write!(sensed, ",{:.4},{:.4}", p[0], p[1]);
            }
        }
        let t = sim.world().time_secs();
        let mut best: Option<(f64, usize, _, Trace, f64)> = None;
        let mut gains = Vec::with_capacity(family.len());
        for (k, wave) in family.iter().enumerate() {
            sim.restore(&saved)?;
            if w == 0 {
                // The first window starts at t = 0: the wave itself, no blend.
                *sim.controller_mut() = SwitchedWave::new(config, n_joints, *wave, opts.blend_secs).sensing(sensing);
            } else {
                sim.controller_mut().switch_to(config, *wave, t);
            }
            let mut seg = Trace::new();
            run_to(&mut sim, end, &mut snap, &mut seg)?;
            let (state, x_end) = save_with_x(&mut sim, &mut snap);
            let x_start =
                if w == 0 { seg.iter().find(|s| s.0 >= ramp_secs - 1e-9).map_or(seg[0].1, |s| s.1) } else { prev_x };
            let mut value = x_end - x_start;
            if opts.lookahead
                && let Some(&next_end) = ends.get(w + 1)
            {
                sim.restore(&state)?;
                value += best_next_gain(&mut sim, config, opts, x_end, next_end, &mut snap)?;
            }
            gains.push(value);
            if best.as_ref().is_none_or(|b| value > b.0) {
                best = Some((value, k, state, seg, x_end));
            }
        }
        let (_, k, state, seg, x_end) = best.expect("the family is not empty");
        rows.push(format!(
            "{w},{t:.3},{},{sensed},{},{k}",
            schedule.last().copied().map_or(-1, |p: usize| p as i64),
            gains.iter().map(|g| format!("{g:.5}")).collect::<Vec<_>>().join(",")
        ));
        sim.restore(&state)?;
        trace.extend(seg);
        schedule.push(k);
        prev_x = x_end;
    }
    record_last_instant(&mut sim, &mut snap, &mut trace);
    let replays = opts
        .replay
        .iter()
        .map(|&eps| replay(config, opts, family, &ends, &schedule, eps, &trace))
        .collect::<anyhow::Result<_>>()?;
    Ok(OracleRun {
        speed_m_per_s: forward_speed(&trace, ramp_secs),
        jammed: jammed(&trace, ramp_secs),
        schedule,
        rows,
        replays,
    })
}

/// The oracle's `schedule` (waves of `family`, windows ending at `ends`) replayed from the start
/// in one plain run, every wave's amplitude scaled by (1 + `eps`): with ε = 0 the oracle's run
/// exactly (a check); with a tiny ε, whether the schedule still gains when the run is not the
/// one it was chosen on; and when its centre of mass leaves the oracle's `oracle_trace`.
fn replay(
    config: &Config,
    opts: &Options,
    family: &[Wave],
    ends: &[u64],
    schedule: &[usize],
    eps: f64,
    oracle_trace: &Trace,
) -> anyhow::Result<Replay> {
    let world = World::from_config(config)?;
    let (nl, nj) = (world.n_links(), world.n_joints());
    let scaled = |k: usize| Wave { amplitude_deg: family[k].amplitude_deg * (1.0 + eps), ..family[k] };
    let controller = SwitchedWave::new(config, nj, scaled(schedule[0]), opts.blend_secs);
    let mut sim = Simulation::with_typed_controller(config, world, controller);
    let mut snap = Snapshot::new(nl, nj);
    let mut trace = Trace::new();
    for (w, (&end, &k)) in ends.iter().zip(schedule).enumerate() {
        if w > 0 {
            let t = sim.world().time_secs();
            sim.controller_mut().switch_to(config, scaled(k), t);
        }
        run_to(&mut sim, end, &mut snap, &mut trace)?;
    }
    record_last_instant(&mut sim, &mut snap, &mut trace);
    let ramp_secs = config.gait.ramp_secs;
    let diverged_secs = trace.iter().zip(oracle_trace).find(|(r, o)| (r.1 - o.1).abs() > DIVERGED_M).map(|(r, _)| r.0);
    Ok(Replay { speed_m_per_s: forward_speed(&trace, ramp_secs), jammed: jammed(&trace, ramp_secs), diverged_secs })
}

fn open_config(base: &Config, density: f64, seed: u64, duration_secs: f64, wave: Wave) -> Config {
    let mut c = field_config(base, density, seed);
    c.general.duration_secs = duration_secs;
    c.control.controller = ControllerKind::Gait;
    c.gait.kind = GaitKind::SineWave;
    c.gait.sine_wave.amplitude_deg = wave.amplitude_deg;
    c.gait.sine_wave.phase_lag_deg = wave.lag_deg;
    c.estimation.enabled = false;
    c
}

fn parse_list<T: std::str::FromStr>(key: &str, s: &str) -> anyhow::Result<Vec<T>> {
    s.split(',')
        .map(|x| {
            x.trim().parse::<T>().map_err(|_| anyhow::anyhow!("{key}: cannot read {x:?} (a comma list of numbers)"))
        })
        .collect()
}

fn parse_args() -> anyhow::Result<Options> {
    let mut o = Options {
        seeds: (0..10).collect(),
        densities: (0..DENSITIES.len()).collect(),
        windows_secs: vec![2.0],
        blend_secs: 0.25,
        duration_secs: 15.0,
        waves: Vec::new(),
        lookahead: false,
        replay: Vec::new(),
        sweep: true,
        sweep_csv: None,
        dump: None,
        check: false,
        threads: 2,
    };
    let (mut amplitudes, mut lags) = (vec![50.0, 65.0, 80.0], vec![-60.0, -45.0, -30.0, 30.0]);
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut i = 0;
    while i < args.len() {
        let (key, inline) = match args[i].split_once('=') {
            Some((k, v)) => (k.to_string(), Some(v.to_string())),
            None => (args[i].clone(), None),
        };
        let flag = matches!(key.as_str(), "--lookahead" | "--no-sweep" | "--check");
        let value = if flag {
            String::new()
        } else if let Some(v) = inline {
            v
        } else {
            i += 1;
            args.get(i).cloned().ok_or_else(|| anyhow::anyhow!("{key} needs a value"))?
        };
        let number = |v: &str| v.parse::<f64>().map_err(|_| anyhow::anyhow!("{key}: cannot read {v:?} (a number)"));
        match key.as_str() {
            "--seeds" => {
                let (a, b) = value.split_once('-').unwrap_or((&value, &value));
                let (a, b): (u64, u64) = (
                    a.parse().map_err(|_| anyhow::anyhow!("--seeds: {value:?} is not FIRST-LAST"))?,
                    b.parse().map_err(|_| anyhow::anyhow!("--seeds: {value:?} is not FIRST-LAST"))?,
                );
                anyhow::ensure!(a <= b, "--seeds: {value:?} is empty");
                o.seeds = (a..=b).collect();
            }
            "--densities" => {
                o.densities = value
                    .split(',')
                    .map(|n| {
                        DENSITIES
                            .iter()
                            .position(|d| d.0 == n.trim())
                            .ok_or_else(|| anyhow::anyhow!("--densities: {n:?} is not one of sparse, medium, dense"))
                    })
                    .collect::<anyhow::Result<_>>()?;
            }
            "--window-secs" => o.windows_secs = parse_list("--window-secs", &value)?,
            "--blend-secs" => o.blend_secs = number(&value)?,
            "--duration-secs" => o.duration_secs = number(&value)?,
            "--amplitudes" => amplitudes = parse_list("--amplitudes", &value)?,
            "--lags" => lags = parse_list("--lags", &value)?,
            "--threads" => {
                o.threads = value.parse().map_err(|_| anyhow::anyhow!("--threads: {value:?} is not a count"))?
            }
            "--lookahead" => o.lookahead = true,
            "--replay" => o.replay = parse_list("--replay", &value)?,
            "--no-sweep" => o.sweep = false,
            "--sweep-csv" => o.sweep_csv = Some(value.into()),
            "--dump" => o.dump = Some(value.into()),
            "--check" => o.check = true,
            _ => anyhow::bail!(
                "unknown argument {key:?} (allowed: --seeds, --densities, --window-secs, --blend-secs, \
                 --duration-secs, --amplitudes, --lags, --threads, --lookahead, --no-sweep, --sweep-csv, --dump, --replay, --check)"
            ),
        }
        i += 1;
    }
    for w in &o.windows_secs {
        anyhow::ensure!(*w >= 0.05, "--window-secs: {w} is shorter than 0.05 s");
    }
    anyhow::ensure!(o.blend_secs >= 0.0, "--blend-secs must be >= 0, got {}", o.blend_secs);
    anyhow::ensure!(o.duration_secs > 1.0, "--duration-secs must be > 1 (the ramp-in), got {}", o.duration_secs);
    anyhow::ensure!(o.threads >= 1, "--threads must be >= 1");
    anyhow::ensure!(!amplitudes.is_empty() && !lags.is_empty(), "the wave family is empty");
    for a in &amplitudes {
        anyhow::ensure!(*a > 0.0 && *a <= 90.0, "--amplitudes: {a} is not in (0, 90] degrees");
    }
    o.waves =
        amplitudes.iter().flat_map(|&a| lags.iter().map(move |&d| Wave { amplitude_deg: a, lag_deg: d })).collect();
    Ok(o)
}

/// The sweep's runs: per (density index, seed, wave index) the forward speed (m/s) and whether
/// the run jammed.
type SweepRuns = std::collections::HashMap<(usize, u64, usize), (f64, bool)>;

/// The sweep's runs from a `hoal_runs.csv` (`simserpent experiment hoal`): per (density, seed,
/// wave) the forward speed (m/s) and whether it jammed; every field and wave asked for must be in it.
fn read_sweep_csv(path: &std::path::Path, opts: &Options) -> anyhow::Result<SweepRuns> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| anyhow::anyhow!("--sweep-csv: cannot read {}: {e}", path.display()))?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or("").split(',').collect();
    let column = |name: &str| {
        header.iter().position(|h| *h == name).ok_or_else(|| {
            anyhow::anyhow!("--sweep-csv: {} has no column {name:?} (is it a hoal_runs.csv?)", path.display())
        })
    };
    let cols = [
        column("density")?,
        column("seed")?,
        column("controller")?,
        column("amplitude_deg")?,
        column("phase_lag_deg")?,
        column("forward_speed_m_per_s")?,
        column("jammed")?,
    ];
    let mut sweep = std::collections::HashMap::new();
    for line in lines {
        let f: Vec<&str> = line.split(',').collect();
        let get = |i: usize| f.get(cols[i]).copied().unwrap_or("");
        if get(2) != "open_loop" {
            continue;
        }
        let Some(d) = DENSITIES.iter().position(|x| x.0 == get(0)) else { continue };
        let bad = || anyhow::anyhow!("--sweep-csv: cannot read the line {line:?}");
        let seed: u64 = get(1).parse().map_err(|_| bad())?;
        let (a, l): (f64, f64) = (get(3).parse().map_err(|_| bad())?, get(4).parse().map_err(|_| bad())?);
        if let Some(k) = opts.waves.iter().position(|w| w.amplitude_deg == a && w.lag_deg == l) {
            sweep.insert((d, seed, k), (get(5).parse().map_err(|_| bad())?, get(6) == "true"));
        }
    }
    for &d in &opts.densities {
        for &seed in &opts.seeds {
            for (k, w) in opts.waves.iter().enumerate() {
                anyhow::ensure!(
                    sweep.contains_key(&(d, seed, k)),
                    "--sweep-csv: {} has no open-loop run of {} seed {seed} wave {}°/{}°",
                    path.display(),
                    DENSITIES[d].0,
                    w.amplitude_deg,
                    w.lag_deg
                );
            }
        }
    }
    Ok(sweep)
}

/// A task for the worker threads.
#[derive(Clone, Copy)]
enum Task {
    /// Open-loop wave `k` on field (density, seed) with `hoal::score_run`.
    Sweep(usize, u64, usize),
    /// The oracle on field (density, seed) with window `windows_secs[w]`; with `--check`, the
    /// oracle restricted to wave k.
    Oracle(usize, u64, Option<usize>, usize),
}

enum Outcome {
    Sweep(f64, bool),
    Oracle(OracleRun),
}

fn main() -> anyhow::Result<()> {
    let opts = parse_args()?;
    let base = Config::default();
    let mut tasks = Vec::new();
    for &d in &opts.densities {
        for &seed in &opts.seeds {
            // The oracle runs first (the longest tasks), then the sweep.
            if opts.check {
                for k in 0..opts.waves.len() {
                    tasks.push(Task::Oracle(d, seed, Some(k), 0));
                }
            } else {
                for wi in 0..opts.windows_secs.len() {
                    tasks.push(Task::Oracle(d, seed, None, wi));
                }
            }
        }
    }
    if (opts.sweep && opts.sweep_csv.is_none()) || opts.check {
        for &d in &opts.densities {
            for &seed in &opts.seeds {
                for k in 0..opts.waves.len() {
                    tasks.push(Task::Sweep(d, seed, k));
                }
            }
        }
    }
    let dump = match &opts.dump {
        Some(path) => {
            use std::io::Write;
            let mut f = std::fs::File::create(path)
                .map_err(|e| anyhow::anyhow!("--dump: cannot create {}: {e}", path.display()))?;
            let mut header =
                String::from("density,seed,window,t_secs,prev_wave,head_x,head_y,head_dx,head_dy,yaw_mean,yaw_end");
            let n_links = field_config(&base, DENSITIES[0].1, 0).snake.n_links;
            for i in 0..n_links {
                header += &format!(",fx{i},fy{i},fa{i},fc{i}");
            }
            for i in 0..n_links {
                header += &format!(",lx{i},ly{i}");
            }
            for k in 0..opts.waves.len() {
                header += &format!(",gain{k}");
            }
            header += ",chosen";
            writeln!(f, "{header}")?;
            Some(Mutex::new(f))
        }
        None => None,
    };
    let started = Instant::now();
    let next = AtomicUsize::new(0);
    let results: Mutex<Vec<(usize, Outcome)>> = Mutex::new(Vec::new());
    let failure: Mutex<Option<anyhow::Error>> = Mutex::new(None);
    std::thread::scope(|s| {
        for _ in 0..opts.threads {
            s.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(task) = tasks.get(i).copied() else { break };
                    let outcome = match task {
                        Task::Sweep(d, seed, k) => {
                            let c = open_config(&base, DENSITIES[d].1, seed, opts.duration_secs, opts.waves[k]);
                            score_run(&c).map(|(v, j)| Outcome::Sweep(v, j)).map_err(anyhow::Error::from)
                        }
                        Task::Oracle(d, seed, only, wi) => {
                            let family = match only {
                                Some(k) => vec![opts.waves[k]],
                                None => opts.waves.clone(),
                            };
                            let mut c = open_config(&base, DENSITIES[d].1, seed, opts.duration_secs, family[0]);
                            // `--dump` records what the contact estimator senses (the estimator
                            // reads the sensors and moves nothing: the runs are the same).
                            c.estimation.enabled = opts.dump.is_some();
                            oracle(&c, &opts, &family, opts.windows_secs[wi]).map(Outcome::Oracle)
                        }
                    };
                    match outcome {
                        Ok(o) => {
                            if let (Some(f), Task::Oracle(d, seed, None, _), Outcome::Oracle(r)) = (&dump, &task, &o) {
                                use std::io::Write;
                                let mut f = f.lock().expect("no panics while locked");
                                for row in &r.rows {
                                    let _ = writeln!(f, "{},{seed},{row}", DENSITIES[*d].0);
                                }
                                // The field's pegs, beside the dump.
                                let path = opts.dump.as_ref().expect("dumping").with_extension("pegs.csv");
                                let c = open_config(&base, DENSITIES[*d].1, *seed, opts.duration_secs, opts.waves[0]);
                                let pegs = simserpent::model::generate(&c).map(|m| m.features.pegs).unwrap_or_default();
                                if let Ok(mut g) = std::fs::OpenOptions::new().create(true).append(true).open(&path) {
                                    for p in pegs {
                                        let _ = writeln!(
                                            g,
                                            "{},{seed},{:.4},{:.4},{:.4}",
                                            DENSITIES[*d].0, p.center_m[0], p.center_m[1], p.radius_m
                                        );
                                    }
                                }
                                let _ = f.flush();
                            }
                            // Progress on stderr, so that an interrupted study keeps its finished runs.
                            let elapsed = started.elapsed().as_secs_f64();
                            match (&task, &o) {
                                (Task::Sweep(d, seed, k), Outcome::Sweep(v, j)) => eprintln!(
                                    "[{elapsed:5.0} s] sweep {} seed {seed} wave {:.0}/{:+.0}: {:.1} mm/s{}",
                                    DENSITIES[*d].0,
                                    opts.waves[*k].amplitude_deg,
                                    opts.waves[*k].lag_deg,
                                    1000.0 * v,
                                    if *j { " JAM" } else { "" }
                                ),
                                (Task::Oracle(d, seed, _, wi), Outcome::Oracle(r)) => eprintln!(
                                    "[{elapsed:5.0} s] oracle {} seed {seed} window {} s: {:.1} mm/s{} schedule {:?}{}",
                                    DENSITIES[*d].0,
                                    opts.windows_secs[*wi],
                                    1000.0 * r.speed_m_per_s,
                                    if r.jammed { " JAM" } else { "" },
                                    r.schedule,
                                    opts.replay
                                        .iter()
                                        .zip(&r.replays)
                                        .map(|(e, r)| format!(
                                            "; replay ε={e:e}: {:.1}{} (apart after {})",
                                            1000.0 * r.speed_m_per_s,
                                            if r.jammed { " JAM" } else { "" },
                                            r.diverged_secs.map_or("never".to_string(), |t| format!("{t:.2} s"))
                                        ))
                                        .collect::<String>()
                                ),
                                _ => {}
                            }
                            results.lock().expect("no panics while locked").push((i, o));
                        }
                        Err(e) => {
                            failure.lock().expect("no panics while locked").get_or_insert(e);
                            next.store(tasks.len(), Ordering::Relaxed);
                        }
                    }
                }
            });
        }
    });
    if let Some(e) = failure.into_inner().expect("no panics while locked") {
        return Err(e);
    }
    let wall_secs = started.elapsed().as_secs_f64();
    let mut results = results.into_inner().expect("no panics while locked");
    results.sort_by_key(|r| r.0);
    let name = |w: &Wave| format!("{:.0}/{:+.0}", w.amplitude_deg, w.lag_deg);
    let mut sweep = std::collections::HashMap::new();
    if let (Some(path), true) = (&opts.sweep_csv, opts.sweep && !opts.check) {
        sweep = read_sweep_csv(path, &opts)?;
    }
    let mut oracles = std::collections::HashMap::new();
    for (i, o) in results {
        match (tasks[i], o) {
            (Task::Sweep(d, seed, k), Outcome::Sweep(v, j)) => {
                sweep.insert((d, seed, k), (v, j));
            }
            (Task::Oracle(d, seed, only, wi), Outcome::Oracle(r)) => {
                oracles.insert((d, seed, only, wi), r);
            }
            _ => unreachable!("a task's outcome is of its kind"),
        }
    }
    println!(
        "hoal_oracle: seeds {}-{}, {} s, windows {:?} s, blend {} s, {} waves [{}]{}; wall time {:.0} s on {} threads",
        opts.seeds[0],
        opts.seeds[opts.seeds.len() - 1],
        opts.duration_secs,
        opts.windows_secs,
        opts.blend_secs,
        opts.waves.len(),
        opts.waves.iter().map(name).collect::<Vec<_>>().join(" "),
        if opts.lookahead { ", one-window lookahead" } else { "" },
        wall_secs,
        opts.threads
    );
    if opts.check {
        let mut worst: f64 = 0.0;
        for (&(d, seed, only, _), r) in &oracles {
            let k = only.expect("--check runs single waves");
            let (v, j) = sweep[&(d, seed, k)];
            worst = worst.max((r.speed_m_per_s - v).abs());
            anyhow::ensure!(
                r.jammed == j,
                "check: {} seed {seed} wave {}: jam {} against score_run's {j}",
                DENSITIES[d].0,
                name(&opts.waves[k]),
                r.jammed
            );
        }
        println!(
            "check: {} single-wave oracle runs against hoal::score_run: largest speed difference {worst:.3e} m/s",
            oracles.len()
        );
        anyhow::ensure!(worst < 1e-9, "check failed: the oracle's machinery does not reproduce score_run");
        return Ok(());
    }
    for &d in &opts.densities {
        println!("\n{}:", DENSITIES[d].0);
        // The best single wave of this density (best median over the seeds, in-sample), and per
        // field the best wave in hindsight.
        let mut best_median = None;
        if opts.sweep {
            let (b, bm) = (0..opts.waves.len())
                .map(|k| (k, 1000.0 * median(&opts.seeds.iter().map(|s| sweep[&(d, *s, k)].0).collect::<Vec<_>>())))
                .max_by(|a, b| a.1.total_cmp(&b.1))
                .expect("the family is not empty");
            let best_jams = opts.seeds.iter().filter(|s| sweep[&(d, **s, b)].1).count();
            let mut hindsight = Vec::new();
            let mut hindsight_jams = 0;
            for &seed in &opts.seeds {
                let (k, (hv, hj)) = (0..opts.waves.len())
                    .map(|k| (k, sweep[&(d, seed, k)]))
                    .max_by(|a, b| a.1.0.total_cmp(&b.1.0))
                    .expect("the family is not empty");
                hindsight.push(1000.0 * hv);
                hindsight_jams += usize::from(hj);
                println!(
                    "  seed {seed:2}: best single wave {:6.1}{}  hindsight best {} {:6.1}{}",
                    1000.0 * sweep[&(d, seed, b)].0,
                    if sweep[&(d, seed, b)].1 { " JAM" } else { "" },
                    name(&opts.waves[k]),
                    1000.0 * hv,
                    if hj { " JAM" } else { "" }
                );
            }
            println!(
                "  best single wave {} median {bm:.1} mm/s, jams {best_jams}/{n}; hindsight best wave per field: median {:.1} mm/s ({:.2} x best), jams {hindsight_jams}/{n}",
                name(&opts.waves[b]),
                median(&hindsight),
                median(&hindsight) / bm,
                n = opts.seeds.len()
            );
            best_median = Some((bm, hindsight));
        }
        for (wi, window) in opts.windows_secs.iter().enumerate() {
            let mut speeds = Vec::new();
            let mut jams = 0;
            let mut beats = 0;
            for (i, &seed) in opts.seeds.iter().enumerate() {
                let r = &oracles[&(d, seed, None, wi)];
                let v = 1000.0 * r.speed_m_per_s;
                speeds.push(v);
                jams += usize::from(r.jammed);
                if let Some((_, h)) = &best_median {
                    beats += usize::from(v > h[i]);
                }
                let sched: Vec<String> = r.schedule.iter().map(|k| name(&opts.waves[*k])).collect();
                println!(
                    "  window {window} s, seed {seed:2}: oracle {v:6.1}{}  [{}]",
                    if r.jammed { " JAM" } else { "" },
                    sched.join(" ")
                );
            }
            let m = median(&speeds);
            let mut line = format!(
                "  window {window} s: ORACLE median {m:.1} mm/s, jams {jams}/{}, mean {:.1}",
                speeds.len(),
                speeds.iter().sum::<f64>() / speeds.len() as f64
            );
            if let Some((bm, h)) = &best_median {
                line.push_str(&format!(
                    "; oracle / best wave = {:.2}, oracle / (2 x best wave) = {:.2}; beats the field's hindsight best wave on {beats}/{}",
                    m / bm,
                    m / (2.0 * bm),
                    h.len()
                ));
            }
            println!("{line}");
            for (e, eps) in opts.replay.iter().enumerate() {
                let runs: Vec<Replay> =
                    opts.seeds.iter().map(|seed| oracles[&(d, *seed, None, wi)].replays[e]).collect();
                let v: Vec<f64> = runs.iter().map(|r| 1000.0 * r.speed_m_per_s).collect();
                // Runs that never left the oracle's count as apart at the run's end.
                let apart: Vec<f64> = runs.iter().map(|r| r.diverged_secs.unwrap_or(opts.duration_secs)).collect();
                println!(
                    "  window {window} s: REPLAY eps {eps:e}: median {:.1} mm/s, jams {}/{}, per seed [{}]; \
                     centre of mass {DIVERGED_M} m from the oracle's after a median {:.2} s ({} never)",
                    median(&v),
                    runs.iter().filter(|r| r.jammed).count(),
                    runs.len(),
                    v.iter().map(|x| format!("{x:.1}")).collect::<Vec<_>>().join(" "),
                    median(&apart),
                    runs.iter().filter(|r| r.diverged_secs.is_none()).count()
                );
            }
        }
    }
    Ok(())
}
