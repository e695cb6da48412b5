//! Proprioceptive contact-force estimation (Boa's method) and its scoring. Pure: no MuJoCo.
//!
//! A snake robot like Boa has a 6-axis force/torque sensor at every joint and an IMU per link.
//! Newton's second law for link `i` (mass `mᵢ`, centre-of-mass acceleration `aᵢ`, world frame):
//!
//! ```text
//! mᵢ·aᵢ = f_ext,i + mᵢ·g + hᵢ − hᵢ₊₁
//! ```
//!
//! where `hᵢ` is the force that link `i−1` exerts on link `i` through joint `i` (the joint
//! force sensor, measured in link `i`'s frame: world `hᵢ = Rᵢ·sᵢ`), `−hᵢ₊₁` the reaction of link
//! `i+1` (its sensor `sᵢ₊₁` in link `i+1`'s frame: `Rᵢ₊₁·sᵢ₊₁`), and `f_ext,i` everything else:
//! ground reaction, obstacles, other links. The accelerometer reads the proper acceleration
//! `accᵢ = Rᵢᵀ·(aᵢ − g)` in the link frame, so
//!
//! ```text
//! f_ext,i = mᵢ·Rᵢ·accᵢ − Rᵢ·sᵢ + Rᵢ₊₁·sᵢ₊₁        (s₀ = s_n = 0: the ends have no joint)
//! ```
//!
//! and the total push on the robot is `Σᵢ f_ext,i`. Gravity needs no model: the accelerometer
//! includes it. The link orientations `Rᵢ` come from the simulator (a real robot estimates them
//! from its IMUs and encoders); the accelerometer must sit at the link's centre of mass (it does
//! in the generated snake).
//!
//! **Contact point.** The moment balance about the centre of mass `cᵢ`, quasi-static (the
//! link's `I·α + ω×I·ω` neglected), gives the moment of the external forces
//! `Mᵢ = −(τᵢ + (oᵢ − cᵢ)×hᵢ) + (τᵢ₊₁ + (oᵢ₊₁ − cᵢ)×hᵢ₊₁)` with `oᵢ` the joint anchors and `τᵢ`
//! the torque sensors (world frame). A single horizontal force `f` at `cᵢ + s·x̂ᵢ` on the link
//! axis `x̂ᵢ` has the vertical moment `s·(x̂ᵢ×f)·ẑ`, so `s = Mᵢ·ẑ / ((x̂ᵢ×f)·ẑ)`. Vertical forces
//! (the floor's normal force) have no vertical moment and do not disturb it; ground friction does,
//! so the point is only meaningful when the obstacle force dominates. The estimator reports it
//! when the lateral part `|(x̂ᵢ×f)·ẑ|` of the horizontal force is at least
//! [`NewtonEulerEstimator::min_lateral_force_n`], else `None`.
//!
//! **Noise propagation.** With independent zero-mean noise of standard deviation `σ_a` on each
//! accelerometer axis and `σ_f` on each force-sensor axis, each term above is a rotation of an
//! isotropic Gaussian vector, which is again isotropic with the same σ; the terms are independent,
//! so each world axis of the error of `f_ext,i` has the variance
//! `mᵢ²·σ_a² + k·σ_f²`, `k` the number of joints adjacent to link `i` (1 at the ends, else 2).
//! [`predicted_error_std_n`] computes it; a test checks the measured error against it.

pub use crate::state::ContactEstimates;
use crate::state::Observation;

mod motion;
mod score;

pub use motion::{
    ChainGeometry, FloorShare, FrictionFit, HeadAttitude, LinkPoses, MotionEstimator, MotionEstimatorState,
};
pub use score::{LinkSample, MotionScore};

