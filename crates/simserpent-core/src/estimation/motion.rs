//! Estimation in motion: the estimator as a component of the step loop.
//!
//! [`MotionEstimator::update`] runs at every sensed step on the **measured** observation and
//! writes [`ContactEstimates`] (per link: external force, the floor's share, the obstacle force,
//! a contact flag and the contact point along the link). Three stages:
//!
//! 1. **Link poses** ([`LinkPoses`]). `estimation.orientation = "imu"`: the head's attitude
//!    `q₀` comes from its IMU — the gyro integrated, `q̇ = ½·q ⊗ (0, ω + k·(â × ĝ_est))`, with
//!    Mahony's tilt correction toward the accelerometer's "up" `â` (gain `k` =
//!    `estimation.tilt_gain_per_s`; R. Mahony, T. Hamel, J.-M. Pflimlin, *Nonlinear
//!    complementary filters on the special orthogonal group*, IEEE TAC 53(5), 2008), started at
//!    the head's pose of the first instant (the robot's IMU is initialised at a known pose).
//!    The other links follow from the encoders along the chain, `Rᵢ = Rᵢ₋₁·Rot(axisᵢ, qᵢ)`,
//!    `oᵢ = oᵢ₋₁ + Rᵢ₋₁·(−L, 0, 0)`, centre of mass `cᵢ = oᵢ + Rᵢ·(−L/2, 0, 0)`; angular
//!    velocities are the measured gyros, `ωᵢ = Rᵢ·gyroᵢ`, and centre-of-mass velocities follow
//!    from the head's (taken as known: a tracking system or odometry; the observation's
//!    `head_velocity_m_per_s`) as `v_{o,i+1} = v_{o,i} + ωᵢ × (oᵢ₊₁ − oᵢ)`,
//!    `v_{c,i} = v_{o,i} + ωᵢ × (cᵢ − oᵢ)`. `"true"`: the simulator's poses and velocities.
//! 2. **External force per link**: the [`ContactEstimator`] (Newton–Euler by default; module
//!    `estimation`), and the moment of the external forces about each centre of mass.
//! 3. **The floor's share** ([`FloorShare`]): the floor (horizontal, `z` up) carries the link
//!    with the normal force `N = max(f_z, 0)` (obstacles are vertical pegs and walls: they push
//!    horizontally) split equally between the two contact points of a capsule lying on a plane,
//!    `pₖ = c ± (L/2 − r)·x̂`. At a contact point sliding faster than
//!    `estimation.sliding_speed_m_per_s` the floor's friction is the maximum-dissipation point of
//!    the friction ellipse (semi-axes `μ_a·N/2` along the link, `μ_l·N/2` across it), opposite
//!    the sliding velocity `v = (v_a, v_l)`:
//!    `F = −(A²·v_a, B²·v_l) / sqrt(A²·v_a² + B²·v_l²)` — exactly what SimSerpent's
//!    `stick_slip` floor applies in steady sliding. A sticking contact point can hold anything
//!    inside its ellipse, so the floor is credited with as much of the remaining horizontal force
//!    as the sticking points' ellipse allows (its nearest point), and only the excess counts as
//!    obstacle force. The coefficients are those of `[ground]` (isotropic: `μ` in every
//!    direction; anisotropic: axial and lateral; directional: axial toward the tail, backward
//!    toward the head; viscous: `−c_t·v_t·x̂ − c_n·v_n·ŷ` at the centre of mass, no Coulomb part).
//!    Floor surfaces with other friction are not modelled (the plain floor's coefficients apply).
//!    The floor's friction bound comes from a model evaluation other than the one the sensors
//!    describe (SimSerpent's floor uses the previous evaluation's normal force), and the contact
//!    forces change from one step to the next, so the sliding friction's support is taken within
//!    the range of this update's and the previous update's `N`, as the value that explains most of
//!    the horizontal force (the floor gets the benefit of the doubt).
//!
//! The obstacle force is the horizontal residual; a link touches an obstacle when its magnitude
//! reaches `estimation.detection_threshold_n`. Its contact point along the link: the obstacle's
//! vertical moment about the centre of mass is the total's minus the sliding friction's,
//! `M_obs = M_z − Σₖ ((pₖ − c) × Fₖ)_z`. An obstacle touches the capsule's side, at
//! `c + s·x̂ + r·n̂` with `n̂ = −sign(f_lat)·ŷ` (the side the push comes from, `ŷ = ẑ × x̂`,
//! `f_lat = f·ŷ`, `f_a = f·x̂`), so its moment is `s·f_lat + r·sign(f_lat)·f_a` (the second term:
//! the peg's friction along the link, acting at the radius), and
//! `s = (M_obs − r·sign(f_lat)·f_a) / f_lat`, clamped to the link (|s| ≤ L/2), reported when
//! `|f_lat|` reaches `estimation.min_lateral_force_n`.
//!
//! Nothing here allocates after construction.

