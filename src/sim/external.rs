//! External forces on links (`[[physics.external_forces]]`): before every step, each force's
//! magnitude at the step's start time along its unit direction, at its link's centre of mass,
//! into MuJoCo's `qfrc_applied` (through `mj_applyFT`, at the state's kinematics), held over the
//! step. Body ids and unit directions are resolved once; no allocation per step.

use super::{SimError, World};
use crate::config::{Config, ExternalForce};

/// Checks that every `[[physics.external_forces]]` names a link of a user's robot (`--robot`,
/// whose links are its bodies, not `snake.n_links`): a force on a link the robot does not have is
/// refused, never dropped.
///
/// # Errors
/// [`SimError::Config`] naming the key, the link and the robot's links.
pub fn check_robot_links(config: &Config, links: &[String], robot: &str) -> Result<(), SimError> {
    use crate::config::shorten;
    for (i, f) in config.physics.external_forces.iter().enumerate() {
        if f.link >= links.len() {
            let names = links.iter().take(8).map(|n| shorten(n).into_owned()).collect::<Vec<_>>().join(", ");
            let more = if links.len() > 8 { format!(", … {} more", links.len() - 8) } else { String::new() };
            return Err(SimError::Config(crate::config::ConfigError::InvalidValue {
                key: format!("physics.external_forces[{i}].link"),
                value: f.link.to_string(),
                allowed: format!(
                    "must be a link index of the robot {}: 0 to {} (its {} links in file order: {names}{more})",
                    shorten(robot),
                    links.len().saturating_sub(1),
                    links.len()
                ),
            }));
        }
    }
    Ok(())
}

/// The configured external forces of a run, resolved for its world.
#[derive(Debug, Clone)]
pub struct ExternalForces {
    /// Each force with its link's body id and its unit direction.
    forces: Vec<(ExternalForce, usize, [f64; 3])>,
    /// Generalized forces of the current step (scratch, one entry per degree of freedom).
    qfrc: Vec<f64>,
}

impl ExternalForces {
    /// The forces of `config` for `world` (links resolved to bodies).
    pub fn new(config: &Config, world: &World) -> Self {
        let forces = config
            .physics
            .external_forces
            .iter()
            .filter_map(|f| {
                let body = world.index.links.get(f.link)?.body;
                let d = f.direction;
                let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                Some((f.clone(), body, d.map(|x| x / len)))
            })
            .collect();
        Self { forces, qfrc: vec![0.0; world.data.qfrc_applied().len()] }
    }

    /// The forces at the world's current time into `qfrc_applied` (written every step, zero
    /// while none acts, so a reset or a restored state never keeps a stale force), and each
    /// link's force (N, world frame, at its centre of mass) into `link_forces_n` when given
    /// (indexed by link; links without a force get zero). Does nothing without configured forces.
    pub fn before_step(&mut self, world: &mut World, mut link_forces_n: Option<&mut [[f64; 3]]>) {
        if self.forces.is_empty() {
            return;
        }
        let t = world.time_secs();
        let any = self.forces.iter().any(|(f, _, _)| f.magnitude_n(t) > 0.0);
        self.qfrc.fill(0.0);
        if let Some(out) = link_forces_n.as_deref_mut() {
            out.fill([0.0; 3]);
        }
        if any {
            // The kinematics and centre-of-mass positions of the state itself (mj_applyFT's
            // Jacobian needs them).
            world.data.kinematics();
            world.data.com_pos();
            for (f, body, dir) in &self.forces {
                let size = f.magnitude_n(t);
                if size > 0.0 {
                    let point = world.data.xipos()[*body];
                    let force = dir.map(|x| x * size);
                    // The body id comes from the world's own index: always in range.
                    let _ = world.data.apply_ft(&force, &[0.0; 3], &point, *body, &mut self.qfrc);
                    if let Some(o) = link_forces_n.as_deref_mut().and_then(|out| out.get_mut(f.link)) {
                        *o = [o[0] + force[0], o[1] + force[1], o[2] + force[2]];
                    }
                }
            }
        }
        world.data.qfrc_applied_mut().copy_from_slice(&self.qfrc);
    }
}
