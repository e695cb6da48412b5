//! `[ros2]`: how the run speaks ROS 2 — the names of its topics and frames in the bag file
//! (`recording.format` with `"mcap"`) — and how its contacts are drawn.

use super::ConfigError;
use serde::{Deserialize, Serialize};

/// The `[ros2]` section.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Ros2 {
    /// Namespace of the robot's own topics (`/<namespace>/link_00/imu`, …); `/clock`, `/tf`
    /// and `/joint_states` stay global, as ROS 2 tools expect them. Empty = no namespace.
    pub namespace: String,
    /// Length of a contact force arrow in `/<namespace>/contacts` (m per N of force).
    pub contact_arrow_m_per_n: f64,
}

impl Ros2 {
    /// The topic `/<namespace>/<name>` (or `/<name>` without a namespace).
    pub fn topic(&self, name: &str) -> String {
        if self.namespace.is_empty() { format!("/{name}") } else { format!("/{}/{name}", self.namespace) }
    }

    /// Checks the section: a namespace of ROS name tokens, a positive arrow scale.
    pub(super) fn validate(&self) -> Result<(), ConfigError> {
        let ns = &self.namespace;
        let token_ok = |t: &str| {
            t.chars().next().is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
                && t.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
        };
        if !ns.is_empty() && !ns.split('/').all(token_ok) {
            return Err(ConfigError::invalid(
                "ros2.namespace",
                format!("{ns:?}"),
                "must be empty or ROS name tokens (letters, digits, `_`; not starting with a digit) \
                 separated by `/`, without a leading or trailing `/`, e.g. \"snake\" or \"lab/snake_1\"",
            ));
        }
        let scale = self.contact_arrow_m_per_n;
        if !(scale.is_finite() && scale > 0.0) {
            return Err(ConfigError::invalid(
                "ros2.contact_arrow_m_per_n",
                scale,
                "must be a finite number greater than 0 (metres of arrow per newton)",
            ));
        }
        Ok(())
    }
}
