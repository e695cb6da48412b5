//! Follow-the-leader ("rail") obstacle-aided locomotion: the body follows the path its head
//! draws, so the bends stay where they are in the world and the pegs inside them keep pushing.
//!
//! Sources: follow-the-leader ("shift") control of snake robots, in which the joint angles are a
//! function of arc length along the path and are shifted down the body as it advances (H.
//! Choset and W. Henning, *A follow-the-leader approach to serpentine robot motion planning*,
//! J. Aerospace Engineering 12(2), 1999; the body-shape propagation of A. A. Transeth et al.,
//! *Snake robot obstacle-aided locomotion: modeling, simulations, and experiments*, IEEE Trans.
//! Robotics 24(1), 2008, and P. Liljebäck et al., *Snake Robots*, Springer 2013, ch. 10–11:
//! a peg that sits inside a bend pushes the body forward while the bend stays at the peg);
//! the heading hold is the line-of-sight law of `control::PathFollowing`.
//!
//! **The path.** S(t) is the arc length the head has advanced along its path (odometry). The
//! head joint (joint 0) is commanded
//!
//! ```text
//! q_head(S) = α·sin(2π S/λ + φ) + clamp(k_θ·wrap(θ̄_λ − θ_ref), ±q_steer,max) − σ·s_peg·q_wrap
//! σ = +1 if s_peg·wrap(θ₀ − θ_ref) ≥ 0, else −1
//! ```
//!
//! (α, λ the spatial sine's amplitude and wavelength; φ the phase the jam rule turns; θ̄_λ the
//! mean heading of the head over the last wavelength of path, from a ring of the head's yaw
//! against S; θ_ref = −arctan(y_c/Δ), the line of sight to the line y = 0 along +x from the
//! centre of mass' y_c; s_peg = +1 (left) / −1 (right) the side of a peg that the head or the
//! link behind it touches, 0 without one). σ = +1 when the head heads toward the peg's side
//! (relative to θ_ref): the head turns toward the peg, which ends up inside the bend the body
//! then follows, on the head side of the bend's apex, where its push on the body has a forward
//! component; σ = −1 when the head heads away from it: the head turns away (the peg would sit
//! on the bend's tail-side flank and hold the body back). Our joint angle is the child link's heading minus the
//! parent's, so a positive q_head turns the head clockwise relative to the body.
//!
//! The head's commands are written into a ring indexed by S (one sample per
//! [`SAMPLE_SPACING_M`]); joint j (whose centre of rotation is j link lengths L behind joint 0)
//! is commanded the sample at S − j·L (linear interpolation):
//!
//! ```text
//! q_j(t) = q_head(S(t) − j·L)
//! ```
//!
//! so the body's shape in the world stays put while the body slides along it ("a train on
//! rails"): a bend pressed around a peg stays at the peg.
//!
//! **The odometry.** Ṡ = g·max(0, v̄) + v_drive, where v̄ is the head's velocity along its own
//! heading (`head_velocity_m_per_s` · (cos θ₀, sin θ₀), the tracking system's velocity and the
//! gyro-integrated head yaw θ₀) low-pass filtered with time constant τ, g the progress gain
//! and v_drive a small slip speed: the shape runs down the body slightly faster than the body
//! moves, so each bend presses on the pegs that hold it.
//!
//! **The gait switch.** Where pegs are few the rail gait has nothing to push on: its
//! wave runs toward the tail, and on an isotropic floor a snake drifts the way its wave runs,
//! so it stalls or drifts backward. The controller therefore has a second gait, the floor-drift
//! wave running toward the head,
//!
//! ```text
//! q_j,drift(t) = r(t)·A_d·sin(ω t − j δ_d),   δ_d < 0,   ω = 2π·0.5 Hz
//! ```
//!
//! (r(t) the ramp-in of `gait.ramp_secs`; the default 65°/−75° is the wave that jams least for
//! its speed among the pegs of isotropic peg fields; 65°/−60° is faster on sparse
//! fields but wedges far more often), and switches between the two on what the contact estimates say the pegs
//! do along +x (world):
//!
//! ```text
//! P = Σ_i max(0,  F_obs,i,x),   R = Σ_i max(0, −F_obs,i,x)   (links with a detected contact)
//! P̄, R̄ low-pass filtered with time constant τ_c
//! rail  → drift when P̄ < P_min for T_quiet        (no peg pushes the body forward)
//! drift → rail  when R̄ > R_min after ≥ T_drift,min (pegs inside the bends hold the drift back:
//!                                                   the rail gait can press on them instead)
//! ```
//!
//! The joints blend linearly from one gait's targets to the other's over `blend_secs`. When the
//! rail gait takes over, the body's current shape is loaded into the path behind S (joint j's
//! target at S − j·L) and the head's sine continues from the head joint's angle, so the body
//! keeps its shape in the world and slides along it. Both gaits run at 0.5 Hz: the drift wave's
//! `drift_frequency_hz` and the rail wave's `drive_speed_m_per_s / wavelength_m` (1.2 m / 2.4 m
//! without progress), the base gait's frequency, so the comparison is fair.
//! `use_contacts = false` turns off every contact term (head wrap and the contact-driven
//! switches; the jam switch below stays): the comparison without contacts.
//!
//! **Jam recovery** (`jam_switch = true`; off by default: with the drift wave 65°/−75° the
//! switch and its back-off make jams by the jam rule, 22 of 120 runs on seeds 100–139
//! with it against 10 without). Every
//! `jam_window_secs` T the controller compares the centre of mass (head
//! position and encoders) with the previous checkpoint; if it advanced less than
//! `jam_min_progress_m` along +x, the snake is jammed. In the rail gait S first runs backward at
//! `backoff_speed_m_per_s` until it is `backoff_m` back (every joint retraces the path it came
//! along), the phase φ turns by a quarter wave (π/2) and the old samples ahead are forgotten;
//! then, in either gait, the controller switches to the other gait. Why (the isotropic peg fields, the
//! estimated forces and the centre of mass logged every 0.5 s in single runs): a rail jam is one of two things. Where pegs are few the
//! body is not pinned at all — it stalls with no peg in a bend (P̄ ≈ R̄ ≈ 0–3 N) and backing off
//! and redrawing the same kind of path stalls again. Where pegs are many the body is wedged:
//! P̄ ≈ R̄ ≈ 50 N, equal and opposite, and they stay so while it backs off 0.3 m along the same
//! shape, because the shape is what wedges it. The drift wave has a different shape (1.2 m
//! wavelength, 65°) and moves the body the other way along the pegs, which frees it.
//!
//! **Further options (all off by default; on seeds 20–39 none of them both jams less and
//! keeps every density's median speed).**
//!
//! ```text
//! F_x,i ← clamp(F_x,i, ±F_clip)                          before P and R (force_clip_n)
//! wedged: min(P̄, R̄) > F_wedge for T_wedge                → handled as a jam (wedge_force_n, wedge_secs)
//! relax:  a drift jam → for T_relax the drift wave blends into A_r·sin(ωt − j δ_r), then rail
//!         q_j,drift = r(t)·[(1 − m)·A_d·sin(ωt − j δ_d) + m·A_r·sin(ωt − j δ_r)],  ṁ = ±1/blend_secs
//! sliding jam window: x_c(t) − x_c(t − T) < d, x_c sampled every T/30 (sliding_jam_window)
//! drift heading hold: q_j,drift += r(t)·clamp(k_d·wrap(θ̄_body − θ_ref), ±q_steer,max)
//!         θ̄_body the body's mean heading, low-pass filtered (drift_heading_gain, _filter_secs)
//! ```
//!
//! The per-link clip keeps single spikes of the raw estimates (100–980 N) out of P̄ and R̄;
//! the wedge rule sees a wedge (both forces large) before the progress-based jam rule; the
//! relax recovery changes the body's shape (e.g. straightens it to 25°) before the rail gait
//! loads it, instead of loading the wedged shape; the sliding window sees a stall one window
//! after it begins, where the restarting windows see it one to two windows after. The runs
//! are chaotic (a last-bit rounding change of the drift targets moves single fields by tens of
//! mm/s), so with every option off the targets are computed exactly as before.
//!
//! What the controller reads: the encoders, the head gyro (yaw), the head's position and
//! velocity (a tracking system, as path following) and the contact estimates
//! (`Observation::contacts`; the simulator's truth only with `contacts = "true"`). Nothing
//! allocates after construction.