use super::{ContactEstimator, EstimateOutput, EstimatorInput, NewtonEulerEstimator, cross, quat_to_matrix};
use crate::config::{Config, GroundModel, JointAxes, OrientationSource};
use crate::control::Observation;

/// Per-link contact estimates of one instant, as controllers see them
/// ([`Observation::contacts`]). Empty vectors (and `active` false) when estimation is off.
/// World frame; forces on the link (N).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ContactEstimates {
    /// Whether an estimator filled this instant.
    pub active: bool,
    /// Total external force (floor + obstacles + other links).
    pub external_force_n: Vec<[f64; 3]>,
    /// The floor's share: normal support and friction.
    pub floor_force_n: Vec<[f64; 3]>,
    /// The rest, horizontal: what obstacles push.
    pub obstacle_force_n: Vec<[f64; 3]>,
    /// Whether the link touches an obstacle (|obstacle force| ≥ the detection threshold).
    pub contact: Vec<bool>,
    /// Obstacle contact point: signed distance from the centre of mass along the link's axis
    /// (+x, toward the head; m), when the lateral obstacle force determines it.
    pub contact_point_along_m: Vec<Option<f64>>,
    /// The same point in the world (m).
    pub contact_point_m: Vec<Option<[f64; 3]>>,
}

impl ContactEstimates {
    /// Estimates for `n_links` links (inactive until filled).
    pub fn new(n_links: usize) -> Self {
        Self {
            active: false,
            external_force_n: vec![[0.0; 3]; n_links],
            floor_force_n: vec![[0.0; 3]; n_links],
            obstacle_force_n: vec![[0.0; 3]; n_links],
            contact: vec![false; n_links],
            contact_point_along_m: vec![None; n_links],
            contact_point_m: vec![None; n_links],
        }
    }

    /// Number of links.
    pub fn n_links(&self) -> usize {
        self.external_force_n.len()
    }

    /// Copies `other` (no allocation once the sizes match).
    pub fn copy_from(&mut self, other: &ContactEstimates) {
        self.active = other.active;
        self.external_force_n.clone_from(&other.external_force_n);
        self.floor_force_n.clone_from(&other.floor_force_n);
        self.obstacle_force_n.clone_from(&other.obstacle_force_n);
        self.contact.clone_from(&other.contact);
        self.contact_point_along_m.clone_from(&other.contact_point_along_m);
        self.contact_point_m.clone_from(&other.contact_point_m);
    }
}

/// Link poses and velocities of one instant (world frame).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LinkPoses {
    /// Orientation quaternions (w, x, y, z), link frame → world.
    pub quat: Vec<[f64; 4]>,
    /// Centres of mass (m).
    pub com_m: Vec<[f64; 3]>,
    /// Frame origins = the joint to the parent (m).
    pub origin_m: Vec<[f64; 3]>,
    /// Centre-of-mass velocities (m/s).
    pub com_velocity_m_per_s: Vec<[f64; 3]>,
    /// Angular velocities (rad/s).
    pub angular_velocity_rad_per_s: Vec<[f64; 3]>,
}

impl LinkPoses {
    /// Poses for `n_links` links (identity, at the origin, at rest).
    pub fn new(n_links: usize) -> Self {
        Self {
            quat: vec![[1.0, 0.0, 0.0, 0.0]; n_links],
            com_m: vec![[0.0; 3]; n_links],
            origin_m: vec![[0.0; 3]; n_links],
            com_velocity_m_per_s: vec![[0.0; 3]; n_links],
            angular_velocity_rad_per_s: vec![[0.0; 3]; n_links],
        }
    }
}

/// The snake's chain as the estimator knows it: the generated snake of `[snake]` (every link
/// `L` long, its frame at the joint to its parent, the child `L` behind along −x, the centre of
/// mass at −L/2, hinge axes z or alternating y, z).
#[derive(Debug, Clone, PartialEq)]
pub struct ChainGeometry {
    /// Link masses (kg).
    pub link_mass_kg: Vec<f64>,
    /// Link length L (m).
    pub link_length_m: f64,
    /// Link radius r (m).
    pub link_radius_m: f64,
    /// Per joint j (between links j and j+1): its axis in link j+1's frame.
    pub joint_axis: Vec<[f64; 3]>,
}

impl ChainGeometry {
    /// The chain of `config`'s snake with the given link masses (the model's, kg).
    pub fn from_config(config: &Config, link_mass_kg: &[f64]) -> Self {
        let n = link_mass_kg.len();
        let joint_axis = (1..n)
            .map(|i| match config.snake.joint_axes {
                // As the generated model (`model::snake`): alternating starts with pitch at link 0's
                // even neighbours: joint into link i is about y for even i.
                JointAxes::Alternating if i % 2 == 0 => [0.0, 1.0, 0.0],
                _ => [0.0, 0.0, 1.0],
            })
            .collect();
        Self {
            link_mass_kg: link_mass_kg.to_vec(),
            link_length_m: config.snake.link_length_m,
            link_radius_m: config.snake.link_radius_m,
            joint_axis,
        }
    }

