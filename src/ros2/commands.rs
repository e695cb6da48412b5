//! Joint commands from ROS 2 (the live bridge, `run --ros2`): the messages of ros2_control's
//! forward command controllers and joint trajectory controller, their checks, and the
//! controller that holds the last valid command.
//!
//! Pure logic without DDS (so it is tested without a network): the bridge ([`super::live`])
//! takes the messages off the wire and hands them to a [`CommandGate`], which checks them
//! against the robot's joints and `control.method`; a valid command replaces the held one in
//! [`Held`], an invalid one is counted by reason, logged (at most one warning per reason per
//! second of wall-clock time) and dropped — the last valid command holds. The
//! [`CommandSource`] is the run's [`Controller`]: it writes the held command (or the held
//! trajectory, interpolated at the instant's simulated time) into the step's command.

use crate::config::ControlMethod;
use crate::control::{Command, Controller, Observation};
use serde::{Deserialize, Serialize};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Instant;

/// `builtin_interfaces/Time` and `Duration`, owned (for reading).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub struct TimeMsg {
    pub sec: i32,
    pub nanosec: u32,
}

impl TimeMsg {
    /// Seconds.
    pub fn secs(&self) -> f64 {
        f64::from(self.sec) + f64::from(self.nanosec) * 1e-9
    }
}

/// `std_msgs/Header`, owned.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct HeaderMsg {
    pub stamp: TimeMsg,
    pub frame_id: String,
}

/// `std_msgs/MultiArrayDimension`, owned.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct DimensionMsg {
    pub label: String,
    pub size: u32,
    pub stride: u32,
}

/// `std_msgs/MultiArrayLayout`, owned.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct LayoutMsg {
    pub dim: Vec<DimensionMsg>,
    pub data_offset: u32,
}

/// `std_msgs/Float64MultiArray`, owned: a forward command controller's command, one value per
/// joint in the robot's joint order (`joint_01`, `joint_02`, …, as in `/joint_states`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct Float64MultiArrayMsg {
    pub layout: LayoutMsg,
    pub data: Vec<f64>,
}

/// `trajectory_msgs/JointTrajectoryPoint`, owned.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct JointTrajectoryPointMsg {
    pub positions: Vec<f64>,
    pub velocities: Vec<f64>,
    pub accelerations: Vec<f64>,
    pub effort: Vec<f64>,
    pub time_from_start: TimeMsg,
}

/// `trajectory_msgs/JointTrajectory`, owned.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct JointTrajectoryMsg {
    pub header: HeaderMsg,
    pub joint_names: Vec<String>,
    pub points: Vec<JointTrajectoryPointMsg>,
}

/// Which command topic a message came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Interface {
    /// `forward_position_controller/commands`.
    Position,
    /// `forward_velocity_controller/commands`.
    Velocity,
    /// `forward_effort_controller/commands`.
    Effort,
}

impl Interface {
    /// The interface that drives the actuators of `method`.
    pub fn of(method: ControlMethod) -> Self {
        match method {
            ControlMethod::Position => Self::Position,
            ControlMethod::Velocity | ControlMethod::Intvelocity => Self::Velocity,
            ControlMethod::Torque => Self::Effort,
        }
    }

    fn name(self) -> &'static str {
        match self {
            Self::Position => "position",
            Self::Velocity => "velocity",
            Self::Effort => "effort",
        }
    }
}

/// Why a command was rejected (the manifest counts each).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Rejection {
    /// A Float64MultiArray without exactly one value per joint (or a trajectory point without
    /// one per named joint).
    WrongLength,
    /// NaN or ±inf in a value.
    NotFinite,
    /// A JointTrajectory naming a joint the robot does not have (or one joint twice).
    UnknownJoint,
    /// A command on another interface than `control.method`'s (say, velocities to a snake
    /// under position control).
    WrongInterface,
    /// A JointTrajectory without points, with times that do not increase, or without the
    /// values `control.method` needs.
    BadTrajectory,
    /// A sample DDS could not decode (not the topic's type).
    Undecodable,
}

const REJECTIONS: usize = 6;

impl Rejection {
    fn index(self) -> usize {
        self as usize
    }
}

