//! Scores of obstacle-contact estimation in motion: detection, obstacle-force error, contact
//! point. Used by `simserpent estimate`, the `estimation` experiment and your own tests.
//!
//! Per link-step (one link at one recorded instant):
//! - **present**: the true horizontal obstacle force reaches the detection threshold;
//!   **detected**: the estimator's contact flag. Detection rate = hits / (hits + misses) over the
//!   present link-steps; false-alarm rate = false alarms / (false alarms + correct rejections)
//!   over the absent ones.
//! - **obstacle-force RMSE** over the present link-steps, of the horizontal error vector,
//!   relative to the RMS of the true horizontal obstacle force over the same link-steps.
//! - **contact point**: where the true lateral obstacle force (across the link) exceeds
//!   `point_min_lateral_n` (1 N in the targets) and the estimator reports a point, the error
//!   along the link; the share of such link-steps within `point_tolerance_m` (and how many had
//!   no point).
//! - **false force**: over the link-steps with no true obstacle contact at all (true obstacle
//!   force exactly zero), the horizontal obstacle force the estimator reports anyway: the share of
//!   them above `false_force_threshold_n`, the largest value and its RMS. The detection and
//!   force scores above cannot see it: the false-alarm rate counts a 1-N and a 200-N phantom
//!   alike, and the force RMSE only scores link-steps with a true contact. The targets use a
//!   link's weight m·g as the threshold: a floor with μ ≤ 1 cannot hold a link sideways with more
//!   than its weight, so a reported obstacle force beyond it cannot be floor friction the floor
//!   model put in the wrong place — it is a phantom push, as large as a real one.

/// Accumulated scores (see the module documentation).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MotionScore {
    /// Truth threshold (N) of a present contact.
    pub threshold_n: f64,
    /// True lateral force (N) from which the contact point is scored.
    pub point_min_lateral_n: f64,
    /// Contact-point tolerance (m).
    pub point_tolerance_m: f64,
    /// Estimated horizontal obstacle force (N) from which a link-step without any true obstacle
    /// contact counts as a false force.
    pub false_force_threshold_n: f64,
    pub hits: u64,
    pub misses: u64,
    pub false_alarms: u64,
    pub correct_rejections: u64,
    /// Σ|error|² and Σ|truth|² of the horizontal obstacle force over present link-steps (N²).
    pub error_sq_sum: f64,
    pub truth_sq_sum: f64,
    /// Contact points scored, within tolerance, missing (no estimate), and Σ|error| (m).
    pub points: u64,
    pub points_within: u64,
    pub points_missing: u64,
    pub point_error_sum_m: f64,
    /// Link-steps without any true obstacle contact; those whose estimated horizontal obstacle
    /// force exceeds `false_force_threshold_n`; the largest such force (N) and Σ of its square (N²).
    pub free_link_steps: u64,
    pub false_forces: u64,
    pub false_force_max_n: f64,
    pub false_force_sq_sum: f64,
}

/// One link at one instant: truth and estimate.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct LinkSample {
    /// True obstacle force on the link (N, world).
    pub true_obstacle_n: [f64; 3],
    /// True contact point along the link from its centre (m), if it touches an obstacle.
    pub true_point_along_m: Option<f64>,
    /// The link's horizontal axis (unit, world) to split lateral from axial force.
    pub axis: [f64; 3],
    /// Estimated obstacle force (N), contact flag and point along the link (m).
    pub estimated_obstacle_n: [f64; 3],
    pub detected: bool,
    pub estimated_point_along_m: Option<f64>,
}

impl MotionScore {
    /// An empty score. `false_force_threshold_n`: see the module documentation (the targets use
    /// a link's weight).
    pub fn new(
        threshold_n: f64,
        point_min_lateral_n: f64,
        point_tolerance_m: f64,
        false_force_threshold_n: f64,
    ) -> Self {
        Self { threshold_n, point_min_lateral_n, point_tolerance_m, false_force_threshold_n, ..Self::default() }
    }