    /// Number of links.
    pub fn n_links(&self) -> usize {
        self.link_mass_kg.len()
    }
}

/// The head's attitude filter: gyro integration with Mahony's tilt correction (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeadAttitude {
    /// The estimate (w, x, y, z), head frame → world.
    pub quat: [f64; 4],
    /// Time of the estimate (s); `None` before the first update.
    pub time_secs: Option<f64>,
    /// Tilt correction gain (1/s).
    pub tilt_gain_per_s: f64,
}

impl HeadAttitude {
    /// A filter with the given gain, started at the first update's pose.
    pub fn new(tilt_gain_per_s: f64) -> Self {
        Self { quat: [1.0, 0.0, 0.0, 0.0], time_secs: None, tilt_gain_per_s }
    }

    /// Advances to `time_secs` with the head's gyro and accelerometer (head frame). At the first
    /// call the estimate starts at `initial_quat`.
    pub fn update(&mut self, time_secs: f64, gyro: [f64; 3], accel: [f64; 3], initial_quat: [f64; 4]) {
        let Some(t0) = self.time_secs else {
            self.quat = normalized_quat(initial_quat);
            self.time_secs = Some(time_secs);
            return;
        };
        let dt = time_secs - t0;
        self.time_secs = Some(time_secs);
        if dt <= 0.0 || !dt.is_finite() {
            return;
        }
        let mut w = gyro;
        let a_norm = (accel[0] * accel[0] + accel[1] * accel[1] + accel[2] * accel[2]).sqrt();
        if self.tilt_gain_per_s > 0.0 && a_norm > 1e-6 {
            // Expected "up" in the head frame: the third row of R (R transposed times z).
            let r = quat_to_matrix(self.quat);
            let up_est = [r[2][0], r[2][1], r[2][2]];
            let up_meas = accel.map(|a| a / a_norm);
            let e = cross(up_meas, up_est);
            for k in 0..3 {
                w[k] += self.tilt_gain_per_s * e[k];
            }
        }
        let half = [0.5 * w[0] * dt, 0.5 * w[1] * dt, 0.5 * w[2] * dt];
        let angle = (half[0] * half[0] + half[1] * half[1] + half[2] * half[2]).sqrt();
        let (s, c) = if angle > 1e-12 { (angle.sin() / angle, angle.cos()) } else { (1.0, 1.0) };
        let dq = [c, half[0] * s, half[1] * s, half[2] * s];
        self.quat = normalized_quat(quat_mul(self.quat, dq));
    }
}

fn quat_mul(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ]
}

fn normalized_quat(q: [f64; 4]) -> [f64; 4] {
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    if n > 0.0 && n.is_finite() { q.map(|x| x / n) } else { [1.0, 0.0, 0.0, 0.0] }
}

fn matrix_to_quat(r: &[[f64; 3]; 3]) -> [f64; 4] {
    // Shepperd's method.
    let tr = r[0][0] + r[1][1] + r[2][2];
    let q = if tr > 0.0 {
        let s = (tr + 1.0).sqrt() * 2.0;
        [0.25 * s, (r[2][1] - r[1][2]) / s, (r[0][2] - r[2][0]) / s, (r[1][0] - r[0][1]) / s]
    } else if r[0][0] > r[1][1] && r[0][0] > r[2][2] {
        let s = (1.0 + r[0][0] - r[1][1] - r[2][2]).sqrt() * 2.0;
        [(r[2][1] - r[1][2]) / s, 0.25 * s, (r[0][1] + r[1][0]) / s, (r[0][2] + r[2][0]) / s]
    } else if r[1][1] > r[2][2] {
        let s = (1.0 + r[1][1] - r[0][0] - r[2][2]).sqrt() * 2.0;
        [(r[0][2] - r[2][0]) / s, (r[0][1] + r[1][0]) / s, 0.25 * s, (r[1][2] + r[2][1]) / s]
    } else {
        let s = (1.0 + r[2][2] - r[0][0] - r[1][1]).sqrt() * 2.0;
        [(r[1][0] - r[0][1]) / s, (r[0][2] + r[2][0]) / s, (r[1][2] + r[2][1]) / s, 0.25 * s]
    };
    normalized_quat(q)
}

fn mat_mul(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let mut m = [[0.0; 3]; 3];
    for (i, row) in m.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
        }
    }
    m
}