/// The counts of a live run, for the manifest (`ros2` in `manifest.json`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Ros2Report {
    /// `ros2.clock`: "free" or "lockstep".
    pub clock: String,
    /// DDS domain id.
    pub domain_id: u16,
    /// Valid commands applied.
    pub commands_accepted: u64,
    /// Rejected commands by reason (the last valid command held).
    pub rejected_wrong_length: u64,
    pub rejected_not_finite: u64,
    pub rejected_unknown_joint: u64,
    pub rejected_wrong_interface: u64,
    pub rejected_bad_trajectory: u64,
    pub rejected_undecodable: u64,
    /// Instants at which the state topics were published.
    pub published_instants: u64,
    /// Lockstep: commands waited for (and received).
    pub lockstep_commands: u64,
    /// Lockstep: how often the state of the first command instant was published again because
    /// no command answered it within [`crate::ros2::FIRST_STATE_RESEND_SECS`] (a peer's reader
    /// that matched the bridge's writer only after the first sample had been sent never gets
    /// that sample; user guide, "ROS 2", "Clock modes").
    #[serde(default)]
    pub lockstep_state_resends: u64,
    /// Lockstep: valid commands that answered a resent copy of the first state after the
    /// first answer had come (applied, counted in `commands_accepted`, but not as the answer
    /// to a later instant).
    #[serde(default)]
    pub lockstep_extra_answers: u64,
    /// Why the bridge stopped the run early (a lockstep peer that went silent), if it did.
    pub stopped: Option<String>,
}

/// A trajectory being followed: per point, the time from its start and the values of the
/// joints it names.
#[derive(Debug, Clone, Default)]
struct Trajectory {
    /// Simulated time of the trajectory's start (s).
    start_secs: f64,
    /// The robot's joint index of each named joint.
    joints: Vec<usize>,
    /// Time of each point from the start (s), increasing.
    times_secs: Vec<f64>,
    /// Values, point after point, `joints.len()` each.
    values: Vec<f64>,
    /// The held values of `joints` when the trajectory arrived (the start of the first segment).
    from: Vec<f64>,
}

/// The command shared between the bridge (which writes valid commands) and the
/// [`CommandSource`] (which applies them).
#[derive(Debug, Default)]
pub struct Held {
    /// One value per joint on `control.method`'s interface.
    values: Vec<f64>,
    trajectory: Option<Trajectory>,
}

impl Held {
    /// Sets `out` (one per joint) to the command at simulated time `time_secs`.
    fn write(&self, time_secs: f64, out: &mut [f64]) {
        out.copy_from_slice(&self.values);
        let Some(tr) = &self.trajectory else { return };
        let n = tr.joints.len();
        let tau = time_secs - tr.start_secs;
        let last = tr.times_secs.len() - 1;
        // The segment containing tau: from (t0, v0) to (t1, v1).
        let seg = tr.times_secs.iter().position(|&t| tau < t);
        for (c, &j) in tr.joints.iter().enumerate() {
            out[j] = match seg {
                None => tr.values[last * n + c],
                Some(0) => {
                    let t1 = tr.times_secs[0];
                    let f = if t1 > 0.0 { (tau / t1).clamp(0.0, 1.0) } else { 1.0 };
                    tr.from[c] + f * (tr.values[c] - tr.from[c])
                }
                Some(i) => {
                    let (t0, t1) = (tr.times_secs[i - 1], tr.times_secs[i]);
                    let (v0, v1) = (tr.values[(i - 1) * n + c], tr.values[i * n + c]);
                    v0 + (tau - t0) / (t1 - t0) * (v1 - v0)
                }
            };
        }
    }
}

/// Locks the shared command (a poisoned lock still holds a whole command: the writer only
/// replaces it after its checks).
fn lock(held: &Mutex<Held>) -> MutexGuard<'_, Held> {
    held.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// Checks incoming commands and stores the valid ones (see the module doc).
#[derive(Debug)]
pub struct CommandGate {
    held: Arc<Mutex<Held>>,
    joints: Vec<String>,
    interface: Interface,
    counts: [u64; REJECTIONS],
    accepted: u64,
    last_warning: [Option<Instant>; REJECTIONS],
    /// Scratch for a checked trajectory (reused).
    scratch: Trajectory,
}

