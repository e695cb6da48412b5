//! ROS 2: the run's data as ROS 2 messages. [`bag`] writes them into an MCAP bag file
//! (`recording.format` with `"mcap"`); [`msgs`] holds the message types, their CDR encoding and
//! their definitions; `live` (cargo feature `ros2`) is the live bridge of `run --ros2`, which
//! publishes them over DDS and takes joint commands ([`commands`]). Topics, types and frames:
//! user guide, "ROS 2" and the table in [`bag`].
//!
//! Conventions (REP 103/105): SI units; right-handed frames; the fixed frame is `world` (z up,
//! the MuJoCo world's axes); each link's frame `link_NN` is its MuJoCo body frame (x along the
//! snake's body towards the head for the generated snake, origin at the joint to its parent);
//! the head `link_00` is the robot's base. Quaternions are ROS's (x, y, z, w).

pub mod bag;
pub mod bag_file;
pub mod commands;
#[cfg(feature = "ros2")]
pub mod live;
pub mod msgs;

pub use bag::BagRecorder;
pub use bag_file::{RepairReport, repair_bag};
pub use commands::{CommandSource, Ros2Report};

/// Lockstep: until the first valid command has arrived, the state of the waiting instant is
/// published again after this many wall-clock seconds without an answer (and again after as
/// many more), so that a peer whose reader missed the first sample still gets one.
///
/// Why: the bridge learns that a peer subscribes to `/joint_states` when the peer's reader
/// announcement reaches it (RustDDS's `PublicationMatched`), but the peer accepts samples only
/// after *the bridge's* writer announcement has reached *it*, which travels separately (one
/// datagram with every writer, about 8 kB for a 10-link snake) and can arrive after the first
/// `/joint_states`. A volatile reader (ROS 2's default) drops a sample of a writer it does not
/// know yet and never asks for it again, and in lockstep both sides would then wait for each
/// other until `ros2.lockstep_timeout_secs`. Once the peer has answered, its reader is known
/// to hold the writer and every later sample is delivered reliably, so only the first wait
/// resends. A peer that answers slower than this would see the first instant twice.
pub const FIRST_STATE_RESEND_SECS: f64 = 0.25;

/// Errors of the live bridge.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Ros2Error {
    /// `--ros2` on a binary built without the `ros2` feature.
    #[error(
        "--ros2: this simserpent was built without the live ROS 2 bridge; build it with \
         `cargo build --release --features ros2` (user guide, \"ROS 2\")"
    )]
    NotBuilt,
    /// DDS could not be set up or a sample not be written.
    #[error("ROS 2 bridge: {what} failed: {message}")]
    Dds {
        /// What was being done.
        what: String,
        /// RustDDS's error.
        message: String,
    },
    /// Lockstep: nobody subscribed to `/joint_states` within `ros2.lockstep_timeout_secs`.
    #[error(
        "ROS 2 lockstep: no subscriber to /joint_states appeared within {waited_secs:.1} s \
         (ros2.lockstep_timeout_secs); is the peer running, on ROS_DOMAIN_ID = {domain_id} (ros2.domain_id)? The \
         run stopped before its first step"
    )]
    NoPeer {
        /// Wall-clock seconds waited.
        waited_secs: f64,
        /// The domain the bridge joined.
        domain_id: u16,
    },
    /// Lockstep: no valid command came within `ros2.lockstep_timeout_secs`.
    #[error(
        "ROS 2 lockstep: no valid command within {waited_secs:.1} s (ros2.lockstep_timeout_secs) at t = \
         {time_secs:.6} s (step {step}); the peer is gone or not running. The run stopped there; the tables hold \
         every row recorded up to then"
    )]
    PeerTimeout {
        /// Wall-clock seconds waited.
        waited_secs: f64,
        /// Simulated time reached.
        time_secs: f64,
        /// Steps taken.
        step: u64,
    },
}

/// The live bridge as the run sees it: an observer of the step loop with a report for the
/// manifest.
pub trait LiveBridge: crate::sim::Observer<Ros2Error> {
    /// The counts so far (commands accepted and rejected, why the run stopped).
    fn report(&self) -> Ros2Report;
}

/// Opens the live bridge for the robot of `index` (`run --ros2`): the observer and the
/// controller that applies the commands from ROS 2.
///
/// # Errors
/// [`Ros2Error::NotBuilt`] without the `ros2` feature; DDS set-up failures.
pub fn open_bridge(
    config: &crate::config::Config,
    index: &crate::sim::Index,
) -> Result<(Box<dyn LiveBridge>, CommandSource), Ros2Error> {
    #[cfg(feature = "ros2")]
    {
        let (bridge, source) = live::Bridge::open(config, index)?;
        Ok((Box::new(bridge), source))
    }
    #[cfg(not(feature = "ros2"))]
    {
        let _ = (config, index);
        Err(Ros2Error::NotBuilt)
    }
}
