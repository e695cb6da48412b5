//! Obstacle-aided locomotion with force feedback: the snake feels the pegs it touches (contact
//! estimates from its joint force/torque sensors and IMUs) and shapes its body to push against
//! the ones that drive it forward.
//!
//! Sources: the hybrid position/force principle of M. Yoshikawa and J. Sudou (force control
//! across the contact, position control along it; Yoshikawa, *Dynamic hybrid position/force
//! control of robot manipulators*, IEEE J. Robotics and Automation 3(5), 1987, as applied to
//! Boa in the thesis' reference list); the obstacle-aided locomotion schemes of A. A. Transeth,
//! R. I. Leine, C. Glocker, K. Y. Pettersen and P. Liljebäck (*Snake robot obstacle-aided
//! locomotion: modeling, simulations, and experiments*, IEEE Trans. Robotics 24(1), 88–104,
//! 2008) and Liljebäck, Pettersen, Stavdahl and Gravdahl (*Snake Robots: Modelling,
//! Mechatronics, and Control*, Springer 2013, ch. 10–11, and *Hybrid modelling and control of
//! obstacle-aided snake robot locomotion*, IEEE Trans. Robotics 26(5), 2010): a peg pushes the
//! snake forward when its contact force has a component along the direction of travel; bends
//! that press on such pegs are kept while the body slides past them, i.e. they move toward the
//! tail at the snake's forward speed.
//!
//! **The wave.** Joint j (0 right behind the head) follows
//!
//! ```text
//! φ_j,ref = r(t)·α·sin(ψ − j δ) + o_j,       ψ̇ = ω (or as below)
//! ```
//!
//! with α = `amplitude_deg`, δ = `phase_lag_deg` (the controller's own), ω = 2πf from
//! `gait.sine_wave.frequency_hz` (0.5 Hz by default, the base gait's frequency, so
//! the comparison is fair), r(t) the ramp-in of `gait.ramp_secs`, ψ the wave's phase and o_j
//! the contact offset of joint j plus the heading offset r(t)·φ_h. **The sign of δ is the
//! wave's direction**: δ > 0 makes the wave run from the head toward the tail (ordinary
//! lateral undulation), δ < 0 from the tail toward the head. On an isotropic Coulomb floor a
//! snake drifts the way its wave runs, so there δ < 0 is the forward gait. The default,
//! 65°/−75°, is the wave that jams least for its speed among the isotropic peg fields' pegs (see below);
//! among pegs on a wave toward the head the bends push the pegs forward and the pegs push the
//! body back (they resist), the reverse of obstacle-aided undulation on an ordinary wave.
//! With `wave_speed = "fixed"` ψ̇ = +ω; with `"progress"` (only for δ > 0)
//!
//! ```text
//! ψ̇ = min(ω, ω_d + δ·v/L)
//! ```
//!
//! (v the measured forward speed below, ω_d = 2π·`drive_frequency_hz`): the wave's bends run
//! down the body at v, i.e. they stay in place in the world while the body advances (Kano et
//! al.'s follow-the-leader shape propagation, *Local reflexive mechanisms essential for snakes'
//! scaffold-based locomotion*, Bioinspir. Biomim. 7, 2012), and press backward at ω_d/δ joints
//! per second when the snake does not advance. During a jam recovery see below.
//!
//! **Heading control** (as path following, `control::path`): every joint gets
//! φ_h = clamp(sign(δ)·k_θ·wrap(θ̃ − θ_g), ±φ_h,max) with θ_g = `goal_heading_deg` and θ̃ the
//! mean heading θ̄ through a first-order low-pass filter of time constant
//! `heading_filter_secs` (θ̄ swings with the wave). A positive joint offset turns a snake on an
//! ordinary wave clockwise, one on a wave running toward the head counterclockwise (measured on
//! the isotropic peg fields: with path following's sign the reversed wave turned away from the goal,
//! 5 mm/s against 42 mm/s without heading control), hence sign(δ). The forward speed counts
//! along θ_g.
//!
//! **What the controller measures.** Link headings θ₀ = head yaw (the head gyro's yaw rate
//! integrated from the starting heading), θᵢ = θᵢ₋₁ + qᵢ₋₁ (encoders; our joint angle is the
//! child's heading minus the parent's); the mean heading θ̄ and û = (cos θ̄, sin θ̄), the
//! direction of travel; each link's left normal n̂ᵢ = (−sin θᵢ, cos θᵢ). From the contacts
//! (`Observation::contacts`, or the simulator's truth with `contacts = "true"`): per link the
//! flag, the horizontal obstacle force f on the link and the contact point a along it (signed
//! distance from the centre, + toward the head). The centre of mass (for the jam rule) follows
//! from the head's position (a tracking system, as for path following) and the chain; the
//! forward speed v = max(0, v_head·û) from the head's velocity — or, with heading control
//! (k_θ > 0) or `wave_speed = "progress"`, v = max(0, v̄) with v̄ the centre of mass's velocity
//! along θ_g through a first-order low-pass filter of time constant `speed_filter_secs`.
//!
//! **The force law** (every link i with a contact; f_n = f·n̂ᵢ the force across the link,
//! f_fwd = f·ĝ its component along the goal direction ĝ = (cos θ_g, sin θ_g) in the world;
//! the peg is on the side s = −sign(f_n)):
//!
//! ```text
//! g_i = k_p·(F_ref − |f_n|)·Δt    if f_fwd > 0   (the peg propels: press on it until |f_n| = F_ref)
//! g_i = −k_y·|f_n|·Δt              if f_fwd ≤ 0   (the peg resists: yield, lower that bend)
//! ```
//!
//! (k_p = `force_gain_rad_per_n_s`, k_y = `yield_gain_rad_per_n_s`; `contact_feedback = false`
//! switches the law off: the same controller without its contact terms.)
//! g_i > 0 deepens a bend whose apex, the joint at the contact, moves toward the peg: a bend
//! with its apex at joint k toward side s is the joint pattern (Δo_{k−1}, Δo_k, Δo_{k+1}) =
//! s·g·(−1, +2, −1) (link k turns toward s going tailward, link k+1 back: joint k moves toward s
//! relative to its neighbours). The apex is the contact's nearer joint: the front joint of link
//! i (k = i − 1) with weight w = clamp(½ + a/L, 0, 1), the rear one (k = i) with 1 − w
//! (w = ½ without a contact point). This is force control across the contact (the offset
//! integrates the force error) and position control along the body (the wave's angles are
//! untouched where nothing pushes). Every step the offsets then relax,
//! o_j ← o_j·(1 − λΔt), are clamped to ±o_max and move along the body by σ joints per step
//! (a first-order upwind shift, o_j ← (1 − σ)·o_j + σ·o_{j∓1}): with `propagation =
//! "progress"` toward the tail at σ = v·Δt/L, so a bend stays where the peg is while the body
//! slides past it; with `"wave"` at the speed of the wave's bends, ψ̇/δ joints per second
//! (toward the head when it is negative), so the extra bend pressed on a peg travels with the
//! wave's bend that presses it; with `"none"` not at all.
//!
//! **Jam recovery.** Every `jam_window_secs` T (from the end of the ramp) the controller
//! compares the centre of mass with the previous checkpoint: if it advanced less than
//! `jam_min_progress_m` along the checkpoint's û, the snake is jammed: the contact offsets are
//! cleared and for `recovery_secs` (0: never) the wave, by `recovery`, runs the other way
//! (`"reverse"`, ψ̇ = −ω: on an ordinary wave the snake backs off the pegs; on a wave toward
//! the head this is the ordinary wave), stops (`"pause"`, ψ̇ = 0) or goes on at
//! `recovery_amplitude_deg` (`"amplitude"`); the next window starts when it ends.
//! On the isotropic peg fields with the wave toward the head none of the three freed the body more
//! often than no recovery at all, so the default is
//! `recovery_secs = 0`.
//!
//! **The second wave** (`switch = "resist"`; off by default). The estimates give the resisting
//! force R = Σ_i max(0, −f_i·ĝ) over the links in contact (what the pegs push against the goal
//! direction), low-pass filtered with `contact_filter_secs`. When R > `switch_force_n` while
//! the filtered forward speed v̄ (the centre of mass along ĝ, `speed_filter_secs`) is below
//! `switch_max_speed_m_per_s`, the joints blend linearly over `blend_secs` to a second wave
//! (α₂ = `switch_amplitude_deg`, δ₂ = `switch_phase_lag_deg`, the same phase ψ):
//!
//! ```text
//! φ_j,ref = r(t)·(1 − s_j)·[(1 − b)·α·sin(ψ − jδ) + b·α₂·sin(ψ − jδ₂)] + o_j
//! ```
//!
//! (b ∈ [0, 1] the blend). The second wave, once selected, runs at least `switch_secs`, the
//! first, once back, at least `first_wave_secs`; the first returns by `switch_exit`: `"resist"` once R ≤ `switch_force_n` (the second wave is an
//! escape from a peg, e.g. a wave that jams less), `"stall"` once v̄ is below
//! `switch_max_speed_m_per_s` (the second wave stays while it moves, e.g. the ordinary wave
//! 65°/+30° that the pegs propel where they resist the wave toward the head).
//!
//! **Full yield** (`straighten = true`; off by default). s_j ∈ [0, 1] above flattens the wave at
//! joint j: at the two joints of a link whose force against the goal, −f_i·ĝ, exceeds
//! `straighten_force_n` its target is 1, elsewhere 0; every step s first moves along the body
//! with the wave's bends (the upwind shift below, ψ̇/δ joints per second) and then approaches
//! its target with time constant `straighten_secs`. The bend that presses a resisting peg goes
//! flat for as long as the contact lasts, and the flattening travels with the wave.
//! `contact_feedback = false` switches both off (they read the contacts).
//!
//! **What is measured.** On the isotropic peg fields, with 65°/−60°, pressing and yielding, the
//! controller is as fast as the open-loop 65°/−60° wave and jams as often; with
//! `contact_feedback = false` it is as fast (the yield and press terms sit within the
//! field-to-field noise), and on the bare floor it is faster than among any pegs. The pegs only
//! hinder a wave toward the head on isotropic friction.
//!
//! **The defaults: 65°/−75°, yield only.** A jam (no progress for 5 s) on a
//! wave toward the head is the body wedged between pegs, and how often it happens depends on
//! the wave's lag far more than on any contact term: on 120 isotropic peg fields outside its seeds
//! (100–139) the open-loop 65°/−60° wave jams in 33 runs (42 mm/s median), 65°/−70° in 11,
//! 65°/−75° in 2 (31 mm/s), 65°/−80° in 1 (30 mm/s), 65°/−90° in none (21 mm/s). Pressing on
//! propelling pegs deepens the bends and wedges the body: on 270 fields (seeds 0–9, 100–139,
//! 200–239) the controller on 65°/−75° jams in 16 runs with pressing (`force_gain_rad_per_n_s`
//! = 0.3) and in 9 without (the open-loop wave: 8); the medians differ by less than 0.4 mm/s.
//! So pressing is off by default (`force_gain_rad_per_n_s = 0`) and the contact law yields
//! only. Details: BENCHMARKS.md, "Obstacle-aided locomotion".
//!
//! Nothing allocates after construction.

