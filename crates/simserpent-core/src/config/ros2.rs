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
    /// The live bridge (`simserpent run --ros2`, cargo feature `ros2`): DDS domain id
    /// (`ROS_DOMAIN_ID`), 0 ..= 232.
    pub domain_id: u16,
    /// The live bridge: IP addresses of the local network interfaces DDS may use and announce
    /// (`["127.0.0.1"]`: this machine only); empty = every interface.
    pub interfaces: Vec<String>,
    /// Free-running clock: how often the state topics are published (Hz of simulated time).
    /// In lockstep they are published at every command instant instead.
    pub publish_rate_hz: f64,
    /// QoS of every topic: `"reliable"` or `"best_effort"`.
    pub reliability: Ros2Reliability,
    /// QoS of every topic: `"volatile"` or `"transient_local"`.
    pub durability: Ros2Durability,
    /// QoS of every topic: history depth (keep last n samples), >= 1.
    pub history_depth: u32,
    /// `"free"`: the simulation runs at `real_time_factor` and applies the latest command;
    /// `"lockstep"`: it publishes the state and `/clock`, then waits for the next command.
    pub clock: Ros2Clock,
    /// Free clock: simulated seconds per wall-clock second (1 = real time); 0 = as fast as
    /// possible.
    pub real_time_factor: f64,
    /// Lockstep: simulation steps per command (each command acts for this many steps), >= 1.
    pub steps_per_command: u64,
    /// Lockstep: how long to wait for a command (wall-clock seconds, > 0) before the run stops
    /// (manifest `incomplete`, the reason in `error`). The first wait also covers discovery.
    pub lockstep_timeout_secs: f64,
}

/// `ros2.reliability`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Ros2Reliability {
    /// Lost samples are sent again (ROS 2's default).
    Reliable,
    /// Lost samples stay lost (sensor-data QoS).
    BestEffort,
}

/// `ros2.durability`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Ros2Durability {
    /// A late subscriber gets only new samples (ROS 2's default).
    Volatile,
    /// A late subscriber gets the last `history_depth` samples.
    TransientLocal,
}

/// `ros2.clock`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Ros2Clock {
    /// Paced by the wall clock at `real_time_factor`; commands are applied when they arrive.
    Free,
    /// Waits for a command every `steps_per_command` steps (deterministic closed loops).
    Lockstep,
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
        if self.domain_id > 232 {
            return Err(ConfigError::invalid(
                "ros2.domain_id",
                self.domain_id,
                "must be 0 ..= 232 (DDS domain ids whose UDP ports exist; ROS 2 recommends 0 ..= 101)",
            ));
        }
        if let Some(bad) = self.interfaces.iter().find(|a| a.parse::<std::net::IpAddr>().is_err()) {
            return Err(ConfigError::invalid(
                "ros2.interfaces",
                format!("{bad:?}"),
                "must be IP addresses of this machine's interfaces, e.g. [\"127.0.0.1\"] (loopback only), or [] \
                 for every interface",
            ));
        }
        let rate = self.publish_rate_hz;
        if !(rate.is_finite() && rate > 0.0) {
            return Err(ConfigError::invalid(
                "ros2.publish_rate_hz",
                rate,
                "must be a finite number greater than 0 (Hz of simulated time; above 1/timestep = every step)",
            ));
        }
        if self.history_depth == 0 {
            return Err(ConfigError::invalid("ros2.history_depth", 0, "must be at least 1 (samples kept per topic)"));
        }
        let rtf = self.real_time_factor;
        if !(rtf.is_finite() && rtf >= 0.0) {
            return Err(ConfigError::invalid(
                "ros2.real_time_factor",
                rtf,
                "must be a finite number >= 0 (1 = real time, 0 = as fast as possible)",
            ));
        }
        if self.steps_per_command == 0 {
            return Err(ConfigError::invalid(
                "ros2.steps_per_command",
                0,
                "must be at least 1 (simulation steps per lockstep command)",
            ));
        }
        let timeout = self.lockstep_timeout_secs;
        if !(timeout.is_finite() && timeout > 0.0) {
            return Err(ConfigError::invalid(
                "ros2.lockstep_timeout_secs",
                timeout,
                "must be a finite number of seconds greater than 0",
            ));
        }
        Ok(())
    }
}