/// Rotation by `angle` about the unit `axis` (Rodrigues).
fn axis_rotation(axis: [f64; 3], angle: f64) -> [[f64; 3]; 3] {
    let (s, c) = angle.sin_cos();
    let t = 1.0 - c;
    let [x, y, z] = axis;
    [
        [t * x * x + c, t * x * y - s * z, t * x * z + s * y],
        [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
        [t * x * z - s * y, t * y * z + s * x, t * z * z + c],
    ]
}

fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

fn scale(a: [f64; 3], k: f64) -> [f64; 3] {
    [a[0] * k, a[1] * k, a[2] * k]
}

/// The floor's friction coefficients as the estimator models them (from `[ground]`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FloorShare {
    /// Coulomb coefficients: along the link for a force toward the tail (forward sliding), toward
    /// the head (backward sliding), and across the link.
    pub mu_forward: f64,
    pub mu_backward: f64,
    pub mu_lateral: f64,
    /// Viscous coefficients (N·s/m) along and across the link (viscous ground model; else 0).
    pub viscous_tangential_n_s_per_m: f64,
    pub viscous_normal_n_s_per_m: f64,
    /// Below this speed (m/s) a contact point sticks.
    pub sliding_speed_m_per_s: f64,
}

impl FloorShare {
    /// The coefficients of `config`'s plain floor.
    pub fn from_config(config: &Config) -> Self {
        let g = &config.ground;
        let mu = config.snake.ground_friction[0];
        let (mu_forward, mu_backward, mu_lateral) = match g.model {
            GroundModel::Isotropic => (mu, mu, mu),
            GroundModel::Anisotropic => (g.axial_friction, g.axial_friction, g.lateral_friction),
            GroundModel::Directional => (g.axial_friction, g.backward_friction, g.lateral_friction),
            GroundModel::Viscous => (0.0, 0.0, 0.0),
        };
        let viscous = g.model == GroundModel::Viscous;
        Self {
            mu_forward,
            mu_backward,
            mu_lateral,
            viscous_tangential_n_s_per_m: if viscous { g.viscous_tangential_n_s_per_m } else { 0.0 },
            viscous_normal_n_s_per_m: if viscous { g.viscous_normal_n_s_per_m } else { 0.0 },
            sliding_speed_m_per_s: config.estimation.sliding_speed_m_per_s,
        }
    }

    /// Splits one link's horizontal external force `f_h` (world, z = 0) into the floor's
    /// friction and the obstacle's share. `axis`: the link's horizontal unit axis; `normal_n`:
    /// the range of the floor's support (N) — this instant's and the previous one's: the floor's
    /// friction bound comes from a model evaluation between them, and the contact forces change
    /// from step to step, so the floor is given the benefit of the doubt within the range;
    /// `points`: the two floor contact points relative to the centre of mass with their
    /// velocities. Returns (floor friction, its vertical moment about the centre of mass from
    /// the sliding points).
    fn friction(
        &self,
        f_h: [f64; 3],
        axis: [f64; 3],
        normal_n: [f64; 2],
        com_velocity: [f64; 3],
        points: &[([f64; 3], [f64; 3]); 2],
    ) -> ([f64; 3], f64) {
        let lat = [-axis[1], axis[0], 0.0];
        let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1];
        let mut viscous = [0.0; 3];
        if self.viscous_tangential_n_s_per_m > 0.0 || self.viscous_normal_n_s_per_m > 0.0 {
            let (vt, vn) = (dot(com_velocity, axis), dot(com_velocity, lat));
            viscous = add(
                scale(axis, -self.viscous_tangential_n_s_per_m * vt),
                scale(lat, -self.viscous_normal_n_s_per_m * vn),
            );
        }
        let (n_lo, n_hi) = (normal_n[0].min(normal_n[1]).max(0.0), normal_n[0].max(normal_n[1]).max(0.0));
        if n_hi <= 0.0 {
            return (viscous, 0.0);
        }
        // Sliding friction per newton of support (each point carries half).
        let mut unit = [0.0; 3];
        let mut unit_moment_z = 0.0;
        let mut stick_share = 0.0;
        for (r, v) in points {
            let (va, vl) = (dot(*v, axis), dot(*v, lat));
            if va.hypot(vl) < self.sliding_speed_m_per_s {
                stick_share += 0.5;
                continue;
            }
            // Friction along the axis opposes va: toward the tail (−x) when sliding forward.
            let mu_a = if va > 0.0 { self.mu_forward } else { self.mu_backward };
            let (a, b) = (mu_a * 0.5, self.mu_lateral * 0.5);
            let d = (a * a * va * va + b * b * vl * vl).sqrt();
            if d <= 0.0 {
                continue;
            }
            let (fa, fl) = (-a * a * va / d, -b * b * vl / d);
            let f = add(scale(axis, fa), scale(lat, fl));
            unit = add(unit, f);
            unit_moment_z += r[0] * f[1] - r[1] * f[0];
        }
        // The support within [n_lo, n_hi] that explains most of the horizontal force.
        let rest_h = [f_h[0] - viscous[0], f_h[1] - viscous[1], 0.0];
        let unit_sq = dot(unit, unit);
        let n_slide = if unit_sq > 0.0 { (dot(rest_h, unit) / unit_sq).clamp(n_lo, n_hi) } else { n_hi };
        let mut friction = add(viscous, scale(unit, n_slide));
        let moment_z = n_slide * unit_moment_z;
        if stick_share > 0.0 {
            // The sticking points take what they can of the rest.
            let n_stick = stick_share * n_hi;
            let rest = [f_h[0] - friction[0], f_h[1] - friction[1], 0.0];
            let (ra, rl) = (dot(rest, axis), dot(rest, lat));
            let mu_a = if ra < 0.0 { self.mu_forward } else { self.mu_backward };
            let (fa, fl) = crate::state::project_to_ellipse(ra, rl, mu_a * n_stick, self.mu_lateral * n_stick);
            friction = add(friction, add(scale(axis, fa), scale(lat, fl)));
        }
        (friction, moment_z)
    }
}