use super::gait::ramp;
use super::{
    Command, ContactFeed, Controller, GyroYaw, Observation, Pid, command_joint, feel, joint_pid, low_pass_gain,
    planar_chain, wrap_angle_rad, yaw_joints,
};
use crate::config::{Config, ContactSource, ControlMethod, Propagation, Recovery, SwitchExit, WaveSpeed, WaveSwitch};
use crate::state::ContactEstimates;
use crate::state::Snapshot;
use std::f64::consts::TAU;

/// The obstacle-aided controller (module documentation).
#[derive(Debug, Clone)]
pub struct ObstacleAided {
    /// α (rad), ω (rad/s), δ (rad), ramp (s).
    pub amplitude_rad: f64,
    pub angular_frequency_rad_per_s: f64,
    pub phase_lag_rad: f64,
    pub ramp_secs: f64,
    /// F_ref (N).
    pub target_force_n: f64,
    /// k_p (rad per N and s): pressing on propelling pegs.
    pub force_gain_rad_per_n_s: f64,
    /// k_y (rad per N and s): yielding at resisting pegs.
    pub yield_gain_rad_per_n_s: f64,
    /// Whether the contacts feed the law at all (false: the same controller without its
    /// contact terms).
    pub contact_feedback: bool,
    /// o_max (rad).
    pub max_offset_rad: f64,
    /// λ (1/s).
    pub release_per_s: f64,
    /// How the offsets move along the body.
    pub propagation: Propagation,
    /// Jam rule: window T (s), progress (m), recovery time (s).
    pub jam_window_secs: f64,
    pub jam_min_progress_m: f64,
    pub recovery_secs: f64,
    /// What the wave does during a jam recovery, and the amplitude (rad) of `Recovery::Amplitude`.
    pub recovery: Recovery,
    pub recovery_amplitude_rad: f64,
    /// L (m).
    pub link_length_m: f64,
    /// Where the contacts come from (estimates or, for comparison, the truth).
    pub contacts: ContactFeed,
    /// Heading control: k_θ (rad per rad), goal heading θ_g (rad), largest offset (rad).
    pub heading_gain: f64,
    pub goal_heading_rad: f64,
    pub max_heading_offset_rad: f64,
    /// Time constant (s) of the low-pass filter on the mean heading (0: none).
    pub heading_filter_secs: f64,
    filtered_heading_rad: Option<f64>,
    /// How fast the phase runs; the drive ω_d (rad/s) of `WaveSpeed::Progress`.
    pub wave_speed: WaveSpeed,
    pub drive_angular_frequency_rad_per_s: f64,
    /// Time constant (s) of the forward-speed filter.
    pub speed_filter_secs: f64,
    /// The second wave and its trigger (module documentation, "The second wave").
    pub switch: WaveSwitch,
    pub switch_amplitude_rad: f64,
    pub switch_phase_lag_rad: f64,
    pub contact_filter_secs: f64,
    pub switch_force_n: f64,
    pub switch_max_speed_m_per_s: f64,
    pub switch_secs: f64,
    pub first_wave_secs: f64,
    pub switch_exit: SwitchExit,
    pub blend_secs: f64,
    /// Full yield (module documentation, "Full yield").
    pub straighten: bool,
    pub straighten_force_n: f64,
    pub straighten_secs: f64,
    /// Filtered resisting force R (N).
    resist_force_n: f64,
    /// Whether the second wave is selected, since when (s) either wave runs, and the blend
    /// b ∈ [0, 1].
    switched: bool,
    switched_since_secs: f64,
    blend: f64,
    /// Flattening s_j ∈ [0, 1] of the wave at joint j, and its per-step target (scratch).
    flatten: Vec<f64>,
    flatten_target: Vec<f64>,
    /// The wave's phase rate ψ̇ (rad/s) of the current step (ω with `WaveSpeed::Fixed`).
    wave_phase_rate_rad_per_s: f64,
    /// Filtered forward speed v (m/s) and the previous centre of mass it differentiates.
    speed_m_per_s: f64,
    last_com_m: Option<[f64; 2]>,
    yaw_joint: Vec<bool>,
    method: ControlMethod,
    pids: Vec<Pid>,
    dt_secs: f64,
    /// o_j (rad).
    offset_rad: Vec<f64>,
    /// θᵢ (rad), scratch.
    heading_rad: Vec<f64>,
    phase_rad: f64,
    yaw: GyroYaw,
    checkpoint: Option<(f64, [f64; 2], [f64; 2])>,
    recovering_until_secs: f64,
    /// Latest values, for logging and tests.
    pub last: ObstacleAidedState,
}