/// What an estimator gets at one instant: per link (`n_links`) and per joint (`n_joints =
/// n_links − 1`, joint `j` between links `j` and `j+1`). World frame unless the name says
/// otherwise.
#[derive(Debug, Clone, Default)]
pub struct EstimatorInput {
    /// Simulated time (s).
    pub time_secs: f64,
    /// Link masses (kg).
    pub link_mass_kg: Vec<f64>,
    /// Link orientations: rotation matrix from the link frame to the world, row-major
    /// (from the simulator).
    pub link_rotation: Vec<[[f64; 3]; 3]>,
    /// Link centres of mass (m).
    pub link_com_m: Vec<[f64; 3]>,
    /// Link frame origins = anchor of the joint to the parent link (m).
    pub link_origin_m: Vec<[f64; 3]>,
    /// Accelerometer (proper acceleration, link frame, m/s²), as measured.
    pub accelerometer_m_per_s2: Vec<[f64; 3]>,
    /// Joint force sensors: force of link `j` on link `j+1`, link `j+1`'s frame (N), as measured.
    pub joint_force_n: Vec<[f64; 3]>,
    /// Joint torque sensors: the matching torque about the anchor, link `j+1`'s frame (N·m).
    pub joint_torque_nm: Vec<[f64; 3]>,
}

/// What an estimator writes.
#[derive(Debug, Clone, Default)]
pub struct EstimateOutput {
    /// Per link: estimated external force (N).
    pub link_force_n: Vec<[f64; 3]>,
    /// Sum over the links: the total push on the robot (N).
    pub total_force_n: [f64; 3],
    /// Per link: estimated point of application on the link axis (m), where the data determine it.
    pub link_contact_point_m: Vec<Option<[f64; 3]>>,
    /// Per link: moment of the external forces about the centre of mass (N·m, world frame,
    /// quasi-static). Estimators that do not compute it leave zeros (the floor separation then
    /// puts the obstacle's contact point at the centre of mass).
    pub link_moment_nm: Vec<[f64; 3]>,
}

/// A contact-force estimator. Implement it to score your own estimator the same way as the
/// built-in [`NewtonEulerEstimator`] (see `simserpent experiment estimation`). Must not allocate
/// if it runs in a step loop.
pub trait ContactEstimator {
    /// Estimates the external forces of this instant into `out` (sized by [`EstimateOutput::new`]).
    fn estimate(&mut self, input: &EstimatorInput, out: &mut EstimateOutput);
}

impl EstimatorInput {
    /// An input sized for `n_links` links.
    pub fn new(n_links: usize) -> Self {
        let n_joints = n_links.saturating_sub(1);
        Self {
            time_secs: 0.0,
            link_mass_kg: vec![0.0; n_links],
            link_rotation: vec![IDENTITY; n_links],
            link_com_m: vec![[0.0; 3]; n_links],
            link_origin_m: vec![[0.0; 3]; n_links],
            accelerometer_m_per_s2: vec![[0.0; 3]; n_links],
            joint_force_n: vec![[0.0; 3]; n_joints],
            joint_torque_nm: vec![[0.0; 3]; n_joints],
        }
    }

    /// Number of links.
    pub fn n_links(&self) -> usize {
        self.link_mass_kg.len()
    }

    /// Copies the sensor values of `obs` (accelerometers, joint force/torque sensors) and the
    /// link poses (orientation quaternions w, x, y, z; centres of mass; frame origins). Slices
    /// must have this input's sizes; extra entries are ignored. Does not allocate.
    pub fn fill(
        &mut self,
        obs: &Observation,
        link_quat: &[[f64; 4]],
        link_com_m: &[[f64; 3]],
        link_origin_m: &[[f64; 3]],
    ) {
        self.time_secs = obs.sensor_time_secs;
        for (r, q) in self.link_rotation.iter_mut().zip(link_quat) {
            *r = quat_to_matrix(*q);
        }
        copy(&mut self.link_com_m, link_com_m);
        copy(&mut self.link_origin_m, link_origin_m);
        copy(&mut self.accelerometer_m_per_s2, &obs.imu_accel_m_per_s2);
        copy(&mut self.joint_force_n, &obs.joint_force_n);
        copy(&mut self.joint_torque_nm, &obs.joint_torque_nm);
    }
}

fn copy(dst: &mut [[f64; 3]], src: &[[f64; 3]]) {
    for (d, s) in dst.iter_mut().zip(src) {
        *d = *s;
    }
}