use super::{
    Command, ContactFeed, Controller, Observation, Pid, command_joint, feel, joint_pid, low_pass_gain, planar_chain,
    wrap_angle_rad, yaw_joints,
};
use crate::config::{Config, ControlMethod, RailGait};
use crate::state::ContactEstimates;
use crate::state::Snapshot;
use std::f64::consts::{FRAC_PI_2, TAU};

/// Spacing (m) of the path samples along S.
pub const SAMPLE_SPACING_M: f64 = 0.005;

/// Samples of the centre of mass per jam window (sliding window).
pub const JAM_WINDOW_SAMPLES: usize = 30;

/// The rail controller (module documentation).
#[derive(Debug, Clone)]
pub struct Rail {
    /// α (rad).
    pub amplitude_rad: f64,
    /// 2π/λ (rad/m).
    pub wavenumber_rad_per_m: f64,
    /// λ (m).
    pub wavelength_m: f64,
    /// v_drive (m/s).
    pub drive_speed_m_per_s: f64,
    /// g.
    pub progress_gain: f64,
    /// τ (s).
    pub progress_filter_secs: f64,
    /// k_θ (rad/rad), Δ (m), q_steer,max (rad).
    pub heading_gain: f64,
    pub lookahead_m: f64,
    pub max_steer_rad: f64,
    /// q_wrap (rad).
    pub wrap_rad: f64,
    /// Jam rule: window (s), progress (m), back-off distance (m) and speed (m/s).
    pub jam_window_secs: f64,
    pub jam_min_progress_m: f64,
    pub backoff_m: f64,
    pub backoff_speed_m_per_s: f64,
    /// L (m).
    pub link_length_m: f64,
    /// Where the contacts come from (estimates or, for comparison, the truth).
    pub contacts: ContactFeed,
    /// Whether the contact terms (head wrap, gait switch) act.
    pub use_contacts: bool,
    /// The drift gait: A_d (rad), δ_d (rad), ω (rad/s), ramp-in (s).
    pub drift_amplitude_rad: f64,
    pub drift_phase_lag_rad: f64,
    pub drift_angular_frequency_rad_per_s: f64,
    pub ramp_secs: f64,
    /// Gait switch: filter τ_c (s), thresholds (N) and times (s).
    pub contact_filter_secs: f64,
    pub propel_force_n: f64,
    pub no_peg_secs: f64,
    pub resist_force_n: f64,
    pub drift_min_secs: f64,
    pub blend_secs: f64,
    /// Per-link clip of the force along x (N).
    pub force_clip_n: f64,
    /// Wedge rule: both filtered forces above this (N) for this long (s).
    pub wedge_force_n: f64,
    pub wedge_secs: f64,
    /// Relax recovery: duration (s; 0 = off), the relax wave's amplitude (rad) and lag (rad).
    pub relax_secs: f64,
    pub relax_amplitude_rad: f64,
    pub relax_phase_lag_rad: f64,
    /// Drift heading hold: gain (rad/rad; signed) and filter of the body's mean heading (s).
    pub drift_heading_gain: f64,
    pub drift_heading_filter_secs: f64,
    body_heading_rad: f64,
    body_heading_set: bool,
    /// Since when both filtered forces have been above the wedge threshold (s).
    wedged_since_secs: Option<f64>,
    /// Until when the drift gait runs the relax wave (s).
    relax_until_secs: f64,
    /// Mix m ∈ [0, 1] of the relax wave into the drift gait.
    relax_mix: f64,
    /// A jam in the drift gait: relaxing, then the switch to the rail gait.
    relax_pending: bool,
    initial_gait: RailGait,
    gait: RailGait,
    /// Blend b ∈ [0, 1]: 0 all rail, 1 all drift.
    blend: f64,
    /// When the current gait started (s).
    gait_since_secs: f64,
    /// Since when the propelling force has been below its threshold (s).
    quiet_since_secs: Option<f64>,
    /// Filtered propelling and resisting obstacle forces (N).
    propel_n: f64,
    resist_n: f64,
    drift_target_rad: Vec<f64>,
    /// A jam was detected: switch the gait once the back-off (if any) is over.
    jam_pending: bool,
    yaw_joint: Vec<bool>,
    method: ControlMethod,
    pids: Vec<Pid>,
    dt_secs: f64,
    /// The head joint's command per path sample (ring indexed by sample mod length).
    path_rad: Vec<f64>,
    /// The head's yaw per path sample (same ring).
    path_yaw_rad: Vec<f64>,
    /// Index of the last written sample (samples below 0 are the straight start).
    written: i64,
    /// S (m).
    arc_m: f64,
    phase_rad: f64,
    speed_m_per_s: f64,
    head_yaw_rad: f64,
    last_time_secs: f64,
    started: bool,
    checkpoint: Option<(f64, f64)>,
    /// Whether the jam rule acts at all (`rail.jam_switch`).
    pub jam_switch: bool,
    /// Whether the jam window slides (every T/30) rather than restarting every T.
    pub sliding_jam_window: bool,
    /// The sliding window's samples of the centre of mass' x (m; ring), their count since the
    /// last restart and the time of the next one (s).
    jam_x_m: Vec<f64>,
    jam_samples: usize,
    jam_next_secs: f64,
    /// During a back-off: the S at which it ends.
    backoff_to_m: Option<f64>,
    heading_rad: Vec<f64>,
    target_rad: Vec<f64>,
    /// Latest values, for logging and tests.
    pub last: RailState,
}

/// What the rail controller did in its latest update.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RailState {
    /// S (m).
    pub arc_m: f64,
    /// v̄ (m/s), filtered.
    pub progress_speed_m_per_s: f64,
    /// q_head (rad).
    pub head_command_rad: f64,
    /// θ̄_λ (rad).
    pub path_heading_rad: f64,
    /// Centre of mass (x, y; m) from the chain.
    pub centre_of_mass_m: [f64; 2],
    /// s_peg (−1, 0, +1).
    pub peg_side: f64,
    /// Whether the body is backing off (jam recovery).
    pub backing_off: bool,
    /// Jams detected so far.
    pub jams: usize,
    /// The gait (rail or drift) and the blend toward drift (0..1).
    pub drift: bool,
    pub blend: f64,
    /// Filtered propelling and resisting obstacle forces (N).
    pub propel_force_n: f64,
    pub resist_force_n: f64,
    /// Gait switches so far.
    pub switches: usize,
    /// Wedges detected so far (also counted in `jams`).
    pub wedges: usize,
    /// Mix of the relax wave into the drift gait (0..1).
    pub relax_mix: f64,
}