/// What the controller did in its latest update.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ObstacleAidedState {
    /// θ̄ (rad).
    pub mean_heading_rad: f64,
    /// Centre of mass (x, y; m) from the chain.
    pub centre_of_mass_m: [f64; 2],
    /// v (m/s).
    pub forward_speed_m_per_s: f64,
    /// Links with a contact that propels / that holds back.
    pub propulsive_contacts: usize,
    pub resistive_contacts: usize,
    /// Whether a jam recovery runs.
    pub recovering: bool,
    /// The heading offset φ_h (rad) on every joint.
    pub heading_offset_rad: f64,
    /// The wave's phase rate ψ̇ (rad/s).
    pub phase_rate_rad_per_s: f64,
    /// Jams detected so far.
    pub jams: usize,
    /// Filtered resisting force R (N), whether the second wave is selected, the blend b, and
    /// how often the second wave was selected so far.
    pub resist_force_n: f64,
    pub switched: bool,
    pub blend: f64,
    pub switches: usize,
}

impl ObstacleAided {
    /// The controller of `config` (`[obstacle_aided]`, `gait.sine_wave.frequency_hz`, `[control]`) for
    /// `n_joints` joints.
    pub fn from_config(config: &Config, n_joints: usize) -> Self {
        let w = &config.gait.sine_wave;
        let o = &config.obstacle_aided;
        Self {
            amplitude_rad: o.amplitude_deg.to_radians(),
            angular_frequency_rad_per_s: TAU * w.frequency_hz,
            phase_lag_rad: o.phase_lag_deg.to_radians(),
            ramp_secs: config.gait.ramp_secs,
            target_force_n: o.target_force_n,
            force_gain_rad_per_n_s: o.force_gain_rad_per_n_s,
            yield_gain_rad_per_n_s: o.yield_gain_rad_per_n_s,
            contact_feedback: o.contact_feedback,
            max_offset_rad: o.max_offset_deg.to_radians(),
            release_per_s: o.release_per_s,
            propagation: o.propagation,
            jam_window_secs: o.jam_window_secs,
            jam_min_progress_m: o.jam_min_progress_m,
            recovery_secs: o.recovery_secs,
            recovery: o.recovery,
            recovery_amplitude_rad: o.recovery_amplitude_deg.to_radians(),
            link_length_m: config.snake.link_length_m,
            contacts: ContactFeed::new(config, o.contacts, n_joints + 1),
            heading_gain: o.heading_gain,
            goal_heading_rad: o.goal_heading_deg.to_radians(),
            max_heading_offset_rad: o.max_heading_offset_deg.to_radians(),
            heading_filter_secs: o.heading_filter_secs,
            filtered_heading_rad: None,
            wave_speed: o.wave_speed,
            drive_angular_frequency_rad_per_s: TAU * o.drive_frequency_hz,
            speed_filter_secs: o.speed_filter_secs,
            switch: o.switch,
            switch_amplitude_rad: o.switch_amplitude_deg.to_radians(),
            switch_phase_lag_rad: o.switch_phase_lag_deg.to_radians(),
            contact_filter_secs: o.contact_filter_secs,
            switch_force_n: o.switch_force_n,
            switch_max_speed_m_per_s: o.switch_max_speed_m_per_s,
            switch_secs: o.switch_secs,
            first_wave_secs: o.first_wave_secs,
            switch_exit: o.switch_exit,
            blend_secs: o.blend_secs,
            straighten: o.straighten,
            straighten_force_n: o.straighten_force_n,
            straighten_secs: o.straighten_secs,
            resist_force_n: 0.0,
            switched: false,
            switched_since_secs: f64::NEG_INFINITY,
            blend: 0.0,
            flatten: vec![0.0; n_joints],
            flatten_target: vec![0.0; n_joints],
            speed_m_per_s: 0.0,
            wave_phase_rate_rad_per_s: TAU * w.frequency_hz,
            last_com_m: None,
            yaw_joint: yaw_joints(config, n_joints),
            method: config.control.method,
            pids: vec![joint_pid(config); n_joints],
            dt_secs: config.general.timestep_secs,
            offset_rad: vec![0.0; n_joints],
            heading_rad: vec![0.0; n_joints + 1],
            phase_rad: 0.0,
            yaw: GyroYaw::default(),
            checkpoint: None,
            recovering_until_secs: f64::NEG_INFINITY,
            last: ObstacleAidedState::default(),
        }
    }

    /// The contact offsets o_j (rad), joint 0 first.
    pub fn offsets_rad(&self) -> &[f64] {
        &self.offset_rad
    }

    /// Adds the bend with its apex at joint `apex` toward side `side` (+1 left, −1 right) and
    /// size `g` (rad): the pattern (−1, +2, −1) on joints apex − 1, apex, apex + 1.
    fn bend(&mut self, apex: usize, side: f64, g: f64) {
        let n = self.offset_rad.len();
        if apex >= n {
            return;
        }
        if apex > 0 {
            self.offset_rad[apex - 1] -= side * g;
        }
        self.offset_rad[apex] += 2.0 * side * g;
        if apex + 1 < n {
            self.offset_rad[apex + 1] -= side * g;
        }
    }

    /// The force law of one step (module documentation): updates the contact offsets from the
    /// contacts, the link headings θᵢ (rad, head first), the mean heading θ̄ and the forward
    /// speed v (m/s) over `dt_secs`. Returns (propulsive, resistive) contact counts.
    pub fn force_law(
        &mut self,
        contacts: &ContactEstimates,
        heading_rad: &[f64],
        forward_rad: f64,
        forward_speed_m_per_s: f64,
        dt_secs: f64,
    ) -> (usize, usize) {
        let n_joints = self.offset_rad.len();
        // Relax, then move toward the tail with the body's progress past the pegs.
        let keep = (1.0 - self.release_per_s * dt_secs).clamp(0.0, 1.0);
        self.offset_rad.iter_mut().for_each(|o| *o *= keep);
        // Joints per second toward the tail (negative: toward the head).
        let joints_per_s = match self.propagation {
            Propagation::None => 0.0,
            Propagation::Progress => forward_speed_m_per_s.max(0.0) / self.link_length_m,
            Propagation::Wave if self.phase_lag_rad != 0.0 => self.wave_phase_rate_rad_per_s / self.phase_lag_rad,
            Propagation::Wave => 0.0,
        };
        shift_along_body(&mut self.offset_rad, joints_per_s * dt_secs);
        let (mut propulsive, mut resistive) = (0, 0);
        if self.contact_feedback && (contacts.active || self.contacts.source == ContactSource::True) {
            let u = [forward_rad.cos(), forward_rad.sin()];
            let n_links = contacts.n_links().min(heading_rad.len()).min(n_joints + 1);
            for (i, heading) in heading_rad.iter().enumerate().take(n_links) {
                if !contacts.contact[i] {
                    continue;
                }
                let f = contacts.obstacle_force_n[i];
                let (s, c) = heading.sin_cos();
                let f_normal = -s * f[0] + c * f[1];
                if f_normal == 0.0 {
                    continue;
                }
                let forward = f[0] * u[0] + f[1] * u[1];
                let g = if forward > 0.0 {
                    propulsive += 1;
                    self.force_gain_rad_per_n_s * (self.target_force_n - f_normal.abs()) * dt_secs
                } else {
                    resistive += 1;
                    -self.yield_gain_rad_per_n_s * f_normal.abs() * dt_secs
                };
                let side = -f_normal.signum();
                let front = contacts
                    .contact_point_along_m
                    .get(i)
                    .copied()
                    .flatten()
                    .map_or(0.5, |a| (0.5 + a / self.link_length_m).clamp(0.0, 1.0));
                if i > 0 {
                    self.bend(i - 1, side, g * front);
                } else {
                    self.bend(0, side, g * front);
                }
                self.bend(i, side, g * (1.0 - front));
            }
        }
        let max = self.max_offset_rad;
        self.offset_rad.iter_mut().for_each(|o| *o = o.clamp(-max, max));
        (propulsive, resistive)
    }