impl EstimateOutput {
    /// An output sized for `n_links` links.
    pub fn new(n_links: usize) -> Self {
        Self {
            link_force_n: vec![[0.0; 3]; n_links],
            total_force_n: [0.0; 3],
            link_contact_point_m: vec![None; n_links],
            link_moment_nm: vec![[0.0; 3]; n_links],
        }
    }
}

const IDENTITY: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// Rotation matrix (row-major, body → world) of a unit quaternion (w, x, y, z).
pub fn quat_to_matrix(q: [f64; 4]) -> [[f64; 3]; 3] {
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    if n.is_nan() || n <= 0.0 || !n.is_finite() {
        return IDENTITY;
    }
    let [w, x, y, z] = [q[0] / n, q[1] / n, q[2] / n, q[3] / n];
    [
        [1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - w * z), 2.0 * (x * z + w * y)],
        [2.0 * (x * y + w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - w * x)],
        [2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y)],
    ]
}

/// `r`·`v`: the vector `v` turned by the rotation matrix `r` (row-major).
pub fn rotate(r: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    [
        r[0][0] * v[0] + r[0][1] * v[1] + r[0][2] * v[2],
        r[1][0] * v[0] + r[1][1] * v[1] + r[1][2] * v[2],
        r[2][0] * v[0] + r[2][1] * v[1] + r[2][2] * v[2],
    ]
}

pub(crate) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub(crate) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

/// The built-in estimator: Newton's law per link from the joint force sensors and the
/// accelerometers (module documentation), and the contact point from the quasi-static moment
/// balance.
#[derive(Debug, Clone)]
pub struct NewtonEulerEstimator {
    /// Smallest lateral horizontal force (N) for which a contact point is reported.
    pub min_lateral_force_n: f64,
}

impl Default for NewtonEulerEstimator {
    fn default() -> Self {
        Self { min_lateral_force_n: 0.5 }
    }
}

impl ContactEstimator for NewtonEulerEstimator {
    fn estimate(&mut self, input: &EstimatorInput, out: &mut EstimateOutput) {
        // Links that every per-link vector covers (inconsistent sizes never panic).
        let n = [
            input.link_mass_kg.len(),
            input.link_rotation.len(),
            input.link_com_m.len(),
            input.link_origin_m.len(),
            input.accelerometer_m_per_s2.len(),
            out.link_force_n.len(),
            out.link_contact_point_m.len(),
        ]
        .into_iter()
        .min()
        .unwrap_or(0);
        out.total_force_n = [0.0; 3];
        for i in 0..n {
            let r = &input.link_rotation[i];
            let m = input.link_mass_kg[i];
            let c = input.link_com_m[i];
            let mut f = rotate(r, input.accelerometer_m_per_s2[i]).map(|a| m * a);
            let mut moment = [0.0; 3];
            // Joint to the parent (index i − 1): the parent pushes link i with h_i.
            let parent =
                i.checked_sub(1).and_then(|j| Some((input.joint_force_n.get(j)?, input.joint_torque_nm.get(j)?)));
            if let Some((s, t)) = parent {
                let (h, tau) = (rotate(r, *s), rotate(r, *t));
                let arm = cross(sub(input.link_origin_m[i], c), h);
                for k in 0..3 {
                    f[k] -= h[k];
                    moment[k] -= tau[k] + arm[k];
                }
            }
            // Joint to the child (index i): link i + 1 pushes back with −h_(i+1).
            let child = (i + 1 < n)
                .then(|| {
                    Some((input.link_rotation.get(i + 1)?, input.joint_force_n.get(i)?, input.joint_torque_nm.get(i)?))
                })
                .flatten();
            if let Some((rc, s, t)) = child {
                let (h, tau) = (rotate(rc, *s), rotate(rc, *t));
                let arm = cross(sub(input.link_origin_m[i + 1], c), h);
                for k in 0..3 {
                    f[k] += h[k];
                    moment[k] += tau[k] + arm[k];
                }
            }
            out.link_force_n[i] = f;
            if let Some(m) = out.link_moment_nm.get_mut(i) {
                *m = moment;
            }
            for (total, fk) in out.total_force_n.iter_mut().zip(f) {
                *total += fk;
            }
            // Point on the link axis: s·(x̂ × f)·ẑ = M·ẑ.
            let axis = [r[0][0], r[1][0], r[2][0]];
            let lateral = axis[0] * f[1] - axis[1] * f[0];
            out.link_contact_point_m[i] =
                (lateral.abs() >= self.min_lateral_force_n && lateral.is_finite()).then(|| {
                    let s = moment[2] / lateral;
                    [c[0] + s * axis[0], c[1] + s * axis[1], c[2] + s * axis[2]]
                });
        }
    }
}