impl Rail {
    /// The controller of `config` (`[rail]`, `[control]`) for `n_joints` joints.
    pub fn from_config(config: &Config, n_joints: usize) -> Self {
        let r = &config.rail;
        let l = config.snake.link_length_m;
        let reach_m = n_joints as f64 * l + r.backoff_m + r.wavelength_m + 0.5;
        let samples = (reach_m / SAMPLE_SPACING_M).ceil() as usize + 4;
        Self {
            amplitude_rad: r.amplitude_deg.to_radians(),
            wavenumber_rad_per_m: TAU / r.wavelength_m,
            wavelength_m: r.wavelength_m,
            drive_speed_m_per_s: r.drive_speed_m_per_s,
            progress_gain: r.progress_gain,
            progress_filter_secs: r.progress_filter_secs,
            heading_gain: r.heading_gain,
            lookahead_m: r.lookahead_m,
            max_steer_rad: r.max_steer_deg.to_radians(),
            wrap_rad: r.wrap_deg.to_radians(),
            jam_window_secs: r.jam_window_secs,
            jam_min_progress_m: r.jam_min_progress_m,
            backoff_m: r.backoff_m,
            backoff_speed_m_per_s: r.backoff_speed_m_per_s,
            link_length_m: l,
            contacts: ContactFeed::new(config, r.contacts, n_joints + 1),
            use_contacts: r.use_contacts,
            drift_amplitude_rad: r.drift_amplitude_deg.to_radians(),
            drift_phase_lag_rad: r.drift_phase_lag_deg.to_radians(),
            drift_angular_frequency_rad_per_s: TAU * r.drift_frequency_hz,
            ramp_secs: config.gait.ramp_secs,
            contact_filter_secs: r.contact_filter_secs,
            propel_force_n: r.propel_force_n,
            no_peg_secs: r.no_peg_secs,
            resist_force_n: r.resist_force_n,
            drift_min_secs: r.drift_min_secs,
            blend_secs: r.blend_secs,
            force_clip_n: r.force_clip_n,
            wedge_force_n: r.wedge_force_n,
            wedge_secs: r.wedge_secs,
            relax_secs: r.relax_secs,
            relax_amplitude_rad: r.relax_amplitude_deg.to_radians(),
            relax_phase_lag_rad: r.relax_phase_lag_deg.to_radians(),
            wedged_since_secs: None,
            drift_heading_gain: r.drift_heading_gain,
            drift_heading_filter_secs: r.drift_heading_filter_secs,
            body_heading_rad: 0.0,
            body_heading_set: false,
            relax_until_secs: f64::NEG_INFINITY,
            relax_mix: 0.0,
            relax_pending: false,
            initial_gait: r.initial_gait,
            gait: r.initial_gait,
            blend: if r.initial_gait == RailGait::Drift { 1.0 } else { 0.0 },
            gait_since_secs: 0.0,
            quiet_since_secs: None,
            propel_n: 0.0,
            resist_n: 0.0,
            drift_target_rad: vec![0.0; n_joints],
            jam_pending: false,
            yaw_joint: yaw_joints(config, n_joints),
            method: config.control.method,
            pids: vec![joint_pid(config); n_joints],
            dt_secs: config.general.timestep_secs,
            path_rad: vec![0.0; samples],
            path_yaw_rad: vec![0.0; samples],
            written: -1,
            arc_m: 0.0,
            phase_rad: 0.0,
            speed_m_per_s: 0.0,
            head_yaw_rad: 0.0,
            last_time_secs: 0.0,
            started: false,
            checkpoint: None,
            jam_switch: r.jam_switch,
            sliding_jam_window: r.sliding_jam_window,
            jam_x_m: vec![0.0; JAM_WINDOW_SAMPLES + 1],
            jam_samples: 0,
            jam_next_secs: 0.0,
            backoff_to_m: None,
            heading_rad: vec![0.0; n_joints + 1],
            target_rad: vec![0.0; n_joints],
            last: RailState::default(),
        }
    }

    fn slot(&self, k: i64) -> usize {
        k.rem_euclid(self.path_rad.len() as i64) as usize
    }

    /// The sample k of a ring: 0 (or the start yaw) before the start, `current` beyond the
    /// last written one.
    fn sample(&self, ring: &[f64], k: i64, before: f64, current: f64) -> f64 {
        if k < 0 {
            before
        } else if k > self.written {
            current
        } else {
            ring[self.slot(k)]
        }
    }

    /// The head command at arc length `s_m` (m) along the path: the written samples,
    /// interpolated; `current` (the head's command now) beyond the last one; 0 before the start.
    pub fn path_command_rad(&self, s_m: f64, current: f64) -> f64 {
        let x = s_m / SAMPLE_SPACING_M;
        let k = x.floor();
        let frac = x - k;
        let k = k as i64;
        let a = self.sample(&self.path_rad, k, 0.0, current);
        let b = self.sample(&self.path_rad, k + 1, 0.0, current);
        a + frac * (b - a)
    }

    /// Moves S to `s_m`, writing the head's command and yaw into every sample passed going
    /// forward (samples already written are kept while backing off: see [`Rail::step`]).
    pub fn advance_to(&mut self, s_m: f64, command_rad: f64, yaw_rad: f64) {
        let k_new = (s_m / SAMPLE_SPACING_M).floor() as i64;
        let first = (self.written + 1).max(k_new - self.path_rad.len() as i64 + 1);
        for k in first..=k_new {
            let i = self.slot(k);
            self.path_rad[i] = command_rad;
            self.path_yaw_rad[i] = yaw_rad;
        }
        if k_new > self.written {
            self.written = k_new;
        }
        self.arc_m = s_m;
    }

    /// Forgets the samples ahead of S (the head draws a new path from here).
    pub fn truncate_path(&mut self) {
        self.written = self.written.min((self.arc_m / SAMPLE_SPACING_M).floor() as i64);
    }

    /// θ̄_λ: the mean head yaw over the last wavelength of path (rad; `current` for samples not
    /// yet written, `start` before the start).
    pub fn path_heading_rad(&self, start: f64, current: f64) -> f64 {
        let k_end = (self.arc_m / SAMPLE_SPACING_M).floor() as i64;
        let n = ((self.wavelength_m / SAMPLE_SPACING_M).round() as i64).clamp(1, self.path_rad.len() as i64 - 1);
        let mut sum = 0.0;
        for k in (k_end - n + 1)..=k_end {
            sum += self.sample(&self.path_yaw_rad, k, start, current);
        }
        sum / n as f64
    }

    /// The side (+1 left, −1 right, 0 none) of a peg touching link 0 or 1: the obstacle force
    /// pushes the link away from the peg, so the peg is on the side opposite to the force's
    /// component along the link's left normal (θᵢ the link headings).
    pub fn head_peg_side(contacts: &ContactEstimates, heading_rad: &[f64]) -> f64 {
        let mut normal_sum = 0.0;
        for (i, heading) in heading_rad.iter().enumerate().take(2.min(contacts.n_links())) {
            if !contacts.contact[i] {
                continue;
            }
            let f = contacts.obstacle_force_n[i];
            let (s, c) = heading.sin_cos();
            normal_sum += -s * f[0] + c * f[1];
        }
        if normal_sum > 0.0 {
            -1.0
        } else if normal_sum < 0.0 {
            1.0
        } else {
            0.0
        }
    }