    /// The resisting force R, the second wave's switch and blend, and the flattening s_j of one
    /// step (module documentation); `goal` is ĝ.
    fn second_wave_and_flattening(
        &mut self,
        contacts: &ContactEstimates,
        goal: [f64; 2],
        t: f64,
        dt: f64,
        phase_rate: f64,
    ) {
        let n_joints = self.flatten.len();
        self.flatten_target.fill(0.0);
        let mut resist = 0.0;
        if self.contact_feedback && (contacts.active || self.contacts.source == ContactSource::True) {
            for i in 0..contacts.n_links() {
                if !contacts.contact[i] {
                    continue;
                }
                let f = contacts.obstacle_force_n[i];
                let against = -(f[0] * goal[0] + f[1] * goal[1]);
                if against <= 0.0 {
                    continue;
                }
                resist += against;
                if self.straighten && against > self.straighten_force_n {
                    // Link i lies between joints i − 1 and i.
                    for j in [i.wrapping_sub(1), i] {
                        if j < n_joints {
                            self.flatten_target[j] = 1.0;
                        }
                    }
                }
            }
        }
        self.resist_force_n += low_pass_gain(dt, self.contact_filter_secs) * (resist - self.resist_force_n);
        if self.switch == WaveSwitch::Resist && t >= self.ramp_secs {
            if !self.switched
                && t - self.switched_since_secs >= self.first_wave_secs
                && self.resist_force_n > self.switch_force_n
                && self.speed_m_per_s < self.switch_max_speed_m_per_s
            {
                self.switched = true;
                self.switched_since_secs = t;
            } else if self.switched
                && t - self.switched_since_secs >= self.switch_secs
                && match self.switch_exit {
                    SwitchExit::Resist => self.resist_force_n <= self.switch_force_n,
                    SwitchExit::Stall => self.speed_m_per_s < self.switch_max_speed_m_per_s,
                }
            {
                self.switched = false;
                self.switched_since_secs = t;
            }
        }
        let target = if self.switched { 1.0 } else { 0.0 };
        let step = if self.blend_secs > 0.0 { dt / self.blend_secs } else { 1.0 };
        self.blend += (target - self.blend).clamp(-step, step);
        // The flattening travels with the first wave's bends (ψ̇/δ joints per second), then
        // approaches its target.
        if self.straighten {
            shift_along_body(&mut self.flatten, phase_rate / self.phase_lag_rad * dt);
            let k = low_pass_gain(dt, self.straighten_secs);
            for (s, target) in self.flatten.iter_mut().zip(&self.flatten_target) {
                *s += k * (target - *s);
            }
        }
    }

    /// Link headings from the integrated head yaw and the encoders; returns θ̄ and the centre of
    /// mass (x, y).
    fn chain(&mut self, obs: &Observation) -> (f64, [f64; 2]) {
        let head = [obs.head_position_m[0], obs.head_position_m[1]];
        planar_chain(
            self.yaw.yaw_rad,
            head,
            &obs.joint_angle_rad,
            &self.yaw_joint,
            self.link_length_m,
            &mut self.heading_rad,
        )
    }

    /// One update with the given contacts.
    fn step(&mut self, obs: &Observation, contacts: &ContactEstimates, cmd: &mut Command) {
        let t = obs.time_secs;
        // The starting heading is known (calibration); from then on the gyro integrates it.
        let dt = self.yaw.update(obs);
        let (mean_heading, com) = self.chain(obs);
        let u = [mean_heading.cos(), mean_heading.sin()];
        // The centre of mass's velocity along the goal direction, low-pass filtered.
        let goal = [self.goal_heading_rad.cos(), self.goal_heading_rad.sin()];
        if let Some(last) = self.last_com_m
            && dt > 0.0
        {
            let raw = ((com[0] - last[0]) * goal[0] + (com[1] - last[1]) * goal[1]) / dt;
            let k = low_pass_gain(dt, self.speed_filter_secs);
            self.speed_m_per_s += k * (raw - self.speed_m_per_s);
        }
        self.last_com_m = Some(com);
        let forward_speed = if self.heading_gain > 0.0 || self.wave_speed == WaveSpeed::Progress {
            self.speed_m_per_s.max(0.0)
        } else {
            let v = obs.head_velocity_m_per_s;
            (v[0] * u[0] + v[1] * u[1]).max(0.0)
        };

        // Jam rule.
        let recovering = t < self.recovering_until_secs;
        if !recovering && t >= self.ramp_secs {
            match self.checkpoint {
                None => self.checkpoint = Some((t, com, u)),
                Some((t0, c0, u0)) if t - t0 >= self.jam_window_secs => {
                    let progress = (com[0] - c0[0]) * u0[0] + (com[1] - c0[1]) * u0[1];
                    if progress < self.jam_min_progress_m && self.recovery_secs > 0.0 {
                        self.recovering_until_secs = t + self.recovery_secs;
                        self.offset_rad.fill(0.0);
                        self.last.jams += 1;
                        self.checkpoint = None;
                    } else {
                        self.checkpoint = Some((t, com, u));
                    }
                }
                Some(_) => {}
            }
        }
        let recovering = t < self.recovering_until_secs;
        let phase_rate = match self.wave_speed {
            _ if recovering => match self.recovery {
                Recovery::Reverse => -self.angular_frequency_rad_per_s,
                Recovery::Pause => 0.0,
                Recovery::Amplitude => self.angular_frequency_rad_per_s,
            },
            WaveSpeed::Fixed => self.angular_frequency_rad_per_s,
            WaveSpeed::Progress => (self.drive_angular_frequency_rad_per_s
                + self.phase_lag_rad * forward_speed / self.link_length_m)
                .min(self.angular_frequency_rad_per_s),
        };
        let amplitude = if recovering && self.recovery == Recovery::Amplitude {
            self.recovery_amplitude_rad
        } else {
            self.amplitude_rad
        };
        self.wave_phase_rate_rad_per_s = phase_rate;
        self.second_wave_and_flattening(contacts, goal, t, dt, phase_rate);
        let (propulsive, resistive) = if recovering {
            self.force_law(&ContactEstimates::default(), &[], self.goal_heading_rad, 0.0, dt)
        } else {
            let heading = std::mem::take(&mut self.heading_rad);
            let counts = self.force_law(contacts, &heading, self.goal_heading_rad, forward_speed, dt);
            self.heading_rad = heading;
            counts
        };
        self.phase_rad = (self.phase_rad + phase_rate * dt) % (1e3 * TAU);
        // Heading control on the filtered mean heading. A positive offset turns the snake
        // clockwise when the wave runs toward the tail (δ > 0, as path following) and
        // counterclockwise when it runs toward the head (δ < 0): hence the sign of δ.
        let k = low_pass_gain(dt, self.heading_filter_secs);
        let filtered = match self.filtered_heading_rad {
            None => mean_heading,
            Some(f) => wrap_angle_rad(f + k * wrap_angle_rad(mean_heading - f)),
        };
        self.filtered_heading_rad = Some(filtered);
        let heading_offset =
            (self.phase_lag_rad.signum() * self.heading_gain * wrap_angle_rad(filtered - self.goal_heading_rad))
                .clamp(-self.max_heading_offset_rad, self.max_heading_offset_rad);
        self.last = ObstacleAidedState {
            mean_heading_rad: mean_heading,
            centre_of_mass_m: com,
            forward_speed_m_per_s: forward_speed,
            propulsive_contacts: propulsive,
            resistive_contacts: resistive,
            recovering,
            heading_offset_rad: heading_offset,
            phase_rate_rad_per_s: phase_rate,
            jams: self.last.jams,
            resist_force_n: self.resist_force_n,
            switched: self.switched,
            blend: self.blend,
            switches: self.last.switches + usize::from(self.switched && self.switched_since_secs == t),
        };

        let (r, dr) = ramp(t, self.ramp_secs);
        let (b, a2) = (self.blend, self.switch_amplitude_rad);
        for j in 0..obs.joint_angle_rad.len().min(cmd.position_rad.len()).min(self.offset_rad.len()) {
            let phase = self.phase_rad - j as f64 * self.phase_lag_rad;
            let offset = if self.yaw_joint[j] { self.offset_rad[j] + r * heading_offset } else { 0.0 };
            let keep = 1.0 - self.flatten[j];
            // (Written so that with b = 0 and s_j = 0 the arithmetic is the single wave's.)
            let (mut wave, mut rate) =
                ((1.0 - b) * amplitude * phase.sin(), r * ((1.0 - b) * amplitude) * phase_rate * phase.cos());
            if b > 0.0 {
                let phase2 = self.phase_rad - j as f64 * self.switch_phase_lag_rad;
                wave += b * a2 * phase2.sin();
                rate += r * (b * a2) * phase_rate * phase2.cos();
            }
            let wave = keep * wave;
            let angle = r * wave + offset;
            let velocity = dr * wave + keep * rate;
            command_joint(self.method, cmd, j, angle, velocity, obs, &mut self.pids[j], self.dt_secs);
        }
    }
}