/// Per-axis standard deviation (N) of the estimation error of a link's external force, for
/// independent Gaussian noise `accel_std_m_per_s2` on each accelerometer axis and
/// `force_std_n` on each force-sensor axis (module documentation):
/// `sqrt(m²·σ_a² + k·σ_f²)` with `k` the number of joints adjacent to the link.
pub fn predicted_error_std_n(mass_kg: f64, adjacent_joints: usize, accel_std_m_per_s2: f64, force_std_n: f64) -> f64 {
    (mass_kg * mass_kg * accel_std_m_per_s2 * accel_std_m_per_s2 + adjacent_joints as f64 * force_std_n * force_std_n)
        .sqrt()
}

/// Number of joints adjacent to link `i` of a chain of `n_links` links.
pub fn adjacent_joints(i: usize, n_links: usize) -> usize {
    usize::from(i > 0) + usize::from(i + 1 < n_links)
}

/// Scores an estimate against the truth over time, per link: RMSE and bias per world axis, and
/// contact detection (a contact is present when the force's magnitude reaches the threshold).
#[derive(Debug, Clone)]
pub struct EstimationScore {
    /// Force magnitude (N) from which a contact counts as present, in the truth and the estimate.
    pub detection_threshold_n: f64,
    /// Samples scored.
    pub samples: usize,
    /// Per link: sums of the error (estimate − truth) and of its square, per axis.
    error_sum: Vec<[f64; 3]>,
    error_sq_sum: Vec<[f64; 3]>,
    /// Per link: detection counts.
    pub hits: Vec<usize>,
    pub misses: Vec<usize>,
    pub false_alarms: Vec<usize>,
}

impl EstimationScore {
    /// An empty score for `n_links` links.
    pub fn new(n_links: usize, detection_threshold_n: f64) -> Self {
        Self {
            detection_threshold_n,
            samples: 0,
            error_sum: vec![[0.0; 3]; n_links],
            error_sq_sum: vec![[0.0; 3]; n_links],
            hits: vec![0; n_links],
            misses: vec![0; n_links],
            false_alarms: vec![0; n_links],
        }
    }