/// The estimator of the step loop (module documentation). Built once; `update` does not
/// allocate.
pub struct MotionEstimator {
    geometry: ChainGeometry,
    orientation: OrientationSource,
    detection_threshold_n: f64,
    min_lateral_force_n: f64,
    floor: FloorShare,
    attitude: HeadAttitude,
    estimator: Box<dyn ContactEstimator + Send + Sync>,
    input: EstimatorInput,
    out: EstimateOutput,
    poses: LinkPoses,
    /// Per link: the floor's support of the previous update (N; NaN before the first).
    previous_normal_n: Vec<f64>,
}

impl std::fmt::Debug for MotionEstimator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MotionEstimator").field("orientation", &self.orientation).finish_non_exhaustive()
    }
}

impl MotionEstimator {
    /// The estimator that `config`'s `[estimation]` describes, with the Newton–Euler estimator,
    /// for a snake with these link masses (kg).
    pub fn from_config(config: &Config, link_mass_kg: &[f64]) -> Self {
        Self::with_estimator(config, link_mass_kg, Box::new(NewtonEulerEstimator::default()))
    }

    /// The same with your own estimator of the external forces (stage 2).
    pub fn with_estimator(
        config: &Config,
        link_mass_kg: &[f64],
        estimator: Box<dyn ContactEstimator + Send + Sync>,
    ) -> Self {
        let e = &config.estimation;
        let geometry = ChainGeometry::from_config(config, link_mass_kg);
        let n = geometry.n_links();
        let mut input = EstimatorInput::new(n);
        input.link_mass_kg.copy_from_slice(link_mass_kg);
        Self {
            geometry,
            orientation: e.orientation,
            detection_threshold_n: e.detection_threshold_n,
            min_lateral_force_n: e.min_lateral_force_n,
            floor: FloorShare::from_config(config),
            attitude: HeadAttitude::new(e.tilt_gain_per_s),
            estimator,
            input,
            out: EstimateOutput::new(n),
            poses: LinkPoses::new(n),
            previous_normal_n: vec![f64::NAN; n],
        }
    }

    /// Whether [`MotionEstimator::update`] needs the simulator's poses.
    pub fn needs_true_poses(&self) -> bool {
        self.orientation == OrientationSource::True
    }

    /// Forgets the attitude filter's state (it restarts at the next update's head pose).
    pub fn reset(&mut self) {
        self.attitude.time_secs = None;
        self.previous_normal_n.fill(f64::NAN);
    }

    /// The link poses of the latest update (estimated or true).
    pub fn poses(&self) -> &LinkPoses {
        &self.poses
    }