/// Moves `values` (one per joint, joint 0 behind the head) along the body by `joints` joints
/// (> 0: toward the tail, < 0: toward the head; at most one) with a first-order upwind shift,
/// v_j ← (1 − σ)·v_j + σ·v_{j∓1}; what enters at the end is zero.
fn shift_along_body(values: &mut [f64], joints: f64) {
    let n = values.len();
    if n == 0 || joints == 0.0 || !joints.is_finite() {
        return;
    }
    let sigma = joints.abs().min(1.0);
    if joints > 0.0 {
        for j in (1..n).rev() {
            values[j] = (1.0 - sigma) * values[j] + sigma * values[j - 1];
        }
        values[0] *= 1.0 - sigma;
    } else {
        for j in 0..n - 1 {
            values[j] = (1.0 - sigma) * values[j] + sigma * values[j + 1];
        }
        values[n - 1] *= 1.0 - sigma;
    }
}

impl Controller for ObstacleAided {
    fn reset(&mut self) {
        self.pids.iter_mut().for_each(Pid::reset);
        self.offset_rad.fill(0.0);
        self.phase_rad = 0.0;
        self.yaw.reset();
        self.checkpoint = None;
        self.recovering_until_secs = f64::NEG_INFINITY;
        self.speed_m_per_s = 0.0;
        self.last_com_m = None;
        self.filtered_heading_rad = None;
        self.resist_force_n = 0.0;
        self.switched = false;
        self.switched_since_secs = f64::NEG_INFINITY;
        self.blend = 0.0;
        self.flatten.fill(0.0);
        self.last = ObstacleAidedState::default();
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

    fn controller(n_joints: usize) -> ObstacleAided {
        let mut c = Config::default();
        c.obstacle_aided.release_per_s = 0.0;
        c.obstacle_aided.propagation = Propagation::None;
        c.obstacle_aided.force_gain_rad_per_n_s = 0.1;
        c.obstacle_aided.yield_gain_rad_per_n_s = 0.1;
        c.obstacle_aided.target_force_n = 3.0;
        ObstacleAided::from_config(&c, n_joints)
    }

    fn one_contact(n_links: usize, link: usize, force: [f64; 3], along: Option<f64>) -> ContactEstimates {
        let mut c = ContactEstimates::new(n_links);
        c.active = true;
        c.contact[link] = true;
        c.obstacle_force_n[link] = force;
        c.contact_point_along_m[link] = along;
        c
    }

    #[test]
    fn a_propelling_peg_gets_a_bend_toward_it_until_the_force_reaches_the_target() {
        // Straight snake along +x; link 3 touches a peg on its right (the peg pushes it left,
        // +y) and forward (+x): propulsive. Contact at the rear end of link 3 (a = −L/2): apex
        // joint 3 only. g = k (F_ref − |f_n|) dt = 0.1 · (3 − 1) · 0.5 = 0.1 rad toward the
        // right (side −1): joints 2, 3, 4 get (+0.1, −0.2, +0.1).
        let mut oa = controller(9);
        let contacts = one_contact(10, 3, [0.5, 1.0, 0.0], Some(-0.1));
        let (p, r) = oa.force_law(&contacts, &[0.0; 10], 0.0, 0.0, 0.5);
        assert_eq!((p, r), (1, 0));
        let expected = [0.0, 0.0, 0.1, -0.2, 0.1, 0.0, 0.0, 0.0, 0.0];
        for (o, e) in oa.offsets_rad().iter().zip(expected) {
            assert!((o - e).abs() < 1e-12, "{:?}", oa.offsets_rad());
        }
        // Above the target force the bend eases: |f_n| = 5 N gives g = 0.1·(3 − 5)·0.5 = −0.1.
        let contacts = one_contact(10, 3, [0.5, 5.0, 0.0], Some(-0.1));
        oa.force_law(&contacts, &[0.0; 10], 0.0, 0.0, 0.5);
        assert!(oa.offsets_rad().iter().all(|o| o.abs() < 1e-12), "{:?}", oa.offsets_rad());
    }

    #[test]
    fn a_blocking_peg_makes_the_body_yield_and_the_contact_point_picks_the_apex() {
        // Link 5 pushed left (+y) and backward (−x): resistive; g = −k |f_n| dt = −0.1·2·0.25 =
        // −0.05 toward the peg (right): the bend grows to the left. Contact in the middle of the
        // link: half on the front joint (4) and half on the rear joint (5).
        let mut oa = controller(9);
        let contacts = one_contact(10, 5, [-1.0, 2.0, 0.0], Some(0.0));
        let (p, r) = oa.force_law(&contacts, &[0.0; 10], 0.0, 0.0, 0.25);
        assert_eq!((p, r), (0, 1));
        // side = −1, g = −0.05: apex 4 gets side·g·½ = +0.025 ·(−1, 2, −1) on joints 3, 4, 5,
        // apex 5 the same on 4, 5, 6.
        let expected = [0.0, 0.0, 0.0, -0.025, 0.025, 0.025, -0.025, 0.0, 0.0];
        for (o, e) in oa.offsets_rad().iter().zip(expected) {
            assert!((o - e).abs() < 1e-12, "{:?}", oa.offsets_rad());
        }
    }

    #[test]
    fn yield_and_press_have_their_own_gains_and_contact_feedback_off_ignores_the_contacts() {
        // The blocking peg of the test above with the yield gain 0: nothing; the propelling
        // peg of the first test with the press gain 0: nothing.
        let mut oa = controller(9);
        oa.yield_gain_rad_per_n_s = 0.0;
        let (p, r) = oa.force_law(&one_contact(10, 5, [-1.0, 2.0, 0.0], Some(0.0)), &[0.0; 10], 0.0, 0.0, 0.25);
        assert_eq!((p, r), (0, 1));
        assert!(oa.offsets_rad().iter().all(|o| *o == 0.0), "{:?}", oa.offsets_rad());
        let mut oa = controller(9);
        oa.force_gain_rad_per_n_s = 0.0;
        oa.force_law(&one_contact(10, 3, [0.5, 1.0, 0.0], Some(-0.1)), &[0.0; 10], 0.0, 0.0, 0.5);
        assert!(oa.offsets_rad().iter().all(|o| *o == 0.0), "{:?}", oa.offsets_rad());
        // With contact_feedback off neither counts nor offsets, whatever the gains.
        let mut oa = controller(9);
        oa.contact_feedback = false;
        let (p, r) = oa.force_law(&one_contact(10, 5, [-1.0, 2.0, 0.0], Some(0.0)), &[0.0; 10], 0.0, 0.0, 0.25);
        assert_eq!((p, r), (0, 0));
        assert!(oa.offsets_rad().iter().all(|o| *o == 0.0), "{:?}", oa.offsets_rad());
    }

    #[test]
    fn forward_is_the_goal_direction_not_the_body_heading() {
        // A straight snake along +x, a peg force along −x and +y on link 5: resistive when
        // the goal is +x (forward = 0), propulsive when the goal is −x (forward = π).
        let contacts = one_contact(10, 5, [-1.0, 2.0, 0.0], Some(0.0));
        let mut oa = controller(9);
        assert_eq!(oa.force_law(&contacts, &[0.0; 10], 0.0, 0.0, 0.25), (0, 1));
        let mut oa = controller(9);
        assert_eq!(oa.force_law(&contacts, &[0.0; 10], std::f64::consts::PI, 0.0, 0.25), (1, 0));
    }

    #[test]
    fn the_law_works_in_the_link_frame_whatever_the_heading() {
        // The same contact as the first test with the whole snake and the force turned by 90°:
        // the same offsets.
        let mut oa = controller(9);
        let turn = std::f64::consts::FRAC_PI_2;
        let contacts = one_contact(10, 3, [-1.0, 0.5, 0.0], Some(-0.1));
        oa.force_law(&contacts, &[turn; 10], turn, 0.0, 0.5);
        let expected = [0.0, 0.0, 0.1, -0.2, 0.1, 0.0, 0.0, 0.0, 0.0];
        for (o, e) in oa.offsets_rad().iter().zip(expected) {
            assert!((o - e).abs() < 1e-12, "{:?}", oa.offsets_rad());
        }
    }

    #[test]
    fn offsets_relax_clamp_and_move_toward_the_tail() {
        let mut c = Config::default();
        c.obstacle_aided.release_per_s = 0.5;
        c.obstacle_aided.propagation = Propagation::Progress;
        c.obstacle_aided.max_offset_deg = 10.0;
        let mut oa = ObstacleAided::from_config(&c, 4);
        oa.offset_rad.copy_from_slice(&[1.0, 0.1, 0.0, 0.0]);
        let none = ContactEstimates::default();
        // λΔt = 0.1: ×0.9; σ = vΔt/L = 0.4·0.2/0.2 = 0.4 joints.
        oa.force_law(&none, &[], 0.0, 0.4, 0.2);
        let max = 10f64.to_radians();
        let expected = [(0.6 * 0.9f64).min(max), 0.6 * 0.09 + 0.4 * 0.9, 0.4 * 0.09, 0.0].map(|x: f64| x.min(max));
        for (o, e) in oa.offsets_rad().iter().zip(expected) {
            assert!((o - e).abs() < 1e-12, "{:?} vs {expected:?}", oa.offsets_rad());
        }
    }

    #[test]
    fn with_a_headward_wave_the_offsets_travel_toward_the_head_at_the_wave_speed() {
        // δ = −60°, ω = π rad/s: ψ̇/δ = −3 joints per second; Δt = 0.1 s: σ = 0.3 toward the head.
        let mut c = Config::default();
        c.obstacle_aided.release_per_s = 0.0;
        c.obstacle_aided.propagation = Propagation::Wave;
        c.obstacle_aided.phase_lag_deg = -60.0;
        c.obstacle_aided.wave_speed = WaveSpeed::Fixed;
        c.gait.sine_wave.frequency_hz = 0.5;
        let mut oa = ObstacleAided::from_config(&c, 4);
        oa.offset_rad.copy_from_slice(&[0.0, 0.0, 0.1, 0.2]);
        oa.force_law(&ContactEstimates::default(), &[], 0.0, 0.0, 0.1);
        let expected = [0.0, 0.03, 0.7 * 0.1 + 0.3 * 0.2, 0.7 * 0.2];
        for (o, e) in oa.offsets_rad().iter().zip(expected) {
            assert!((o - e).abs() < 1e-12, "{:?} vs {expected:?}", oa.offsets_rad());
        }
    }

    #[test]
    fn no_progress_for_a_window_reverses_the_wave_for_the_recovery_time() {
        let mut c = Config::default();
        c.gait.ramp_secs = 0.0;
        c.obstacle_aided.jam_window_secs = 1.0;
        c.obstacle_aided.jam_min_progress_m = 0.05;
        c.obstacle_aided.recovery_secs = 0.5;
        c.obstacle_aided.recovery = Recovery::Reverse;
        c.obstacle_aided.wave_speed = WaveSpeed::Fixed;
        c.obstacle_aided.phase_lag_deg = -60.0;
        let mut oa = ObstacleAided::from_config(&c, 3);
        let mut obs = Observation::new(4, 3);
        obs.head_quat = [1.0, 0.0, 0.0, 0.0];
        let mut cmd = Command::new(3);
        let mut recovering_at = Vec::new();
        let omega = TAU * c.gait.sine_wave.frequency_hz;
        for k in 0..200 {
            obs.time_secs = k as f64 * 0.01;
            oa.update(&obs, &mut cmd);
            recovering_at.push((obs.time_secs, oa.last.recovering));
            let expected = if oa.last.recovering { -omega } else { omega };
            assert_eq!(oa.last.phase_rate_rad_per_s, expected, "t = {}", obs.time_secs);
        }
        // Stuck at the origin: jam at t = 1 s, backward until 1.5 s, a new window from then.
        assert_eq!(oa.last.jams, 1);
        for (t, rec) in recovering_at {
            if (t - 1.0).abs() > 0.005 && (t - 1.5).abs() > 0.005 {
                assert_eq!(rec, (1.0..1.5).contains(&t), "t = {t}");
            }
        }
        // While the head advances 0.1 m per second nothing jams.
        let mut oa = ObstacleAided::from_config(&c, 3);
        for k in 0..300 {
            obs.time_secs = k as f64 * 0.01;
            obs.head_position_m[0] = 0.1 * obs.time_secs;
            oa.update(&obs, &mut cmd);
        }
        assert_eq!(oa.last.jams, 0);
    }

    #[test]
    fn pause_and_amplitude_recoveries_stop_the_phase_or_enlarge_the_wave() {
        let mut c = Config::default();
        c.gait.ramp_secs = 0.0;
        c.control.method = ControlMethod::Position;
        c.obstacle_aided.jam_window_secs = 1.0;
        c.obstacle_aided.recovery_secs = 0.5;
        c.obstacle_aided.recovery_amplitude_deg = 80.0;
        c.obstacle_aided.wave_speed = WaveSpeed::Fixed;
        for recovery in [Recovery::Pause, Recovery::Amplitude] {
            c.obstacle_aided.recovery = recovery;
            let mut oa = ObstacleAided::from_config(&c, 3);
            let mut obs = Observation::new(4, 3);
            obs.head_quat = [1.0, 0.0, 0.0, 0.0];
            let mut cmd = Command::new(3);
            let mut largest_command = 0.0f64;
            for k in 0..140 {
                obs.time_secs = k as f64 * 0.01;
                oa.update(&obs, &mut cmd);
                if oa.last.recovering {
                    largest_command = largest_command.max(cmd.position_rad[0].abs());
                    let rate = if recovery == Recovery::Pause { 0.0 } else { oa.angular_frequency_rad_per_s };
                    assert_eq!(oa.last.phase_rate_rad_per_s, rate, "{recovery:?}");
                }
            }
            assert_eq!(oa.last.jams, 1, "{recovery:?}");
            if recovery == Recovery::Amplitude {
                // 0.4 s of a 0.5-Hz wave sweep past a crest of joint 0: above the 65° wave.
                assert!(largest_command > 70f64.to_radians(), "{largest_command}");
            }
        }
    }

    #[test]
    fn heading_control_offsets_every_joint_against_the_heading_error_and_clamps() {
        // Straight snake (joints 0) turned 0.2 rad left of the goal (+x): θ̄ = 0.2. With an
        // ordinary wave (δ > 0) φ_h = k_θ·0.2 = 0.1 rad (positive: turns that snake clockwise,
        // back toward the goal); with a wave toward the head (δ < 0) the sign flips.
        for (lag_deg, sign) in [(60.0, 1.0), (-60.0, -1.0)] {
            let mut c = Config::default();
            c.gait.ramp_secs = 0.0;
            c.obstacle_aided.phase_lag_deg = lag_deg;
            c.obstacle_aided.wave_speed = WaveSpeed::Fixed;
            c.obstacle_aided.heading_gain = 0.5;
            c.obstacle_aided.heading_filter_secs = 0.0;
            c.obstacle_aided.max_heading_offset_deg = 10.0;
            c.control.method = ControlMethod::Position;
            let mut oa = ObstacleAided::from_config(&c, 3);
            let mut obs = Observation::new(4, 3);
            let yaw = 0.2f64;
            obs.head_quat = [(yaw / 2.0).cos(), 0.0, 0.0, (yaw / 2.0).sin()];
            let mut cmd = Command::new(3);
            oa.update(&obs, &mut cmd);
            assert!((oa.last.mean_heading_rad - 0.2).abs() < 1e-12, "{:?}", oa.last);
            assert!((oa.last.heading_offset_rad - sign * 0.1).abs() < 1e-12, "{:?}", oa.last);
            for j in 0..3 {
                let wave = oa.amplitude_rad * (oa.phase_rad - j as f64 * oa.phase_lag_rad).sin();
                assert!((cmd.position_rad[j] - wave - sign * 0.1).abs() < 1e-9, "joint {j}: {:?}", cmd.position_rad);
            }
            // 0.6 rad to the right: ∓0.3 rad, clamped to ∓10°.
            let mut oa = ObstacleAided::from_config(&c, 3);
            let yaw = -0.6f64;
            obs.head_quat = [(yaw / 2.0).cos(), 0.0, 0.0, (yaw / 2.0).sin()];
            oa.update(&obs, &mut cmd);
            assert!((oa.last.heading_offset_rad + sign * 10f64.to_radians()).abs() < 1e-12, "{:?}", oa.last);
        }
    }

    #[test]
    fn the_heading_filter_lags_a_heading_step() {
        // The filter starts at the first heading (0) and follows a step to 0.2 rad with time
        // constant 1 s: after one 0.1-s step 0.2·0.1 = 0.02 rad of it, so φ_h = −0.5·0.02.
        let mut c = Config::default();
        c.gait.ramp_secs = 0.0;
        c.obstacle_aided.heading_gain = 0.5;
        c.obstacle_aided.heading_filter_secs = 1.0;
        let mut oa = ObstacleAided::from_config(&c, 3);
        let mut obs = Observation::new(4, 3);
        obs.head_quat = [1.0, 0.0, 0.0, 0.0];
        let mut cmd = Command::new(3);
        oa.update(&obs, &mut cmd);
        assert_eq!(oa.last.heading_offset_rad, 0.0);
        obs.time_secs = 0.1;
        obs.imu_gyro_rad_per_s[0] = [0.0, 0.0, 2.0];
        oa.update(&obs, &mut cmd);
        assert!((oa.last.mean_heading_rad - 0.2).abs() < 1e-12, "{:?}", oa.last);
        assert!((oa.last.heading_offset_rad + 0.5 * 0.02).abs() < 1e-12, "{:?}", oa.last);
    }

    /// A stationary snake along +x (head at the origin, joints straight) for `steps` steps of
    /// 0.01 s with the contacts of `contacts_at(time)`; returns the controller and the last
    /// command.
    fn run_still(
        c: &Config,
        steps: usize,
        contacts_at: impl Fn(f64) -> ContactEstimates,
        mut each: impl FnMut(&ObstacleAided, &Command),
    ) -> ObstacleAided {
        let mut oa = ObstacleAided::from_config(c, 9);
        let mut obs = Observation::new(10, 9);
        obs.head_quat = [1.0, 0.0, 0.0, 0.0];
        let mut cmd = Command::new(9);
        for k in 0..steps {
            obs.time_secs = k as f64 * 0.01;
            let contacts = contacts_at(obs.time_secs);
            oa.step(&obs, &contacts, &mut cmd);
            each(&oa, &cmd);
        }
        oa
    }

    fn switch_config() -> Config {
        let mut c = Config::default();
        c.gait.ramp_secs = 0.0;
        c.control.method = ControlMethod::Position;
        c.obstacle_aided.switch = WaveSwitch::Resist;
        c.obstacle_aided.switch_amplitude_deg = 50.0;
        c.obstacle_aided.switch_phase_lag_deg = 30.0;
        c.obstacle_aided.contact_filter_secs = 0.1;
        c.obstacle_aided.switch_force_n = 5.0;
        c.obstacle_aided.switch_max_speed_m_per_s = 0.03;
        c.obstacle_aided.switch_secs = 1.0;
        c.obstacle_aided.first_wave_secs = 1.0;
        c.obstacle_aided.blend_secs = 0.2;
        c.obstacle_aided.force_gain_rad_per_n_s = 0.0;
        c.obstacle_aided.yield_gain_rad_per_n_s = 0.0;
        c.obstacle_aided.jam_window_secs = 100.0;
        c
    }

    #[test]
    fn a_resisting_force_above_the_threshold_hands_the_joints_to_the_second_wave_and_back() {
        // 8 N against the goal on link 4 for the first 2 s, then nothing. The filter (0.1 s)
        // passes 5 N after 0.1·ln(8/3) ≈ 0.1 s; the blend then takes 0.2 s; after the contact
        // ends R falls below 5 N within 0.1 s and, 1 s after the switch, the first wave returns.
        let c = switch_config();
        let push = |t: f64| {
            if t < 2.0 { one_contact(10, 4, [-8.0, 1.0, 0.0], Some(0.0)) } else { ContactEstimates::new(10) }
        };
        let mut switched_at = None;
        let mut back_at = None;
        let oa = run_still(&c, 300, push, |oa, cmd| {
            let t = oa.yaw.last_time_secs;
            if oa.last.switched && switched_at.is_none() {
                switched_at = Some(t);
            }
            if switched_at.is_some() && !oa.last.switched && back_at.is_none() {
                back_at = Some(t);
            }
            if oa.last.blend == 1.0 || oa.last.blend == 0.0 {
                // Fully on one wave: the joints follow it exactly.
                let (a, lag) = if oa.last.blend == 1.0 {
                    (oa.switch_amplitude_rad, oa.switch_phase_lag_rad)
                } else {
                    (oa.amplitude_rad, oa.phase_lag_rad)
                };
                for j in 0..9 {
                    let wave = a * (oa.phase_rad - j as f64 * lag).sin();
                    assert!((cmd.position_rad[j] - wave).abs() < 1e-12, "t = {t}, joint {j}");
                }
            }
        });
        let on = switched_at.expect("never switched");
        assert!((0.08..0.13).contains(&on), "switched at {on}");
        let off = back_at.expect("never switched back");
        assert!((2.0..2.15).contains(&off), "back at {off}");
        assert_eq!(oa.last.switches, 1);
        assert_eq!(oa.last.blend, 0.0);
    }

    #[test]
    fn with_the_stall_exit_the_second_wave_stays_while_it_moves_whatever_the_force() {
        // Switched by a resisting 8 N at rest; the force stays, and from t = 0.5 s the snake
        // advances at 0.1 m/s: the second wave stays (the speed is above 0.03 m/s once the
        // 0.5-s filter has followed), and when the snake stops again at t = 3 s the first wave
        // returns within the filter's lag although the force is still there.
        let mut c = switch_config();
        c.obstacle_aided.switch_exit = SwitchExit::Stall;
        c.obstacle_aided.first_wave_secs = 0.5;
        let mut again_at = None;
        let mut oa = ObstacleAided::from_config(&c, 9);
        let mut obs = Observation::new(10, 9);
        obs.head_quat = [1.0, 0.0, 0.0, 0.0];
        let mut cmd = Command::new(9);
        let push = one_contact(10, 4, [-8.0, 1.0, 0.0], Some(0.0));
        let mut back_at = None;
        for k in 0..470 {
            let t = k as f64 * 0.01;
            obs.time_secs = t;
            obs.head_position_m[0] = 0.1 * (t.clamp(0.5, 3.0) - 0.5);
            oa.step(&obs, &push, &mut cmd);
            if (0.2..3.0).contains(&t) {
                assert!(oa.last.switched, "t = {t}: {:?}", oa.last);
            }
            if t > 3.0 && !oa.last.switched && back_at.is_none() {
                back_at = Some(t);
            }
            if back_at.is_some() && oa.last.switched && again_at.is_none() {
                again_at = Some(t);
            }
        }
        // v decays from 0.1 as e^(−(t − 3)/0.5): below 0.03 after 0.5·ln(10/3) ≈ 0.6 s.
        let back = back_at.expect("never switched back");
        assert!((3.55..3.7).contains(&back), "back at {back}");
        // With the force still on and the snake at rest the second wave comes again once the
        // first has run for first_wave_secs (0.5 s).
        let again = again_at.expect("never switched again");
        assert!((again - back - 0.5).abs() < 0.015, "back at {back}, again at {again}");
        assert!(oa.last.switched && oa.last.switches == 2, "{:?}", oa.last);
    }

    #[test]
    fn no_switch_while_moving_below_the_force_or_with_contact_feedback_off() {
        let push = |_: f64| one_contact(10, 4, [-8.0, 1.0, 0.0], Some(0.0));
        // A propelling force (+x) of any size: no switch.
        let c = switch_config();
        let oa = run_still(&c, 100, |_| one_contact(10, 4, [8.0, 1.0, 0.0], Some(0.0)), |_, _| ());
        assert!(!oa.last.switched && oa.last.switches == 0);
        // Below the threshold.
        let oa = run_still(&c, 100, |_| one_contact(10, 4, [-4.0, 1.0, 0.0], Some(0.0)), |_, _| ());
        assert!(!oa.last.switched && (oa.last.resist_force_n - 4.0).abs() < 1e-3, "{:?}", oa.last);
        // Contact terms off.
        let mut c = switch_config();
        c.obstacle_aided.contact_feedback = false;
        let oa = run_still(&c, 100, push, |_, _| ());
        assert!(!oa.last.switched && oa.last.resist_force_n == 0.0);
        // The snake advancing at 0.1 m/s (above the 0.03 m/s limit): no switch.
        let c = switch_config();
        let mut oa = ObstacleAided::from_config(&c, 9);
        let mut obs = Observation::new(10, 9);
        obs.head_quat = [1.0, 0.0, 0.0, 0.0];
        let mut cmd = Command::new(9);
        for k in 0..300 {
            // The force comes once the speed filter (0.5 s) has settled.
            obs.time_secs = k as f64 * 0.01;
            obs.head_position_m[0] = 0.1 * obs.time_secs;
            let contacts = if obs.time_secs < 2.0 { ContactEstimates::new(10) } else { push(obs.time_secs) };
            oa.step(&obs, &contacts, &mut cmd);
        }
        assert!(!oa.last.switched && oa.last.resist_force_n > 7.9, "{:?}", oa.last);
    }

    #[test]
    fn full_yield_flattens_the_wave_at_a_resisting_link_and_the_flattening_travels_with_the_wave() {
        // δ = −60° at 0.5 Hz: the wave's bends run 3 joints per second toward the head.
        // 6 N against the goal on link 6 (joints 5 and 6) above the 2-N threshold.
        let mut c = switch_config();
        c.obstacle_aided.switch = WaveSwitch::None;
        c.obstacle_aided.phase_lag_deg = -60.0;
        c.obstacle_aided.straighten = true;
        c.obstacle_aided.straighten_force_n = 2.0;
        c.obstacle_aided.straighten_secs = 0.05;
        let push = |_: f64| one_contact(10, 6, [-6.0, 1.0, 0.0], Some(0.0));
        let oa = run_still(&c, 100, push, |_, _| ());
        let s = &oa.flatten;
        // At the contact's joints nearly flat; the flattening has spread toward the head
        // (joints 4 and 3, decreasing: per step joint 4 takes σ = 3·0.01 of joint 5 and keeps
        // 1 − k = 1 − 0.01/0.05 of itself, so it settles at 0.8·0.03/(1 − 0.8·0.97)·s₅ ≈ 0.107·s₅)
        // but not toward the tail (7, 8).
        // Joint 6 takes σ of joint 7 (unflattened): it settles at k/(1 − (1 − k)(1 − σ)) =
        // 0.2/0.224; joint 5 takes σ of joint 6 and stays nearer 1.
        assert!((s[6] - 0.2 / 0.224).abs() < 1e-6 && s[5] > 0.98, "{s:?}");
        assert!((s[4] / s[5] - 0.024 / 0.224).abs() < 0.01, "{s:?}");
        assert!(s[3] > 0.005 && s[3] < s[4] && s[4] < s[5], "{s:?}");
        assert!(s[7] == 0.0 && s[8] == 0.0, "{s:?}");
        // The command at joint 6 is the wave times (1 − s₆).
        let mut cmd = Command::new(9);
        let mut oa = oa;
        let mut obs = Observation::new(10, 9);
        obs.head_quat = [1.0, 0.0, 0.0, 0.0];
        obs.time_secs = 1.0;
        oa.step(&obs, &push(1.0), &mut cmd);
        let wave6 = oa.amplitude_rad * (oa.phase_rad - 6.0 * oa.phase_lag_rad).sin();
        assert!((cmd.position_rad[6] - (1.0 - oa.flatten[6]) * wave6).abs() < 1e-12);
        // A force below the threshold, or along the goal: nothing flattens.
        let oa = run_still(&c, 100, |_| one_contact(10, 6, [-1.5, 1.0, 0.0], Some(0.0)), |_, _| ());
        assert!(oa.flatten.iter().all(|s| *s == 0.0), "{:?}", oa.flatten);
        let oa = run_still(&c, 100, |_| one_contact(10, 6, [6.0, 1.0, 0.0], Some(0.0)), |_, _| ());
        assert!(oa.flatten.iter().all(|s| *s == 0.0), "{:?}", oa.flatten);
        // Once the contact ends the wave comes back.
        let oa = run_still(&c, 200, |t| if t < 1.0 { push(t) } else { ContactEstimates::new(10) }, |_, _| ());
        assert!(oa.flatten.iter().all(|s| *s < 0.01), "{:?}", oa.flatten);
    }

    #[test]
    fn the_progress_wave_runs_at_the_drive_when_stuck_and_follows_the_measured_speed() {
        let mut c = Config::default();
        c.gait.ramp_secs = 0.0;
        c.gait.sine_wave.frequency_hz = 0.5;
        c.obstacle_aided.phase_lag_deg = 30.0;
        c.obstacle_aided.wave_speed = WaveSpeed::Progress;
        c.obstacle_aided.drive_frequency_hz = 0.05;
        c.obstacle_aided.speed_filter_secs = 0.2;
        c.obstacle_aided.jam_window_secs = 100.0;
        let l = c.snake.link_length_m;
        let run = |speed: f64| {
            let mut oa = ObstacleAided::from_config(&c, 3);
            let mut obs = Observation::new(4, 3);
            obs.head_quat = [1.0, 0.0, 0.0, 0.0];
            let mut cmd = Command::new(3);
            for k in 0..300 {
                obs.time_secs = k as f64 * 0.01;
                obs.head_position_m[0] = speed * obs.time_secs;
                oa.update(&obs, &mut cmd);
            }
            oa.last.phase_rate_rad_per_s
        };
        // Stuck: ψ̇ = ω_d = 2π·0.05.
        assert!((run(0.0) - TAU * 0.05).abs() < 1e-9, "{}", run(0.0));
        // 0.1 m/s (the filter has settled after 15 time constants): ω_d + δ·v/L.
        let expected = TAU * 0.05 + 30f64.to_radians() * 0.1 / l;
        assert!((run(0.1) - expected).abs() < 1e-3 * expected, "{} vs {expected}", run(0.1));
        // Fast: capped at ω.
        assert!((run(2.0) - TAU * 0.5).abs() < 1e-9, "{}", run(2.0));
    }
}