impl CommandGate {
    /// A gate for a robot with `joints` under `method`, and the controller that applies its
    /// commands. Until the first valid command the held command is zero on every joint.
    pub fn new(joints: Vec<String>, method: ControlMethod) -> (Self, CommandSource) {
        let held = Arc::new(Mutex::new(Held { values: vec![0.0; joints.len()], trajectory: None }));
        let source = CommandSource { held: Arc::clone(&held), method };
        let gate = Self {
            held,
            joints,
            interface: Interface::of(method),
            counts: [0; REJECTIONS],
            accepted: 0,
            last_warning: [None; REJECTIONS],
            scratch: Trajectory::default(),
        };
        (gate, source)
    }

    /// A forward command controller's command on `interface`. `Ok` when it now holds.
    pub fn array(&mut self, interface: Interface, data: &[f64]) -> Result<(), Rejection> {
        let checked = if interface != self.interface {
            Err((
                Rejection::WrongInterface,
                format!(
                    "a {} command, but the snake takes {} commands (control.method); send to forward_{}_controller",
                    interface.name(),
                    self.interface.name(),
                    self.interface.name()
                ),
            ))
        } else if data.len() != self.joints.len() {
            Err((
                Rejection::WrongLength,
                format!("{} values, but the robot has {} joints (one value per joint)", data.len(), self.joints.len()),
            ))
        } else if let Some(i) = data.iter().position(|x| !x.is_finite()) {
            Err((Rejection::NotFinite, format!("value {i} ({}) is {}", self.joints[i], data[i])))
        } else {
            Ok(())
        };
        match checked {
            Ok(()) => {
                let mut held = lock(&self.held);
                held.values.copy_from_slice(data);
                held.trajectory = None;
                self.accepted += 1;
                Ok(())
            }
            Err((why, text)) => Err(self.reject(why, &text)),
        }
    }

    /// A joint trajectory, received at simulated time `now_secs`; a zero header stamp means
    /// "start now" (as in ros2_control). `Ok` when it now holds.
    pub fn trajectory(&mut self, msg: &JointTrajectoryMsg, now_secs: f64) -> Result<(), Rejection> {
        match self.check_trajectory(msg, now_secs) {
            Ok(()) => {
                let mut held = lock(&self.held);
                // The segment to the first point starts from what is applied now.
                let mut now = vec![0.0; self.joints.len()];
                held.write(now_secs, &mut now);
                held.values.copy_from_slice(&now);
                self.scratch.from.clear();
                self.scratch.from.extend(self.scratch.joints.iter().map(|&j| now[j]));
                let tr = held.trajectory.get_or_insert_with(Trajectory::default);
                tr.clone_from(&self.scratch);
                self.accepted += 1;
                Ok(())
            }
            Err((why, text)) => Err(self.reject(why, &text)),
        }
    }

    /// An undecodable sample.
    pub fn undecodable(&mut self, topic: &str, error: &str) {
        self.reject(Rejection::Undecodable, &format!("on {topic}: {error}"));
    }

    fn check_trajectory(&mut self, msg: &JointTrajectoryMsg, now_secs: f64) -> Result<(), (Rejection, String)> {
        let tr = &mut self.scratch;
        tr.joints.clear();
        for name in &msg.joint_names {
            match self.joints.iter().position(|j| j == name) {
                Some(j) if !tr.joints.contains(&j) => tr.joints.push(j),
                Some(_) => return Err((Rejection::UnknownJoint, format!("joint {name:?} named twice"))),
                None => {
                    return Err((
                        Rejection::UnknownJoint,
                        format!("unknown joint {name:?}; the robot's joints are {:?}", self.joints),
                    ));
                }
            }
        }
        if msg.points.is_empty() || tr.joints.is_empty() {
            return Err((Rejection::BadTrajectory, "no points or no joint names".to_string()));
        }
        tr.times_secs.clear();
        tr.values.clear();
        for (p, point) in msg.points.iter().enumerate() {
            let values = match self.interface {
                Interface::Position => &point.positions,
                Interface::Velocity => &point.velocities,
                Interface::Effort => &point.effort,
            };
            if values.len() != tr.joints.len() {
                let field = match self.interface {
                    Interface::Position => "positions",
                    Interface::Velocity => "velocities",
                    Interface::Effort => "effort",
                };
                let kind = if values.is_empty() { Rejection::BadTrajectory } else { Rejection::WrongLength };
                return Err((
                    kind,
                    format!(
                        "point {p} has {} {field} for {} joint names (control.method needs {field})",
                        values.len(),
                        tr.joints.len()
                    ),
                ));
            }
            if let Some(i) = values.iter().position(|x| !x.is_finite()) {
                return Err((Rejection::NotFinite, format!("point {p}, value {i} is {}", values[i])));
            }
            let t = point.time_from_start.secs();
            if tr.times_secs.last().is_some_and(|&last| t <= last) || t < 0.0 {
                return Err((
                    Rejection::BadTrajectory,
                    format!("point {p}: time_from_start {t} s does not increase (or is negative)"),
                ));
            }
            tr.times_secs.push(t);
            tr.values.extend_from_slice(values);
        }
        let stamp = msg.header.stamp.secs();
        tr.start_secs = if stamp > 0.0 { stamp } else { now_secs };
        Ok(())
    }

