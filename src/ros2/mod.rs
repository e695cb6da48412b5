//! ROS 2: the run's data as ROS 2 messages. [`bag`] writes them into an MCAP bag file
//! (`recording.format` with `"mcap"`); [`msgs`] holds the message types, their CDR encoding and
//! their definitions. Topics, types and frames: README "ROS 2" and the table in [`bag`].
//!
//! Conventions (REP 103/105): SI units; right-handed frames; the fixed frame is `world` (z up,
//! the MuJoCo world's axes); each link's frame `link_NN` is its MuJoCo body frame (x along the
//! snake's body towards the head for the generated snake, origin at the joint to its parent);
//! the head `link_00` is the robot's base. Quaternions are ROS's (x, y, z, w).

pub mod bag;
pub mod msgs;

pub use bag::BagRecorder;