    /// The filtered propelling force P (sum over links in contact of the obstacle force's +x
    /// component, world) and resisting force R (of its −x component), both ≥ 0 (N), before
    /// filtering.
    /// Each link's component is clipped to ±`clip_n` first.
    pub fn propelling_and_resisting_n(contacts: &ContactEstimates, clip_n: f64) -> (f64, f64) {
        let mut propel = 0.0;
        let mut resist = 0.0;
        for i in 0..contacts.n_links() {
            if !contacts.contact[i] {
                continue;
            }
            let fx = contacts.obstacle_force_n[i][0].clamp(-clip_n, clip_n);
            if fx > 0.0 {
                propel += fx;
            } else {
                resist -= fx;
            }
        }
        (propel, resist)
    }

    /// Loads the body's current shape `q_rad` (joint targets) into the path behind S, so that
    /// the rail gait continues from it (joint j sits j link lengths behind the head's sample).
    /// The head's yaw fills the samples the path heading averages.
    fn load_shape(&mut self, q_rad: &[f64], yaw_rad: f64) {
        let n = q_rad.len();
        let l = self.link_length_m;
        let reach_m = self.wavelength_m.max(n as f64 * l) + 2.0 * SAMPLE_SPACING_M;
        let s0 = self.arc_m.max(reach_m);
        let k_end = (s0 / SAMPLE_SPACING_M).floor() as i64;
        let k_lo = ((s0 - reach_m) / SAMPLE_SPACING_M).floor() as i64;
        for k in k_lo.max(0)..=k_end {
            let u = ((s0 - k as f64 * SAMPLE_SPACING_M) / l).clamp(0.0, (n.max(1) - 1) as f64);
            let j = (u.floor() as usize).min(n.saturating_sub(1));
            let frac = u - j as f64;
            let a = q_rad.get(j).copied().unwrap_or(0.0);
            let b = q_rad.get(j + 1).copied().unwrap_or(a);
            let i = self.slot(k);
            self.path_rad[i] = a + frac * (b - a);
            self.path_yaw_rad[i] = yaw_rad;
        }
        self.written = k_end;
        self.arc_m = s0;
    }

    /// Starts the jam window afresh at time `t` (s) and centre-of-mass x `x_m` (m).
    fn restart_jam_window(&mut self, t: f64, x_m: f64) {
        self.checkpoint = Some((t, x_m));
        self.jam_samples = 0;
        self.jam_next_secs = t;
    }

    /// The sliding jam window: samples x every T/[`JAM_WINDOW_SAMPLES`]; true when the newest
    /// sample is less than the progress threshold ahead of the one T before it.
    fn slide_jam_window(&mut self, t: f64, x_m: f64) -> bool {
        if t < self.jam_next_secs {
            return false;
        }
        let n = self.jam_x_m.len();
        let h = self.jam_window_secs / JAM_WINDOW_SAMPLES as f64;
        self.jam_next_secs = if self.jam_samples == 0 { t + h } else { (self.jam_next_secs + h).max(t) };
        self.jam_x_m[self.jam_samples % n] = x_m;
        self.jam_samples += 1;
        // The oldest sample, T before this one (the slot written next).
        self.jam_samples >= n && x_m - self.jam_x_m[self.jam_samples % n] < self.jam_min_progress_m
    }