    /// Counts a rejection and logs it, at most once per reason per second.
    fn reject(&mut self, why: Rejection, text: &str) -> Rejection {
        let i = why.index();
        self.counts[i] += 1;
        let now = Instant::now();
        if self.last_warning[i].is_none_or(|t| now.duration_since(t).as_secs_f64() >= 1.0) {
            self.last_warning[i] = Some(now);
            log::warn!(
                "ROS 2 command rejected ({} so far for this reason), the last valid command holds: {text}",
                self.counts[i]
            );
        }
        why
    }

    /// Valid commands so far.
    pub fn accepted(&self) -> u64 {
        self.accepted
    }

    /// Rejected commands of one reason so far.
    pub fn rejected(&self, why: Rejection) -> u64 {
        self.counts[why.index()]
    }

    /// The counts into `report`.
    pub fn fill(&self, report: &mut Ros2Report) {
        report.commands_accepted = self.accepted;
        report.rejected_wrong_length = self.rejected(Rejection::WrongLength);
        report.rejected_not_finite = self.rejected(Rejection::NotFinite);
        report.rejected_unknown_joint = self.rejected(Rejection::UnknownJoint);
        report.rejected_wrong_interface = self.rejected(Rejection::WrongInterface);
        report.rejected_bad_trajectory = self.rejected(Rejection::BadTrajectory);
        report.rejected_undecodable = self.rejected(Rejection::Undecodable);
    }
}

/// The run's controller under `--ros2`: applies the last valid command from ROS 2 (zero until
/// the first), or the held trajectory at the instant's simulated time. Allocates nothing.
#[derive(Debug)]
pub struct CommandSource {
    held: Arc<Mutex<Held>>,
    method: ControlMethod,
}