    /// The estimates of this instant from the measured observation `obs` into `out` (sized by
    /// [`ContactEstimates::new`]). `true_poses` are used with `orientation = "true"` (and for
    /// nothing else; `None` then falls back to the IMU chain).
    pub fn update(&mut self, obs: &Observation, true_poses: Option<&LinkPoses>, out: &mut ContactEstimates) {
        let n = self.geometry.n_links().min(out.n_links()).min(obs.imu_accel_m_per_s2.len());
        match (self.orientation, true_poses) {
            (OrientationSource::True, Some(p)) => {
                let p_n = p.quat.len().min(n);
                self.poses.quat[..p_n].copy_from_slice(&p.quat[..p_n]);
                self.poses.com_m[..p_n].copy_from_slice(&p.com_m[..p_n]);
                self.poses.origin_m[..p_n].copy_from_slice(&p.origin_m[..p_n]);
                self.poses.com_velocity_m_per_s[..p_n].copy_from_slice(&p.com_velocity_m_per_s[..p_n]);
                self.poses.angular_velocity_rad_per_s[..p_n].copy_from_slice(&p.angular_velocity_rad_per_s[..p_n]);
            }
            _ => self.chain_poses(obs, n),
        }
        // Stage 2: external forces (sensor values of obs, poses above).
        let input = &mut self.input;
        input.time_secs = obs.sensor_time_secs;
        for i in 0..n {
            input.link_rotation[i] = quat_to_matrix(self.poses.quat[i]);
        }
        input.link_com_m.copy_from_slice(&self.poses.com_m);
        input.link_origin_m.copy_from_slice(&self.poses.origin_m);
        let copy = |dst: &mut [[f64; 3]], src: &[[f64; 3]]| {
            for (d, s) in dst.iter_mut().zip(src) {
                *d = *s;
            }
        };
        copy(&mut input.accelerometer_m_per_s2, &obs.imu_accel_m_per_s2);
        copy(&mut input.joint_force_n, &obs.joint_force_n);
        copy(&mut input.joint_torque_nm, &obs.joint_torque_nm);
        self.estimator.estimate(&self.input, &mut self.out);
        // Stage 3: the floor's share and the obstacles'.
        let half_core = (0.5 * self.geometry.link_length_m - self.geometry.link_radius_m).max(0.0);
        for i in 0..n {
            let f = self.out.link_force_n[i];
            let r = &self.input.link_rotation[i];
            let axis3 = [r[0][0], r[1][0], r[2][0]];
            let h = axis3[0].hypot(axis3[1]);
            let axis = if h > 1e-9 { [axis3[0] / h, axis3[1] / h, 0.0] } else { [1.0, 0.0, 0.0] };
            let c = self.poses.com_m[i];
            let v = self.poses.com_velocity_m_per_s[i];
            let w = self.poses.angular_velocity_rad_per_s[i];
            let points = [1.0, -1.0].map(|side| {
                let rp = scale(axis3, side * half_core);
                (rp, add(v, cross(w, rp)))
            });
            let normal_n = f[2].max(0.0);
            let previous_n = std::mem::replace(&mut self.previous_normal_n[i], normal_n);
            let previous_n = if previous_n.is_nan() { normal_n } else { previous_n };
            let f_h = [f[0], f[1], 0.0];
            let (friction, friction_moment_z) = self.floor.friction(f_h, axis, [normal_n, previous_n], v, &points);
            let floor = [friction[0], friction[1], normal_n];
            let obstacle = [f[0] - friction[0], f[1] - friction[1], 0.0];
            out.external_force_n[i] = f;
            out.floor_force_n[i] = floor;
            out.obstacle_force_n[i] = obstacle;
            let magnitude = obstacle[0].hypot(obstacle[1]);
            let touching = magnitude >= self.detection_threshold_n && magnitude.is_finite();
            out.contact[i] = touching;
            let lateral = axis[0] * obstacle[1] - axis[1] * obstacle[0];
            let point = (touching && lateral.abs() >= self.min_lateral_force_n).then(|| {
                // The obstacle touches the capsule's side, r from the axis on the side the force
                // comes from; its axial part (peg friction) has the moment r·sign(f_lat)·f_a there.
                let axial = axis[0] * obstacle[0] + axis[1] * obstacle[1];
                let side = self.geometry.link_radius_m * lateral.signum() * axial;
                let moment = self.out.link_moment_nm[i][2] - friction_moment_z - side;
                (moment / lateral).clamp(-0.5 * self.geometry.link_length_m, 0.5 * self.geometry.link_length_m)
            });
            out.contact_point_along_m[i] = point;
            out.contact_point_m[i] = point.map(|s| add(c, scale(axis3, s)));
        }
        out.active = true;
    }