    fn step(&mut self, obs: &Observation, contacts: &ContactEstimates, cmd: &mut Command) {
        let t = obs.time_secs;
        if !self.started {
            // The starting heading is known (calibration); from then on the gyro integrates it.
            self.head_yaw_rad = crate::state::yaw_rad(obs.head_quat);
            self.last_time_secs = t;
            self.started = true;
            let yaw = self.head_yaw_rad;
            self.path_yaw_rad.fill(yaw);
            self.gait_since_secs = t;
        }
        let dt = (t - self.last_time_secs).max(0.0);
        self.last_time_secs = t;
        // Unwrapped: the path heading averages it.
        self.head_yaw_rad += obs.imu_gyro_rad_per_s.first().map_or(0.0, |g| g[2]) * dt;
        let head = [obs.head_position_m[0], obs.head_position_m[1]];
        let (mean_heading, com) = planar_chain(
            self.head_yaw_rad,
            head,
            &obs.joint_angle_rad,
            &self.yaw_joint,
            self.link_length_m,
            &mut self.heading_rad,
        );

        if !self.body_heading_set {
            self.body_heading_rad = mean_heading;
            self.body_heading_set = true;
        }
        self.body_heading_rad +=
            low_pass_gain(dt, self.drift_heading_filter_secs) * (mean_heading - self.body_heading_rad);

        // Odometry.
        let (s, c) = self.head_yaw_rad.sin_cos();
        let v = obs.head_velocity_m_per_s;
        let along = v[0] * c + v[1] * s;
        let alpha = low_pass_gain(dt, self.progress_filter_secs);
        self.speed_m_per_s += alpha * (along - self.speed_m_per_s);

        // What the pegs do along +x.
        let (propel, resist) =
            if self.use_contacts { Self::propelling_and_resisting_n(contacts, self.force_clip_n) } else { (0.0, 0.0) };
        let alpha_c = low_pass_gain(dt, self.contact_filter_secs);
        self.propel_n += alpha_c * (propel - self.propel_n);
        self.resist_n += alpha_c * (resist - self.resist_n);

        // Jam rule.
        let mut jammed = false;
        if self.jam_switch && self.backoff_to_m.is_none() && !self.relax_pending {
            let stalled = if self.sliding_jam_window {
                self.slide_jam_window(t, com[0])
            } else {
                match self.checkpoint {
                    None => {
                        self.restart_jam_window(t, com[0]);
                        false
                    }
                    Some((t0, x0)) if t - t0 >= self.jam_window_secs => {
                        let stalled = com[0] - x0 < self.jam_min_progress_m;
                        self.restart_jam_window(t, com[0]);
                        stalled
                    }
                    Some(_) => false,
                }
            };
            if stalled {
                jammed = true;
                self.last.jams += 1;
                self.restart_jam_window(t, com[0]);
                if self.gait == RailGait::Rail && self.backoff_m > 0.0 {
                    self.backoff_to_m = Some((self.arc_m - self.backoff_m).max(0.0));
                }
            }
        }
        // Wedge rule: both filtered forces large (the body pressed from ahead and behind).
        let relaxing = self.relax_pending && t < self.relax_until_secs;
        if self.use_contacts && self.propel_n.min(self.resist_n) > self.wedge_force_n {
            let since = *self.wedged_since_secs.get_or_insert(t);
            if t - since >= self.wedge_secs && !jammed && self.backoff_to_m.is_none() && !self.jam_pending && !relaxing
            {
                jammed = true;
                self.wedged_since_secs = None;
                self.last.jams += 1;
                self.last.wedges += 1;
                self.restart_jam_window(t, com[0]);
                if self.gait == RailGait::Rail && self.backoff_m > 0.0 {
                    self.backoff_to_m = Some((self.arc_m - self.backoff_m).max(0.0));
                }
            }
        } else {
            self.wedged_since_secs = None;
        }
        // Gait switch.
        // A jam switches the gait (the rail gait first backs off); so do the contacts. With the
        // relax recovery a jam in the drift gait first runs the relax wave for relax_secs, then
        // switches (the rail gait then starts from the relaxed shape).
        let mut switch_to = None;
        if jammed {
            self.jam_pending = true;
        }
        if self.jam_pending && self.backoff_to_m.is_none() {
            self.jam_pending = false;
            if self.relax_secs > 0.0 && self.gait == RailGait::Drift {
                self.relax_until_secs = t + self.relax_secs;
                self.relax_pending = true;
            } else {
                switch_to = Some(match self.gait {
                    RailGait::Rail => RailGait::Drift,
                    RailGait::Drift => RailGait::Rail,
                });
            }
        } else if self.relax_pending {
            if !relaxing {
                self.relax_pending = false;
                switch_to = Some(RailGait::Rail);
            }
        } else if self.use_contacts && self.backoff_to_m.is_none() {
            match self.gait {
                RailGait::Rail => {
                    if self.propel_n < self.propel_force_n {
                        let since = *self.quiet_since_secs.get_or_insert(t);
                        if t - since >= self.no_peg_secs {
                            switch_to = Some(RailGait::Drift);
                        }
                    } else {
                        self.quiet_since_secs = None;
                    }
                }
                RailGait::Drift => {
                    if t - self.gait_since_secs >= self.drift_min_secs && self.resist_n > self.resist_force_n {
                        switch_to = Some(RailGait::Rail);
                    }
                }
            }
        }
        if let Some(gait) = switch_to {
            self.gait = gait;
            self.gait_since_secs = t;
            self.quiet_since_secs = None;
            self.restart_jam_window(t, com[0]);
            self.last.switches += 1;
            if gait == RailGait::Rail {
                let shape = std::mem::take(&mut self.target_rad);
                let yaw = self.head_yaw_rad;
                self.load_shape(&shape, yaw);
                self.target_rad = shape;
                // Continue the head's sine from the head joint's command now, on the branch
                // whose slope has the drift wave's sign there.
                let q0 = self.target_rad.first().copied().unwrap_or(0.0);
                let x = if self.amplitude_rad > 0.0 { (q0 / self.amplitude_rad).clamp(-1.0, 1.0) } else { 0.0 };
                let rising = (self.drift_angular_frequency_rad_per_s * t).cos() >= 0.0;
                let theta = if rising { x.asin() } else { std::f64::consts::PI - x.asin() };
                self.phase_rad = (theta - self.wavenumber_rad_per_m * self.arc_m).rem_euclid(TAU);
            }
        }
        let step_b = if self.blend_secs > 0.0 { dt / self.blend_secs } else { 1.0 };
        self.blend = match self.gait {
            RailGait::Drift => (self.blend + step_b).min(1.0),
            RailGait::Rail => (self.blend - step_b).max(0.0),
        };

        // The head's command.
        let peg_side = if self.use_contacts { Self::head_peg_side(contacts, &self.heading_rad) } else { 0.0 };
        let start_yaw = self.path_yaw_rad[self.slot(-1)];
        let path_heading = self.path_heading_rad(start_yaw, self.head_yaw_rad);
        let reference = -(com[1] / self.lookahead_m).atan();
        let steer = (self.heading_gain * wrap_angle_rad(path_heading - reference))
            .clamp(-self.max_steer_rad, self.max_steer_rad);
        // Wrap toward a peg on the side the head heads to (it ends up inside the bend, on the
        // bend's propulsive flank); turn away from one on the other side (it would hold back).
        let toward = if peg_side * wrap_angle_rad(self.head_yaw_rad - reference) >= 0.0 { 1.0 } else { -1.0 };
        let head_command = self.amplitude_rad * (self.wavenumber_rad_per_m * self.arc_m + self.phase_rad).sin() + steer
            - toward * peg_side * self.wrap_rad;

        // Shift the path (while the rail gait has any weight).
        if self.blend < 1.0 {
            match self.backoff_to_m {
                Some(to) => {
                    let s_new = self.arc_m - self.backoff_speed_m_per_s * dt;
                    if s_new <= to {
                        self.arc_m = to;
                        self.truncate_path();
                        self.backoff_to_m = None;
                        self.phase_rad = (self.phase_rad + FRAC_PI_2) % TAU;
                        self.restart_jam_window(t, com[0]);
                    } else {
                        self.arc_m = s_new;
                    }
                }
                None => {
                    let rate = self.progress_gain * self.speed_m_per_s.max(0.0) + self.drive_speed_m_per_s;
                    let yaw = self.head_yaw_rad;
                    self.advance_to(self.arc_m + rate * dt, head_command, yaw);
                }
            }
        }

        // The drift gait's targets: its own wave, mixed with the relax wave while relaxing.
        let step_m = if self.blend_secs > 0.0 { dt / self.blend_secs } else { 1.0 };
        // (The relaxed shape is held while the rail gait blends in from it.)
        self.relax_mix = if self.gait == RailGait::Rail {
            if self.blend > 0.0 { self.relax_mix } else { 0.0 }
        } else if t < self.relax_until_secs {
            (self.relax_mix + step_m).min(1.0)
        } else {
            (self.relax_mix - step_m).max(0.0)
        };
        let m = self.relax_mix;
        let (r, _) = super::gait::ramp(t, self.ramp_secs);
        let psi = self.drift_angular_frequency_rad_per_s * t;
        // Heading hold of the drift gait: one offset on every joint (the body curves).
        let drift_steer = (self.drift_heading_gain * wrap_angle_rad(self.body_heading_rad - reference))
            .clamp(-self.max_steer_rad, self.max_steer_rad);
        // (With the options off this is exactly r·A_d·sin(ωt − j δ_d), rounding included: the
        // runs are chaotic, and a last-bit difference changes single fields' results.)
        for (j, q) in self.drift_target_rad.iter_mut().enumerate() {
            let own = (psi - j as f64 * self.drift_phase_lag_rad).sin();
            *q = r * self.drift_amplitude_rad * own;
            if m > 0.0 {
                let relax = self.relax_amplitude_rad * (psi - j as f64 * self.relax_phase_lag_rad).sin();
                *q += r * m * (relax - self.drift_amplitude_rad * own);
            }
            if drift_steer != 0.0 {
                *q += r * drift_steer;
            }
        }

        self.last = RailState {
            arc_m: self.arc_m,
            progress_speed_m_per_s: self.speed_m_per_s,
            head_command_rad: head_command,
            path_heading_rad: path_heading,
            centre_of_mass_m: com,
            peg_side,
            backing_off: self.backoff_to_m.is_some(),
            jams: self.last.jams,
            drift: self.gait == RailGait::Drift,
            blend: self.blend,
            propel_force_n: self.propel_n,
            resist_force_n: self.resist_n,
            switches: self.last.switches,
            wedges: self.last.wedges,
            relax_mix: self.relax_mix,
        };

        let b = self.blend;
        let n = obs.joint_angle_rad.len().min(cmd.position_rad.len()).min(self.target_rad.len());
        for j in 0..n {
            let target = if self.yaw_joint[j] {
                let rail = if b < 1.0 {
                    self.path_command_rad(self.arc_m - j as f64 * self.link_length_m, head_command)
                } else {
                    0.0
                };
                (1.0 - b) * rail + b * self.drift_target_rad.get(j).copied().unwrap_or(0.0)
            } else {
                0.0
            };
            let velocity = if dt > 0.0 { (target - self.target_rad[j]) / dt } else { 0.0 };
            self.target_rad[j] = target;
            command_joint(self.method, cmd, j, target, velocity, obs, &mut self.pids[j], self.dt_secs);
        }
    }
}