impl Controller for CommandSource {
    fn update(&mut self, obs: &Observation, cmd: &mut Command) {
        let held = lock(&self.held);
        let out = match self.method {
            ControlMethod::Position => &mut cmd.position_rad,
            ControlMethod::Velocity => &mut cmd.velocity_rad_per_s,
            ControlMethod::Intvelocity => &mut cmd.intvelocity_rad_per_s,
            ControlMethod::Torque => &mut cmd.torque_nm,
        };
        held.write(obs.time_secs, out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gate() -> (CommandGate, CommandSource) {
        CommandGate::new(vec!["joint_01".into(), "joint_02".into(), "joint_03".into()], ControlMethod::Position)
    }

    fn applied(source: &mut CommandSource, t: f64) -> Vec<f64> {
        let mut obs = Observation::new(4, 3);
        obs.time_secs = t;
        let mut cmd = Command::new(3);
        source.update(&obs, &mut cmd);
        cmd.position_rad
    }

    #[test]
    fn bad_arrays_are_rejected_and_the_last_valid_command_holds() {
        let (mut g, mut s) = gate();
        assert_eq!(applied(&mut s, 0.0), [0.0; 3], "zero until the first command");
        assert_eq!(g.array(Interface::Position, &[0.1, 0.2, 0.3]), Ok(()));
        assert_eq!(g.array(Interface::Position, &[0.1, 0.2]), Err(Rejection::WrongLength));
        assert_eq!(g.array(Interface::Position, &[0.1, 0.2, 0.3, 0.4]), Err(Rejection::WrongLength));
        assert_eq!(g.array(Interface::Position, &[f64::NAN, 0.2, 0.3]), Err(Rejection::NotFinite));
        assert_eq!(g.array(Interface::Position, &[0.0, f64::INFINITY, 0.3]), Err(Rejection::NotFinite));
        assert_eq!(g.array(Interface::Velocity, &[0.0, 0.0, 0.0]), Err(Rejection::WrongInterface));
        g.undecodable("/snake/forward_position_controller/commands", "truncated CDR");
        assert_eq!(applied(&mut s, 1.0), [0.1, 0.2, 0.3], "no truncation, no partial update");
        let mut r = Ros2Report::default();
        g.fill(&mut r);
        assert_eq!(
            (
                r.commands_accepted,
                r.rejected_wrong_length,
                r.rejected_not_finite,
                r.rejected_wrong_interface,
                r.rejected_undecodable
            ),
            (1, 2, 2, 1, 1)
        );
    }

    fn point(positions: Vec<f64>, t: f64) -> JointTrajectoryPointMsg {
        JointTrajectoryPointMsg {
            positions,
            time_from_start: TimeMsg { sec: t.floor() as i32, nanosec: ((t - t.floor()) * 1e9).round() as u32 },
            ..Default::default()
        }
    }

    #[test]
    fn a_trajectory_is_interpolated_from_the_held_command() {
        let (mut g, mut s) = gate();
        g.array(Interface::Position, &[0.0, 1.0, 0.0]).expect("valid");
        let msg = JointTrajectoryMsg {
            header: HeaderMsg::default(),
            joint_names: vec!["joint_02".into(), "joint_03".into()],
            points: vec![point(vec![2.0, 1.0], 1.0), point(vec![4.0, -1.0], 2.0)],
        };
        g.trajectory(&msg, 10.0).expect("valid");
        let close = |a: &[f64], b: &[f64]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-12);
        assert!(close(&applied(&mut s, 10.0), &[0.0, 1.0, 0.0]));
        assert!(close(&applied(&mut s, 10.5), &[0.0, 1.5, 0.5]));
        assert!(close(&applied(&mut s, 11.5), &[0.0, 3.0, 0.0]));
        assert!(close(&applied(&mut s, 20.0), &[0.0, 4.0, -1.0]), "the last point holds");
    }

    #[test]
    fn bad_trajectories_are_rejected() {
        let (mut g, mut s) = gate();
        g.array(Interface::Position, &[0.3, 0.3, 0.3]).expect("valid");
        let good = JointTrajectoryMsg {
            header: HeaderMsg::default(),
            joint_names: vec!["joint_01".into()],
            points: vec![point(vec![1.0], 1.0)],
        };
        let mut unknown = good.clone();
        unknown.joint_names = vec!["joint_09".into()];
        assert_eq!(g.trajectory(&unknown, 0.0), Err(Rejection::UnknownJoint));
        let mut twice = good.clone();
        twice.joint_names = vec!["joint_01".into(), "joint_01".into()];
        twice.points[0].positions = vec![1.0, 1.0];
        assert_eq!(g.trajectory(&twice, 0.0), Err(Rejection::UnknownJoint));
        let mut short = good.clone();
        short.points[0].positions = vec![1.0, 2.0];
        assert_eq!(g.trajectory(&short, 0.0), Err(Rejection::WrongLength));
        let mut nan = good.clone();
        nan.points[0].positions = vec![f64::NAN];
        assert_eq!(g.trajectory(&nan, 0.0), Err(Rejection::NotFinite));
        let mut backwards = good.clone();
        backwards.points.push(point(vec![2.0], 0.5));
        assert_eq!(g.trajectory(&backwards, 0.0), Err(Rejection::BadTrajectory));
        let mut empty = good.clone();
        empty.points.clear();
        assert_eq!(g.trajectory(&empty, 0.0), Err(Rejection::BadTrajectory));
        assert_eq!(applied(&mut s, 5.0), [0.3, 0.3, 0.3], "the last valid command holds");
        assert_eq!(g.rejected(Rejection::UnknownJoint), 2);
        // A later valid array replaces the trajectory.
        g.trajectory(&good, 0.0).expect("valid");
        assert_eq!(applied(&mut s, 5.0), [1.0, 0.3, 0.3]);
        g.array(Interface::Position, &[0.0, 0.0, 0.0]).expect("valid");
        assert_eq!(applied(&mut s, 5.0), [0.0; 3]);
    }
}