    /// Stage 1 with `orientation = "imu"`: head attitude filter, then the chain.
    fn chain_poses(&mut self, obs: &Observation, n: usize) {
        if n == 0 {
            return;
        }
        self.attitude.update(obs.sensor_time_secs, obs.imu_gyro_rad_per_s[0], obs.imu_accel_m_per_s2[0], obs.head_quat);
        let l = self.geometry.link_length_m;
        let p = &mut self.poses;
        let mut r = quat_to_matrix(self.attitude.quat);
        let mut origin = obs.head_position_m;
        let mut v_origin = [0.0; 3];
        for i in 0..n {
            if i > 0 {
                let q = obs.joint_angle_rad.get(i - 1).copied().unwrap_or(0.0);
                let axis = self.geometry.joint_axis.get(i - 1).copied().unwrap_or([0.0, 0.0, 1.0]);
                let r_parent = r;
                r = mat_mul(&r_parent, &axis_rotation(axis, q));
                let step = super::rotate(&r_parent, [-l, 0.0, 0.0]);
                v_origin = add(v_origin, cross(p.angular_velocity_rad_per_s[i - 1], step));
                origin = add(origin, step);
            }
            let w = super::rotate(&r, obs.imu_gyro_rad_per_s[i]);
            let to_com = super::rotate(&r, [-0.5 * l, 0.0, 0.0]);
            let com = add(origin, to_com);
            if i == 0 {
                // The head's centre-of-mass velocity is known; its frame origin's follows.
                v_origin = add(obs.head_velocity_m_per_s, cross(w, scale(to_com, -1.0)));
            }
            p.quat[i] = if i == 0 { self.attitude.quat } else { matrix_to_quat(&r) };
            p.origin_m[i] = origin;
            p.com_m[i] = com;
            p.angular_velocity_rad_per_s[i] = w;
            p.com_velocity_m_per_s[i] = add(v_origin, cross(w, to_com));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn straight_config(n: usize) -> Config {
        let mut c = Config::default();
        c.snake.n_links = n;
        c.ground.model = GroundModel::Anisotropic;
        c
    }

    #[test]
    fn chain_of_a_straight_snake_lies_along_minus_x() {
        let config = straight_config(3);
        let mut est = MotionEstimator::from_config(&config, &[0.3; 3]);
        let mut obs = Observation::new(3, 2);
        obs.head_quat = [1.0, 0.0, 0.0, 0.0];
        est.chain_poses(&obs, 3);
        let p = est.poses();
        assert!((p.com_m[2][0] + 0.5).abs() < 1e-12, "{:?}", p.com_m);
        assert!((p.origin_m[1][0] + 0.2).abs() < 1e-12);
    }

    #[test]
    fn chain_follows_the_encoders_and_the_gyros() {
        // Joint 1 at +90°: link 1 points along −y from its origin (rotated +90° about z), and
        // spinning the whole snake at ω about z moves link 1's centre with ω × r.
        let config = straight_config(2);
        let mut est = MotionEstimator::from_config(&config, &[0.3; 2]);
        let mut obs = Observation::new(2, 1);
        obs.head_quat = [1.0, 0.0, 0.0, 0.0];
        obs.joint_angle_rad[0] = std::f64::consts::FRAC_PI_2;
        let w = 0.7;
        obs.imu_gyro_rad_per_s = vec![[0.0, 0.0, w]; 2];
        // The head's centre (−0.1, 0, 0) moves with ω × c = (0, −0.1 ω, 0).
        obs.head_velocity_m_per_s = [0.0, -0.1 * w, 0.0];
        est.chain_poses(&obs, 2);
        let p = est.poses();
        assert!((p.com_m[1][0] + 0.2).abs() < 1e-12 && (p.com_m[1][1] + 0.1).abs() < 1e-12, "{:?}", p.com_m);
        // ω × (−0.2, −0.1, 0) = (0.1 ω, −0.2 ω, 0).
        let v = p.com_velocity_m_per_s[1];
        assert!((v[0] - 0.1 * w).abs() < 1e-12 && (v[1] + 0.2 * w).abs() < 1e-12, "{v:?}");
    }

    #[test]
    fn attitude_filter_integrates_a_constant_yaw_rate() {
        let mut f = HeadAttitude::new(1.0);
        let up = [0.0, 0.0, 9.81];
        f.update(0.0, [0.0, 0.0, 0.5], up, [1.0, 0.0, 0.0, 0.0]);
        for k in 1..=1000 {
            f.update(k as f64 * 1e-3, [0.0, 0.0, 0.5], up, [0.0; 4]);
        }
        // After 1 s at 0.5 rad/s: yaw 0.5 rad, q = (cos 0.25, 0, 0, sin 0.25).
        assert!((f.quat[0] - 0.25f64.cos()).abs() < 1e-9 && (f.quat[3] - 0.25f64.sin()).abs() < 1e-9, "{:?}", f.quat);
    }

    #[test]
    fn attitude_filter_pulls_a_wrong_tilt_back_to_the_accelerometer() {
        let mut f = HeadAttitude::new(2.0);
        let tilt = 0.2f64; // a wrong start: 0.2 rad about x
        f.update(0.0, [0.0; 3], [0.0, 0.0, 9.81], [(tilt / 2.0).cos(), (tilt / 2.0).sin(), 0.0, 0.0]);
        for k in 1..=5000 {
            f.update(k as f64 * 1e-3, [0.0; 3], [0.0, 0.0, 9.81], [0.0; 4]);
        }
        // Error decays like exp(−k t): 0.2·e^(−10) ≈ 1e−5 rad.
        assert!(f.quat[1].abs() < 1e-4, "{:?}", f.quat);
    }

    fn floor(mu_f: f64, mu_b: f64, mu_l: f64) -> FloorShare {
        FloorShare {
            mu_forward: mu_f,
            mu_backward: mu_b,
            mu_lateral: mu_l,
            viscous_tangential_n_s_per_m: 0.0,
            viscous_normal_n_s_per_m: 0.0,
            sliding_speed_m_per_s: 0.005,
        }
    }

    #[test]
    fn sliding_friction_is_the_maximum_dissipation_point_of_the_ellipse() {
        // Isotropic μ = 0.5, N = 2 N, sliding along +x at both points: F = (−1, 0) N in total.
        let fs = floor(0.5, 0.5, 0.5);
        let pts = [([0.06, 0.0, 0.0], [0.1, 0.0, 0.0]), ([-0.06, 0.0, 0.0], [0.1, 0.0, 0.0])];
        let (f, m) = fs.friction([0.0; 3], [1.0, 0.0, 0.0], [2.0; 2], [0.1, 0.0, 0.0], &pts);
        assert!((f[0] + 1.0).abs() < 1e-12 && f[1].abs() < 1e-12 && m.abs() < 1e-12, "{f:?}");
        // Anisotropic (0.1 along, 1.0 across), sliding at 45°: A = 0.1, B = 1.0 per point (N/2 = 1);
        // F ∝ −(A² v, B² v) / sqrt(A² v² + B² v²), on the ellipse.
        let fs = floor(0.1, 0.1, 1.0);
        let v = [0.1, 0.1, 0.0];
        let pts = [([0.06, 0.0, 0.0], v), ([-0.06, 0.0, 0.0], v)];
        let (f, _) = fs.friction([0.0; 3], [1.0, 0.0, 0.0], [2.0; 2], v, &pts);
        let d = (0.01f64 + 1.0).sqrt();
        assert!((f[0] + 2.0 * 0.01 / d).abs() < 1e-12 && (f[1] + 2.0 * 1.0 / d).abs() < 1e-12, "{f:?}");
    }

    #[test]
    fn sticking_floor_takes_up_to_its_limit_and_the_rest_is_obstacle() {
        // At rest, μ = 0.5, N = 2 N: the floor holds up to 1 N; a 3 N push leaves 2 N.
        let fs = floor(0.5, 0.5, 0.5);
        let pts = [([0.06, 0.0, 0.0], [0.0; 3]), ([-0.06, 0.0, 0.0], [0.0; 3])];
        let (f, _) = fs.friction([0.0, 3.0, 0.0], [1.0, 0.0, 0.0], [2.0; 2], [0.0; 3], &pts);
        assert!((f[1] - 1.0).abs() < 1e-9 && f[0].abs() < 1e-9, "{f:?}");
        let (f, _) = fs.friction([0.0, 0.4, 0.0], [1.0, 0.0, 0.0], [2.0; 2], [0.0; 3], &pts);
        assert!((f[1] - 0.4).abs() < 1e-12, "inside the limit the floor holds it all: {f:?}");
    }

    #[test]
    fn a_pushed_sliding_link_gets_its_obstacle_force_and_point_back() {
        // One link (head) sliding along +x at 0.1 m/s on an isotropic floor (μ = 0.5), an
        // obstacle pushing 2 N along +y at 3 cm ahead of the centre: the external force is
        // floor (−μ N, 0, N) + obstacle; the moment about the centre is the obstacle's plus the
        // friction's (zero: both points slide the same way, the moments cancel).
        let mut config = straight_config(1);
        config.ground.model = GroundModel::Isotropic;
        config.snake.ground_friction = [0.5, 0.0, 0.0];
        struct Fixed;
        impl ContactEstimator for Fixed {
            fn estimate(&mut self, _input: &EstimatorInput, out: &mut EstimateOutput) {
                let n = 0.3 * 9.81;
                out.link_force_n[0] = [-0.5 * n, 2.0, n];
                out.link_moment_nm[0] = [0.0, 0.0, 0.03 * 2.0];
            }
        }
        let mut est = MotionEstimator::with_estimator(&config, &[0.3], Box::new(Fixed));
        let mut obs = Observation::new(1, 0);
        obs.head_quat = [1.0, 0.0, 0.0, 0.0];
        obs.head_velocity_m_per_s = [0.1, 0.0, 0.0];
        let mut out = ContactEstimates::new(1);
        est.update(&obs, None, &mut out);
        let o = out.obstacle_force_n[0];
        assert!(o[0].abs() < 1e-9 && (o[1] - 2.0).abs() < 1e-9, "{o:?}");
        assert!(out.contact[0]);
        let s = out.contact_point_along_m[0].expect("2 N lateral determines the point");
        assert!((s - 0.03).abs() < 1e-9, "{s}");
    }

    #[test]
    fn ellipse_projection_lands_on_the_ellipse() {
        let (x, y) = crate::state::project_to_ellipse(3.0, 4.0, 1.0, 2.0);
        assert!(((x / 1.0).powi(2) + (y / 2.0).powi(2) - 1.0).abs() < 1e-9);
        assert_eq!(crate::state::project_to_ellipse(0.1, 0.1, 1.0, 2.0), (0.1, 0.1));
    }
}