impl Controller for Rail {
    fn reset(&mut self) {
        self.pids.iter_mut().for_each(Pid::reset);
        self.path_rad.fill(0.0);
        self.written = -1;
        self.arc_m = 0.0;
        self.phase_rad = 0.0;
        self.speed_m_per_s = 0.0;
        self.started = false;
        self.checkpoint = None;
        self.jam_samples = 0;
        self.jam_next_secs = 0.0;
        self.backoff_to_m = None;
        self.target_rad.fill(0.0);
        self.gait = self.initial_gait;
        self.blend = if self.initial_gait == RailGait::Drift { 1.0 } else { 0.0 };
        self.gait_since_secs = 0.0;
        self.quiet_since_secs = None;
        self.propel_n = 0.0;
        self.resist_n = 0.0;
        self.drift_target_rad.fill(0.0);
        self.jam_pending = false;
        self.wedged_since_secs = None;
        self.relax_until_secs = f64::NEG_INFINITY;
        self.relax_mix = 0.0;
        self.relax_pending = false;
        self.body_heading_set = false;
        self.last = RailState::default();
    }

    fn update(&mut self, obs: &Observation, cmd: &mut Command) {
        feel(self, |c| &mut c.contacts, Self::step, obs, None, cmd);
    }

    fn needs_full_state(&self) -> bool {
        self.contacts.needs_full_state()
    }