    /// The scores of the estimation targets for `config`'s estimator: detection at
    /// `estimation.detection_threshold_n`, contact points where the true lateral force exceeds
    /// 1 N within 1 cm, false forces above one link's weight (`snake.link_mass_kg` × |gravity|).
    pub fn for_targets(config: &crate::config::Config) -> Self {
        let g = config.general.gravity_m_per_s2;
        let weight_n = config.snake.link_mass_kg * (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
        Self::new(config.estimation.detection_threshold_n, 1.0, 0.01, weight_n)
    }

    /// Adds one link-step.
    pub fn add(&mut self, s: &LinkSample) {
        let t = s.true_obstacle_n;
        let present = t[0].hypot(t[1]) >= self.threshold_n;
        match (present, s.detected) {
            (true, true) => self.hits += 1,
            (true, false) => self.misses += 1,
            (false, true) => self.false_alarms += 1,
            (false, false) => self.correct_rejections += 1,
        }
        if present {
            let e = [s.estimated_obstacle_n[0] - t[0], s.estimated_obstacle_n[1] - t[1]];
            self.error_sq_sum += e[0] * e[0] + e[1] * e[1];
            self.truth_sq_sum += t[0] * t[0] + t[1] * t[1];
        }
        if t == [0.0; 3] {
            let e = s.estimated_obstacle_n[0].hypot(s.estimated_obstacle_n[1]);
            self.free_link_steps += 1;
            if e > self.false_force_threshold_n {
                self.false_forces += 1;
            }
            self.false_force_max_n = self.false_force_max_n.max(e);
            self.false_force_sq_sum += e * e;
        }
        let lateral = (s.axis[0] * t[1] - s.axis[1] * t[0]).abs();
        if let (true, Some(truth)) = (lateral > self.point_min_lateral_n, s.true_point_along_m) {
            self.points += 1;
            match s.estimated_point_along_m {
                Some(p) => {
                    let err = (p - truth).abs();
                    self.point_error_sum_m += err;
                    if err <= self.point_tolerance_m {
                        self.points_within += 1;
                    }
                }
                None => self.points_missing += 1,
            }
        }
    }

    /// Adds another score's counts (same thresholds).
    pub fn merge(&mut self, o: &MotionScore) {
        self.hits += o.hits;
        self.misses += o.misses;
        self.false_alarms += o.false_alarms;
        self.correct_rejections += o.correct_rejections;
        self.error_sq_sum += o.error_sq_sum;
        self.truth_sq_sum += o.truth_sq_sum;
        self.points += o.points;
        self.points_within += o.points_within;
        self.points_missing += o.points_missing;
        self.point_error_sum_m += o.point_error_sum_m;
        self.free_link_steps += o.free_link_steps;
        self.false_forces += o.false_forces;
        self.false_force_max_n = self.false_force_max_n.max(o.false_force_max_n);
        self.false_force_sq_sum += o.false_force_sq_sum;
    }

    /// hits / (hits + misses); NaN without present contacts.
    pub fn detection_rate(&self) -> f64 {
        self.hits as f64 / (self.hits + self.misses) as f64
    }

    /// false alarms / (false alarms + correct rejections); NaN without absent link-steps.
    pub fn false_alarm_rate(&self) -> f64 {
        self.false_alarms as f64 / (self.false_alarms + self.correct_rejections) as f64
    }

    /// RMSE of the horizontal obstacle force / RMS of the true one, over present link-steps.
    pub fn relative_force_rmse(&self) -> f64 {
        (self.error_sq_sum / self.truth_sq_sum).sqrt()
    }

    /// RMS of the true horizontal obstacle force over present link-steps (N).
    pub fn truth_rms_n(&self) -> f64 {
        (self.truth_sq_sum / (self.hits + self.misses) as f64).sqrt()
    }

    /// Share of the scored contact points within the tolerance (missing ones count as outside).
    pub fn point_within_rate(&self) -> f64 {
        self.points_within as f64 / self.points as f64
    }

    /// Share of the link-steps without true obstacle contact on which the estimator reports more
    /// than `false_force_threshold_n` of obstacle force; NaN without such link-steps.
    pub fn false_force_rate(&self) -> f64 {
        self.false_forces as f64 / self.free_link_steps as f64
    }

    /// RMS of the estimated horizontal obstacle force over the link-steps without true obstacle
    /// contact (N); NaN without such link-steps.
    pub fn false_force_rms_n(&self) -> f64 {
        (self.false_force_sq_sum / self.free_link_steps as f64).sqrt()
    }

    /// Mean contact-point error (m) over the scored points that had an estimate.
    pub fn mean_point_error_m(&self) -> f64 {
        self.point_error_sum_m / (self.points - self.points_missing) as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_rates_and_errors() {
        let mut s = MotionScore::new(0.5, 1.0, 0.01, 3.0);
        let base = LinkSample { axis: [1.0, 0.0, 0.0], ..LinkSample::default() };
        // Present, detected, 2 N across at +3 cm, estimated 1.8 N at +3.5 cm.
        s.add(&LinkSample {
            true_obstacle_n: [0.0, 2.0, 0.0],
            true_point_along_m: Some(0.03),
            estimated_obstacle_n: [0.0, 1.8, 0.0],
            detected: true,
            estimated_point_along_m: Some(0.035),
            ..base
        });
        // Present, missed.
        s.add(&LinkSample { true_obstacle_n: [0.6, 0.0, 0.0], ..base });
        // Absent, false alarm with a 4 N phantom; absent, rejected, a 0.3 N one.
        s.add(&LinkSample { detected: true, estimated_obstacle_n: [0.0, -4.0, 0.0], ..base });
        s.add(&LinkSample { estimated_obstacle_n: [0.3, 0.0, 0.0], ..base });
        assert_eq!((s.hits, s.misses, s.false_alarms, s.correct_rejections), (1, 1, 1, 1));
        assert!((s.detection_rate() - 0.5).abs() < 1e-12);
        assert!((s.false_alarm_rate() - 0.5).abs() < 1e-12);
        assert!((s.relative_force_rmse() - ((0.04f64 + 0.36) / (4.0 + 0.36)).sqrt()).abs() < 1e-12);
        assert_eq!((s.points, s.points_within), (1, 1));
        assert!((s.mean_point_error_m() - 0.005).abs() < 1e-12);
        // False force: the two link-steps without any true obstacle force (the missed 0.6 N
        // contact is a contact, not a free link-step); one of them above 3 N.
        assert_eq!((s.free_link_steps, s.false_forces), (2, 1));
        assert!((s.false_force_rate() - 0.5).abs() < 1e-12);
        assert_eq!(s.false_force_max_n, 4.0);
        assert!((s.false_force_rms_n() - ((16.0f64 + 0.09) / 2.0).sqrt()).abs() < 1e-12);
        // Merging keeps the largest and adds the counts.
        let mut m = MotionScore::new(0.5, 1.0, 0.01, 3.0);
        m.add(&LinkSample { estimated_obstacle_n: [5.0, 0.0, 0.0], ..base });
        m.merge(&s);
        assert_eq!((m.free_link_steps, m.false_forces, m.false_force_max_n), (3, 2, 5.0));
    }
}
