//! A PID controller with output saturation and integrator anti-windup.

/// PID on one scalar error. Output = kp·e + ki·∫e dt + kd·ė, clamped to `[min, max]`; the
/// integral stops growing while the output is saturated in the direction of the error
/// (conditional integration), so it does not wind up against the torque limit.
#[derive(Debug, Clone, PartialEq)]
pub struct Pid {
    kp: f64,
    ki: f64,
    kd: f64,
    min: f64,
    max: f64,
    integral: f64,
}

impl Pid {
    /// A PID with gains and output limits.
    pub fn new(kp: f64, ki: f64, kd: f64, min: f64, max: f64) -> Self {
        Self { kp, ki, kd, min, max, integral: 0.0 }
    }

    /// Forgets the integral.
    pub fn reset(&mut self) {
        self.integral = 0.0;
    }

    /// One update: `error` and its rate of change (the derivative is taken from the measured
    /// velocity, not by differencing, so it has no kick when the target jumps).
    pub fn update(&mut self, error: f64, error_rate: f64, dt_secs: f64) -> f64 {
        let candidate = self.integral + error * dt_secs;
        let unclamped = self.kp * error + self.ki * candidate + self.kd * error_rate;
        let out = unclamped.clamp(self.min, self.max);
        let saturated_same_way = (unclamped > self.max && error > 0.0) || (unclamped < self.min && error < 0.0);
        if !saturated_same_way {
            self.integral = candidate;
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn proportional_integral_derivative_terms() {
        let mut pid = Pid::new(2.0, 0.5, 0.1, -100.0, 100.0);
        let out = pid.update(1.0, -3.0, 0.01);
        assert!((out - (2.0 + 0.5 * 0.01 - 0.3)).abs() < 1e-12);
        let out = pid.update(1.0, 0.0, 0.01);
        assert!((out - (2.0 + 0.5 * 0.02)).abs() < 1e-12);
    }

    #[test]
    fn integral_does_not_wind_up_when_saturated() {
        let mut pid = Pid::new(10.0, 10.0, 0.0, -1.0, 1.0);
        for _ in 0..1000 {
            assert_eq!(pid.update(1.0, 0.0, 0.01), 1.0);
        }
        // After the error reverses the output leaves saturation at once.
        assert!(pid.update(-0.2, 0.0, 0.01) < 0.0);
    }
}