    fn update_with_state(&mut self, obs: &Observation, state: &Snapshot, cmd: &mut Command) {
        feel(self, |c| &mut c.contacts, Self::step, obs, Some(state), cmd);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn controller(n_joints: usize) -> Rail {
        let mut c = Config::default();
        c.control.method = ControlMethod::Position;
        c.rail.initial_gait = RailGait::Rail;
        Rail::from_config(&c, n_joints)
    }

    fn drift_controller(n_joints: usize) -> Rail {
        let mut c = Config::default();
        c.control.method = ControlMethod::Position;
        c.rail.initial_gait = RailGait::Drift;
        Rail::from_config(&c, n_joints)
    }

    /// Runs `r` on `obs` from `t0` to `t1` (s) at 10 ms steps, with `obs.contacts` as given.
    fn run_for(r: &mut Rail, obs: &mut Observation, t0: f64, t1: f64, cmd: &mut Command) {
        let steps = ((t1 - t0) / 0.01).round() as usize;
        for k in 1..=steps {
            obs.time_secs = t0 + k as f64 * 0.01;
            r.update(obs, cmd);
        }
    }

    /// Contact estimates with one link pushed along `force_x_n` (world x).
    fn pushed_along_x(n_links: usize, link: usize, force_x_n: f64) -> ContactEstimates {
        let mut c = ContactEstimates::new(n_links);
        c.active = true;
        c.contact[link] = true;
        c.obstacle_force_n[link] = [force_x_n, 0.0, 0.0];
        c
    }

    #[test]
    fn propelling_and_resisting_forces_split_by_the_sign_along_x() {
        let mut c = ContactEstimates::new(5);
        c.active = true;
        c.contact[1] = true;
        c.obstacle_force_n[1] = [3.0, 7.0, 0.0];
        c.contact[2] = true;
        c.obstacle_force_n[2] = [-2.0, -9.0, 0.0];
        c.contact[3] = true;
        c.obstacle_force_n[3] = [4.0, 0.0, 0.0];
        // Link 4 has a force but no detected contact: it does not count.
        c.obstacle_force_n[4] = [-50.0, 0.0, 0.0];
        assert_eq!(Rail::propelling_and_resisting_n(&c, 1e9), (7.0, 2.0));
        // Clipped per link: a spike counts as the clip.
        c.obstacle_force_n[3] = [400.0, 0.0, 0.0];
        assert_eq!(Rail::propelling_and_resisting_n(&c, 10.0), (13.0, 2.0));
    }

    #[test]
    fn the_drift_gait_is_a_wave_running_toward_the_head() {
        let mut r = drift_controller(9);
        let mut obs = straight(9, 0.0, r.link_length_m);
        let mut cmd = Command::new(9);
        run_for(&mut r, &mut obs, 0.0, 3.0, &mut cmd);
        assert!(r.last.drift);
        let a = r.drift_amplitude_rad;
        let lag = r.drift_phase_lag_rad;
        assert!(lag < 0.0);
        let omega = r.drift_angular_frequency_rad_per_s;
        for j in 0..9 {
            let expected = a * (omega * 3.0 - j as f64 * lag).sin();
            assert!(
                (cmd.position_rad[j] - expected).abs() < 1e-9,
                "joint {j}: {} against {expected}",
                cmd.position_rad[j]
            );
        }
        // Toward the head: joint j + 1 (nearer the tail) shows now what joint j shows |δ|/ω
        // later.
        let later = a * (omega * (3.0 - lag / omega)).sin();
        assert!((cmd.position_rad[1] - later).abs() < 1e-9);
    }

    #[test]
    fn the_drift_heading_hold_offsets_every_joint_by_the_heading_error() {
        for (gain, yaw) in [(0.5, 0.3), (0.5, -0.3), (-0.5, 0.3), (2.0, 0.3)] {
            let mut r = drift_controller(9);
            r.use_contacts = false;
            r.drift_heading_gain = gain;
            // Straight along `yaw`, centre of mass on y = 0: the line of sight is along +x.
            let mut obs = straight(9, yaw, r.link_length_m);
            let mut cmd = Command::new(9);
            run_for(&mut r, &mut obs, 0.0, 2.5, &mut cmd);
            let omega = r.drift_angular_frequency_rad_per_s;
            let offset = (gain * yaw).clamp(-r.max_steer_rad, r.max_steer_rad);
            for j in 0..9 {
                let wave = r.drift_amplitude_rad * (omega * 2.5 - j as f64 * r.drift_phase_lag_rad).sin();
                assert!(
                    (cmd.position_rad[j] - wave - offset).abs() < 1e-9,
                    "gain {gain}, yaw {yaw}, joint {j}: {} against {}",
                    cmd.position_rad[j],
                    wave + offset
                );
            }
        }
    }

    #[test]
    fn rail_switches_to_drift_when_no_peg_propels_and_back_when_pegs_resist() {
        let mut r = controller(9);
        // No jam rule here: the switch is the contacts' doing.
        r.jam_window_secs = 1e9;
        let mut obs = straight(9, 0.0, r.link_length_m);
        let mut cmd = Command::new(9);
        let (quiet, blend) = (r.no_peg_secs, r.blend_secs);
        // A peg propelling the body (along +x) keeps the rail gait.
        obs.contacts = pushed_along_x(10, 5, 20.0);
        run_for(&mut r, &mut obs, 0.0, 5.0, &mut cmd);
        assert!(!r.last.drift, "{:?}", r.last);
        assert!(r.last.propel_force_n > r.propel_force_n);
        // No contacts: after the filter decays and T_quiet passes, the drift gait.
        obs.contacts = ContactEstimates::new(10);
        obs.contacts.active = true;
        run_for(&mut r, &mut obs, 5.0, 5.0 + quiet, &mut cmd);
        assert!(!r.last.drift, "too early: {:?}", r.last);
        run_for(&mut r, &mut obs, 5.0 + quiet, 5.0 + quiet + 3.0 + blend, &mut cmd);
        assert!(r.last.drift, "{:?}", r.last);
        assert_eq!(r.last.blend, 1.0);
        assert_eq!(r.last.switches, 1);
        // A peg holding the body back (along −x) brings the rail gait back.
        let t = 5.0 + quiet + 3.0 + blend;
        obs.contacts = pushed_along_x(10, 5, -20.0);
        run_for(&mut r, &mut obs, t, t + 0.5, &mut cmd);
        assert!(!r.last.drift, "{:?}", r.last);
        assert_eq!(r.last.switches, 2);
        // With the contact terms off nothing of this happens.
        let mut r = controller(9);
        r.jam_window_secs = 1e9;
        r.use_contacts = false;
        obs.contacts = ContactEstimates::new(10);
        obs.contacts.active = true;
        run_for(&mut r, &mut obs, 0.0, 10.0, &mut cmd);
        assert!(!r.last.drift);
        assert_eq!(r.last.switches, 0);
    }

    #[test]
    fn a_jam_switches_the_gait() {
        // The snake does not move at all (the same observation every step). With the default
        // `jam_switch = false` nothing happens.
        let mut r = drift_controller(9);
        r.use_contacts = false;
        let mut obs = straight(9, 0.0, r.link_length_m);
        let mut cmd = Command::new(9);
        let window = r.jam_window_secs;
        assert!(!r.jam_switch);
        run_for(&mut r, &mut obs, 0.0, 3.0 * window, &mut cmd);
        assert_eq!(r.last.jams, 0);
        assert!(r.last.drift && !r.last.backing_off, "{:?}", r.last);
        let mut r = drift_controller(9);
        r.use_contacts = false;
        r.jam_switch = true;
        let backoff_secs = r.backoff_m / r.backoff_speed_m_per_s;
        run_for(&mut r, &mut obs, 0.0, window + 0.5, &mut cmd);
        assert_eq!(r.last.jams, 1);
        assert!(!r.last.drift, "a jam in the drift gait switches to rail: {:?}", r.last);
        // In the rail gait a jam first backs off, then switches to drift.
        let t = window + 0.5;
        run_for(&mut r, &mut obs, t, t + window, &mut cmd);
        assert_eq!(r.last.jams, 2);
        assert!(r.last.backing_off);
        assert!(!r.last.drift);
        run_for(&mut r, &mut obs, t + window, t + window + backoff_secs + 0.1, &mut cmd);
        assert!(!r.last.backing_off);
        assert!(r.last.drift, "{:?}", r.last);
    }

    /// Contact estimates with link 3 pushed forward and link 6 back, `force_n` each (world x).
    fn wedged(force_n: f64) -> ContactEstimates {
        let mut c = pushed_along_x(10, 3, force_n);
        c.contact[6] = true;
        c.obstacle_force_n[6] = [-force_n, 0.0, 0.0];
        c
    }

    #[test]
    fn a_wedge_is_a_jam_detected_from_the_forces() {
        let mut r = drift_controller(9);
        // Only the wedge rule can fire here.
        r.jam_window_secs = 1e9;
        r.wedge_force_n = 30.0;
        r.wedge_secs = 1.0;
        r.drift_min_secs = 1e9;
        let mut obs = straight(9, 0.0, r.link_length_m);
        let mut cmd = Command::new(9);
        // Pressed from ahead only: no wedge.
        obs.contacts = pushed_along_x(10, 3, 60.0);
        run_for(&mut r, &mut obs, 0.0, 6.0, &mut cmd);
        assert_eq!(r.last.wedges, 0, "{:?}", r.last);
        // Pressed from ahead and behind by 60 N each: the filtered forces pass 30 N after
        // τ_c·ln 2 and the wedge fires wedge_secs later, then the jam switch acts (drift → rail).
        obs.contacts = wedged(60.0);
        let fires = 6.0 + r.contact_filter_secs * 2f64.ln() + r.wedge_secs;
        run_for(&mut r, &mut obs, 6.0, fires - 0.1, &mut cmd);
        assert_eq!(r.last.wedges, 0, "too early: {:?}", r.last);
        run_for(&mut r, &mut obs, fires - 0.1, fires + 0.1, &mut cmd);
        assert_eq!(r.last.wedges, 1, "{:?}", r.last);
        assert_eq!(r.last.jams, 1);
        assert!(!r.last.drift, "{:?}", r.last);
        // Spikes clipped per link: 20 N a link never reaches the 30-N wedge threshold.
        let mut r = drift_controller(9);
        r.jam_window_secs = 1e9;
        r.wedge_force_n = 30.0;
        r.force_clip_n = 20.0;
        obs.contacts = wedged(500.0);
        run_for(&mut r, &mut obs, 0.0, 10.0, &mut cmd);
        assert_eq!(r.last.wedges, 0, "{:?}", r.last);
        assert!((r.last.propel_force_n - 20.0).abs() < 0.1, "{:?}", r.last);
    }

    #[test]
    fn the_relax_recovery_changes_the_drift_wave_then_switches() {
        let mut r = drift_controller(9);
        r.use_contacts = false;
        r.jam_switch = true;
        r.relax_secs = 4.0;
        r.relax_amplitude_rad = 50f64.to_radians();
        r.relax_phase_lag_rad = (-60f64).to_radians();
        let mut obs = straight(9, 0.0, r.link_length_m);
        let mut cmd = Command::new(9);
        let window = r.jam_window_secs;
        // The snake does not move: a jam after the window; the gait stays drift for relax_secs
        // and the relax wave blends in over blend_secs.
        let t1 = window + r.blend_secs + 0.2;
        run_for(&mut r, &mut obs, 0.0, t1, &mut cmd);
        assert_eq!(r.last.jams, 1);
        assert!(r.last.drift, "{:?}", r.last);
        assert_eq!(r.last.relax_mix, 1.0);
        let omega = r.drift_angular_frequency_rad_per_s;
        for j in 0..9 {
            let expected = r.relax_amplitude_rad * (omega * t1 - j as f64 * r.relax_phase_lag_rad).sin();
            assert!(
                (cmd.position_rad[j] - expected).abs() < 1e-9,
                "joint {j}: {} against {expected}",
                cmd.position_rad[j]
            );
        }
        // relax_secs after the jam the gait switches to rail, starting from the relaxed shape.
        let t2 = window + r.relax_secs + 0.05;
        run_for(&mut r, &mut obs, t1, t2, &mut cmd);
        assert!(!r.last.drift, "{:?}", r.last);
        assert_eq!(r.last.switches, 1);
        assert_eq!(r.last.jams, 1);
        assert_eq!(r.last.relax_mix, 1.0, "held while the rail gait blends in: {:?}", r.last);
        let blend = r.last.blend;
        assert!(blend > 0.9, "{:?}", r.last);
        for j in 0..9 {
            let relaxed = r.relax_amplitude_rad * (omega * t2 - j as f64 * r.relax_phase_lag_rad).sin();
            assert!(
                (cmd.position_rad[j] - relaxed).abs() < 0.1,
                "joint {j}: {} against {relaxed}",
                cmd.position_rad[j]
            );
        }
        // Without the relax recovery the same jam switches at once.
        let mut r = drift_controller(9);
        r.use_contacts = false;
        r.jam_switch = true;
        run_for(&mut r, &mut obs, 0.0, window + 0.05, &mut cmd);
        assert!(!r.last.drift, "{:?}", r.last);
    }

    #[test]
    fn the_sliding_jam_window_sees_a_stall_one_window_after_it_starts() {
        // The body advances 0.1 m/s for 4 s, then stops. T = 3 s, 5 cm: the progress over the
        // last T falls below 5 cm at t = 6.5 s. Windows restarting every T check at 3 s
        // (0.3 m), 6 s (0.1 m) and 9 s: they see the stall only at 9 s.
        let run = |sliding: bool, until_secs: f64| {
            let mut r = drift_controller(9);
            r.use_contacts = false;
            r.jam_switch = true;
            r.sliding_jam_window = sliding;
            let mut obs = straight(9, 0.0, r.link_length_m);
            let x0 = obs.head_position_m[0];
            let mut cmd = Command::new(9);
            let steps = (until_secs / 0.01).round() as usize;
            for k in 1..=steps {
                let t = k as f64 * 0.01;
                obs.time_secs = t;
                obs.head_position_m[0] = x0 + 0.1 * t.min(4.0);
                r.update(&obs, &mut cmd);
            }
            r.last.jams
        };
        assert_eq!(run(true, 6.4), 0);
        assert_eq!(run(true, 6.7), 1);
        assert_eq!(run(false, 8.9), 0);
        assert_eq!(run(false, 9.1), 1);
    }

    #[test]
    fn switching_to_rail_keeps_the_body_shape() {
        let mut r = controller(9);
        let shape: Vec<f64> = (0..9).map(|j| 0.1 * j as f64 - 0.3).collect();
        r.arc_m = 0.4;
        r.load_shape(&shape, 0.0);
        let l = r.link_length_m;
        // (The head's own sample is interpolated toward the head's command now: shape[0] when
        // the rail gait takes over.)
        for (j, q) in shape.iter().enumerate() {
            let got = r.path_command_rad(r.arc_m - j as f64 * l, shape[0]);
            assert!((got - q).abs() < 1e-9, "joint {j}: {got} against {q}");
        }
        // Between joints: linear.
        let mid = r.path_command_rad(r.arc_m - 2.5 * l, shape[0]);
        assert!((mid - 0.5 * (shape[2] + shape[3])).abs() < 1e-3, "{mid}");
    }

    /// An observation of a straight snake whose head points along `yaw_rad`, its centre of
    /// mass on the line y = 0.
    fn straight(n_joints: usize, yaw_rad: f64, link_length_m: f64) -> Observation {
        let mut obs = Observation::new(n_joints + 1, n_joints);
        obs.head_quat = [(0.5 * yaw_rad).cos(), 0.0, 0.0, (0.5 * yaw_rad).sin()];
        let half_body_m = 0.5 * (n_joints + 1) as f64 * link_length_m;
        obs.head_position_m = [half_body_m * yaw_rad.cos(), half_body_m * yaw_rad.sin(), 0.0];
        obs
    }

    #[test]
    fn joints_repeat_the_head_command_one_link_length_later() {
        let mut r = controller(4);
        let l = r.link_length_m;
        // The head draws q(S) = S (rad per m) for 1 m of path.
        let steps = 200;
        for k in 1..=steps {
            let s = k as f64 * 1.0 / steps as f64;
            r.advance_to(s, s, 0.0);
        }
        let s = r.arc_m;
        for j in 1..4 {
            let back = s - j as f64 * l;
            let got = r.path_command_rad(back, 99.0);
            assert!((got - back).abs() < 2.0 * SAMPLE_SPACING_M, "joint {j}: {got} against {back}");
        }
        // Before the start of the path the body is straight; ahead of it, the head's command now.
        assert_eq!(r.path_command_rad(-0.3, 99.0), 0.0);
        assert_eq!(r.path_command_rad(s + 0.1, 99.0), 99.0);
    }

    #[test]
    fn backing_off_retraces_the_path_then_the_head_draws_a_new_one() {
        let mut r = controller(4);
        for k in 1..=100 {
            let s = k as f64 * 0.01;
            r.advance_to(s, s, 0.0);
        }
        // Back off 0.3 m: the samples there are the old ones.
        r.arc_m = 0.7;
        assert!((r.path_command_rad(0.75, -5.0) - 0.75).abs() < 0.02);
        r.truncate_path();
        // Going forward again overwrites what lies ahead.
        r.advance_to(0.9, -5.0, 0.0);
        assert_eq!(r.path_command_rad(0.85, 0.0), -5.0);
        assert!((r.path_command_rad(0.5, 0.0) - 0.5).abs() < 0.02);
    }

    #[test]
    fn peg_side_is_opposite_to_the_push() {
        let mut c = ContactEstimates::new(5);
        let heading = [0.0; 5];
        assert_eq!(Rail::head_peg_side(&c, &heading), 0.0);
        // A force along the head's left normal (+y for heading 0): the peg is on its right.
        c.contact[0] = true;
        c.obstacle_force_n[0] = [0.0, 4.0, 0.0];
        assert_eq!(Rail::head_peg_side(&c, &heading), -1.0);
        c.obstacle_force_n[0] = [1.0, -4.0, 0.0];
        assert_eq!(Rail::head_peg_side(&c, &heading), 1.0);
        // Links behind the second do not count.
        c.contact[0] = false;
        c.contact[3] = true;
        c.obstacle_force_n[3] = [0.0, 4.0, 0.0];
        assert_eq!(Rail::head_peg_side(&c, &heading), 0.0);
    }

    #[test]
    fn heading_left_of_the_goal_turns_the_head_right() {
        let mut r = controller(9);
        r.amplitude_rad = 0.0;
        r.wrap_rad = 0.0;
        let yaw = 0.3;
        let obs = straight(9, yaw, r.link_length_m);
        let mut cmd = Command::new(9);
        r.update(&obs, &mut cmd);
        // A positive joint angle turns the head clockwise relative to the body.
        let expected = (r.heading_gain * yaw).min(r.max_steer_rad);
        assert!((cmd.position_rad[0] - expected).abs() < 1e-6, "{} against {expected}", cmd.position_rad[0]);
        // Mirrored heading, mirrored turn.
        let mut r = controller(9);
        r.amplitude_rad = 0.0;
        r.wrap_rad = 0.0;
        r.update(&straight(9, -yaw, r.link_length_m), &mut cmd);
        assert!((cmd.position_rad[0] + expected).abs() < 1e-6);
    }

    #[test]
    fn the_head_wraps_toward_a_peg_ahead_and_turns_away_from_one_behind() {
        let run = |yaw: f64, force_y_n: f64| {
            let mut r = controller(9);
            r.amplitude_rad = 0.0;
            r.heading_gain = 0.0;
            let mut obs = straight(9, yaw, r.link_length_m);
            obs.contacts = ContactEstimates::new(10);
            obs.contacts.active = true;
            obs.contacts.contact[0] = true;
            obs.contacts.obstacle_force_n[0] = [-yaw.sin() * force_y_n, yaw.cos() * force_y_n, 0.0];
            let mut cmd = Command::new(9);
            r.update(&obs, &mut cmd);
            (cmd.position_rad[0], r.wrap_rad)
        };
        // Heading left (yaw > 0) with a peg on the left (pushed right): turn left, toward it
        // (a negative joint angle turns the head counter-clockwise).
        let (q, wrap) = run(0.2, -4.0);
        assert!((q + wrap).abs() < 1e-9, "{q}");
        // Heading left with a peg on the right: turn left, away from it.
        let (q, wrap) = run(0.2, 4.0);
        assert!((q + wrap).abs() < 1e-9, "{q}");
        // Heading right with a peg on the right: turn right, toward it.
        let (q, wrap) = run(-0.2, 4.0);
        assert!((q - wrap).abs() < 1e-9, "{q}");
    }
}