    /// Adds one instant: per link estimated and true force (N).
    pub fn add(&mut self, estimate_n: &[[f64; 3]], truth_n: &[[f64; 3]]) {
        self.samples += 1;
        for (i, (e, t)) in estimate_n.iter().zip(truth_n).enumerate().take(self.hits.len()) {
            for k in 0..3 {
                let d = e[k] - t[k];
                self.error_sum[i][k] += d;
                self.error_sq_sum[i][k] += d * d;
            }
            let norm = |v: &[f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            match (norm(e) >= self.detection_threshold_n, norm(t) >= self.detection_threshold_n) {
                (true, true) => self.hits[i] += 1,
                (false, true) => self.misses[i] += 1,
                (true, false) => self.false_alarms[i] += 1,
                (false, false) => {}
            }
        }
    }

    /// Per link: mean error (bias) per axis (N).
    pub fn bias_n(&self, link: usize) -> [f64; 3] {
        let n = self.samples.max(1) as f64;
        self.error_sum.get(link).map_or([0.0; 3], |s| [s[0] / n, s[1] / n, s[2] / n])
    }

    /// Per link: root-mean-square error per axis (N).
    pub fn rmse_n(&self, link: usize) -> [f64; 3] {
        let n = self.samples.max(1) as f64;
        self.error_sq_sum.get(link).map_or([0.0; 3], |s| [(s[0] / n).sqrt(), (s[1] / n).sqrt(), (s[2] / n).sqrt()])
    }

    /// Per link: RMS of the error vector's magnitude (N).
    pub fn rmse_norm_n(&self, link: usize) -> f64 {
        let r = self.rmse_n(link);
        (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quaternion_rotates_like_mujoco() {
        // 90° about z: x → y.
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let r = quat_to_matrix([h, 0.0, 0.0, h]);
        let v = rotate(&r, [1.0, 0.0, 0.0]);
        assert!((v[0]).abs() < 1e-12 && (v[1] - 1.0).abs() < 1e-12 && v[2].abs() < 1e-12);
    }

    #[test]
    fn a_chain_at_rest_on_a_table_has_only_the_weight_as_external_force() {
        // Three links in a row along −x, at rest: accelerometers read +g (proper acceleration),
        // joints carry no force; the external force is the floor's m·g up.
        let mut input = EstimatorInput::new(3);
        for i in 0..3 {
            input.link_mass_kg[i] = 0.5;
            input.accelerometer_m_per_s2[i] = [0.0, 0.0, 9.81];
        }
        let mut out = EstimateOutput::new(3);
        NewtonEulerEstimator::default().estimate(&input, &mut out);
        for f in &out.link_force_n {
            assert!((f[2] - 0.5 * 9.81).abs() < 1e-12);
        }
        assert!((out.total_force_n[2] - 1.5 * 9.81).abs() < 1e-12);
        assert!(out.link_contact_point_m.iter().all(Option::is_none));
    }

    #[test]
    fn a_pushed_static_link_places_the_contact_where_the_moment_says() {
        // Link 0 (head, from x = −0.2 to 0, CoM at −0.1) held by joint 1 at x = −0.2, pushed at
        // x = −0.05 by 2 N along +y. Statics: link 1 pushes link 0 with −h₁ = (0, −2, 0), so the
        // sensor reads h₁ = (0, 2, 0); about the anchor, −τ₁ balances (0.15, 0, 0) × (0, 2, 0)
        // = (0, 0, 0.3), so τ₁ = (0, 0, 0.3).
        let mut input = EstimatorInput::new(2);
        input.link_mass_kg = vec![0.4, 0.4];
        input.link_com_m = vec![[-0.1, 0.0, 0.0], [-0.3, 0.0, 0.0]];
        input.link_origin_m = vec![[0.0, 0.0, 0.0], [-0.2, 0.0, 0.0]];
        input.joint_force_n[0] = [0.0, 2.0, 0.0];
        input.joint_torque_nm[0] = [0.0, 0.0, 0.3];
        let mut out = EstimateOutput::new(2);
        NewtonEulerEstimator::default().estimate(&input, &mut out);
        assert!((out.link_force_n[0][1] - 2.0).abs() < 1e-12, "{:?}", out.link_force_n[0]);
        let p = out.link_contact_point_m[0].expect("lateral force of 2 N determines the point");
        assert!((p[0] + 0.05).abs() < 1e-12, "{p:?}");
    }

    #[test]
    fn predicted_error_adds_variances() {
        assert!((predicted_error_std_n(2.0, 2, 0.1, 0.3) - (0.04f64 + 0.18).sqrt()).abs() < 1e-15);
        assert_eq!(adjacent_joints(0, 5), 1);
        assert_eq!(adjacent_joints(2, 5), 2);
        assert_eq!(adjacent_joints(4, 5), 1);
        assert_eq!(adjacent_joints(0, 1), 0);
    }

    #[test]
    fn score_counts_detections_and_errors() {
        let mut s = EstimationScore::new(1, 1.0);
        s.add(&[[2.0, 0.0, 0.0]], &[[1.5, 0.0, 0.0]]);
        s.add(&[[0.0, 0.0, 0.0]], &[[1.5, 0.0, 0.0]]);
        s.add(&[[1.5, 0.0, 0.0]], &[[0.0, 0.0, 0.0]]);
        assert_eq!((s.hits[0], s.misses[0], s.false_alarms[0]), (1, 1, 1));
        assert!((s.bias_n(0)[0] - (0.5 - 1.5 + 1.5) / 3.0).abs() < 1e-12);
        assert!((s.rmse_n(0)[0] - ((0.25 + 2.25 + 2.25) / 3.0f64).sqrt()).abs() < 1e-12);
    }
}
