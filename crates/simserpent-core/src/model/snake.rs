//! MJCF text of the snake itself: the body chain, its actuators, its sensors and the keyframe.
//!
//! Layout (see [`super`] for the conventions and [`super::names`] for the names):
//! - body `link_00` at the head tip, with `euler` = head rotation and the free joint `head_free`;
//!   body `link_i` (i > 0) inside `link_{i-1}` at `(−L, 0, 0)`, with the hinge `joint_i` at its
//!   origin;
//! - each link: geom `link_ii_geom` spanning x ∈ [−L, 0] exactly (caps included), site
//!   `link_ii_imu` at `(−L/2, 0, 0)`, and for i > 0 site `joint_ii_site` at the origin;
//! - actuators: all `torque_jj` motors, then all `position_jj`, `velocity_jj`, `intvelocity_jj`
//!   servos (thesis ordering); only the kind equal to `control.method` has non-zero gains;
//! - sensors: per link vel, acc, gyro, pos, quat; then per joint force, torque, angle, angvel.

use std::fmt::{self, Write};

use super::names::{self, SensorKind};
use super::{Nums, fmt_num as n};
use crate::config::{Config, ControlMethod, LegacyGeometry};

/// Below this core length (L − 2r, m) a capsule is written with explicit `pos`/`zaxis`/`size`
/// instead of `fromto`: MuJoCo rejects `fromto` points closer than about 3e-8 m.
const MIN_FROMTO_CORE_M: f64 = 1e-6;

/// Contact bit masks: links have contype 1; floor and obstacles contype 2 and conaffinity 1.
/// Link conaffinity is 3 (floor/obstacles and other links) or 2 (floor/obstacles only).
pub(crate) const LINK_CONTYPE: u32 = 1;
/// Link conaffinity with self-collision.
pub(crate) const LINK_CONAFFINITY_SELF: u32 = 3;
/// Link conaffinity without self-collision.
pub(crate) const LINK_CONAFFINITY_NO_SELF: u32 = 2;
/// Contype of the floor and of obstacles.
pub(crate) const ENV_CONTYPE: u32 = 2;
/// Conaffinity of the floor and of obstacles.
pub(crate) const ENV_CONAFFINITY: u32 = 1;

/// MuJoCo contact dimensionality for a friction triple (sliding, torsional, rolling): 6 when the
/// rolling coefficient is positive, else 4 when the torsional one is positive, else 3.
pub(crate) fn condim(friction: [f64; 3]) -> u32 {
    if friction[2] > 0.0 {
        6
    } else if friction[1] > 0.0 {
        4
    } else {
        3
    }
}

fn indent(out: &mut String, depth: usize) {
    for _ in 0..depth {
        out.push_str("  ");
    }
}

/// Writes the link geom of one link: for `legacy.geometry = "no_overlap"` a capsule spanning
/// x ∈ [−L, 0] (a sphere when L = 2r); for `"faithful"` the original tool's capsule, core x ∈ [−L, 0]
/// (joint to joint) plus a cap of radius r beyond each joint.
fn write_link_geom(out: &mut String, cfg: &Config, i: usize) -> fmt::Result {
    let s = &cfg.snake;
    let (l, r) = (s.link_length_m, s.link_radius_m);
    let shape = if cfg.legacy.geometry == LegacyGeometry::Faithful {
        if l < MIN_FROMTO_CORE_M {
            format!("type=\"capsule\" pos=\"{} 0 0\" zaxis=\"1 0 0\" size=\"{} {}\"", n(-l / 2.0), n(r), n(l / 2.0))
        } else {
            format!("type=\"capsule\" fromto=\"0 0 0 {} 0 0\" size=\"{}\"", n(-l), n(r))
        }
    } else if l - 2.0 * r <= 0.0 {
        format!("type=\"sphere\" pos=\"{} 0 0\" size=\"{}\"", n(-l / 2.0), n(r))
    } else if l - 2.0 * r < MIN_FROMTO_CORE_M {
        format!("type=\"capsule\" pos=\"{} 0 0\" zaxis=\"1 0 0\" size=\"{} {}\"", n(-l / 2.0), n(r), n(l / 2.0 - r))
    } else {
        format!("type=\"capsule\" fromto=\"{} 0 0 {} 0 0\" size=\"{}\"", n(-r), n(-(l - r)), n(r))
    };
    let conaffinity = if cfg.physics.self_collision { LINK_CONAFFINITY_SELF } else { LINK_CONAFFINITY_NO_SELF };
    write!(
        out,
        "<geom name=\"{}\" {shape} mass=\"{}\" rgba=\"{}\" contype=\"{LINK_CONTYPE}\" conaffinity=\"{conaffinity}\" \
         priority=\"0\" friction=\"{}\" condim=\"{}\"/>",
        names::link_geom(i),
        n(s.link_mass_kg),
        Nums(&s.color_rgba),
        Nums(&s.link_friction),
        condim(s.link_friction),
    )
}

/// Writes the body chain (inside `<worldbody>`), starting at indentation `depth`.
pub(crate) fn write_bodies(out: &mut String, cfg: &Config, depth: usize) -> fmt::Result {
    let s = &cfg.snake;
    let (l, r) = (s.link_length_m, s.link_radius_m);
    let range = cfg.joint_range_rad();
    let tip = super::geometry::head_tip(cfg);
    let euler = super::geometry::head_rotation_rad(cfg);
    for i in 0..s.n_links {
        let d = depth + i;
        indent(out, d);
        if i == 0 {
            writeln!(out, "<body name=\"{}\" pos=\"{}\" euler=\"{}\">", names::link_body(0), Nums(&tip), Nums(&euler))?;
            indent(out, d + 1);
            writeln!(out, "<freejoint name=\"{}\"/>", names::HEAD_FREE_JOINT)?;
        } else {
            writeln!(out, "<body name=\"{}\" pos=\"{} 0 0\">", names::link_body(i), n(-l))?;
            let axis = match super::geometry::joint_axis_index(s.joint_axes, i) {
                1 => "0 1 0",
                _ => "0 0 1",
            };
            indent(out, d + 1);
            writeln!(
                out,
                "<joint name=\"{}\" type=\"hinge\" pos=\"0 0 0\" axis=\"{axis}\" range=\"{} {}\" damping=\"{}\" \
                 armature=\"{}\"/>",
                names::joint(i),
                n(-range),
                n(range),
                n(s.joint_damping_nm_s_per_rad),
                n(s.joint_armature_kg_m2),
            )?;
        }
        indent(out, d + 1);
        write_link_geom(out, cfg, i)?;
        out.push('\n');
        indent(out, d + 1);
        writeln!(out, "<site name=\"{}\" pos=\"{} 0 0\" size=\"{}\"/>", names::link_site(i), n(-l / 2.0), n(r / 4.0))?;
        if i > 0 {
            indent(out, d + 1);
            writeln!(out, "<site name=\"{}\" pos=\"0 0 0\" size=\"{}\"/>", names::joint_site(i), n(r / 5.0))?;
        }
    }
    for i in (0..s.n_links).rev() {
        indent(out, depth + i);
        out.push_str("</body>\n");
    }
    Ok(())
}

/// Writes the `<actuator>` section (nothing when the snake has no joints).
pub(crate) fn write_actuators(out: &mut String, cfg: &Config) -> fmt::Result {
    let nj = cfg.snake.n_joints();
    if nj == 0 {
        return Ok(());
    }
    let c = &cfg.control;
    let [t_lo, t_hi] = cfg.snake.torque_range_nm;
    let range = cfg.joint_range_rad();
    let gear = c.torque_gear;
    // The motor's force (= ctrl) is multiplied by the gear on its way to the joint: limit it to
    // torque_range / gear, so that the joint torque is limited to torque_range for any gear.
    let (g_lo, g_hi) = (t_lo / gear, t_hi / gear);
    let (g_lo, g_hi) = (g_lo.min(g_hi), g_lo.max(g_hi));
    let gain = |kind: ControlMethod, value: f64| if c.method == kind { value } else { 0.0 };
    out.push_str("  <actuator>\n");
    for j in 1..=nj {
        writeln!(
            out,
            "    <motor name=\"{}\" joint=\"{}\" gear=\"{}\" ctrlrange=\"{} {}\" forcelimited=\"true\" \
             forcerange=\"{} {}\"/>",
            names::actuator(ControlMethod::Torque, j),
            names::joint(j),
            n(gear),
            n(g_lo),
            n(g_hi),
            n(g_lo),
            n(g_hi),
        )?;
    }
    for j in 1..=nj {
        writeln!(
            out,
            "    <position name=\"{}\" joint=\"{}\" kp=\"{}\" kv=\"{}\" ctrlrange=\"{} {}\" forcelimited=\"true\" \
             forcerange=\"{} {}\"/>",
            names::actuator(ControlMethod::Position, j),
            names::joint(j),
            n(gain(ControlMethod::Position, c.position_kp_nm_per_rad)),
            n(gain(ControlMethod::Position, c.position_kv_nm_s_per_rad)),
            n(-range),
            n(range),
            n(t_lo),
            n(t_hi),
        )?;
    }
    for j in 1..=nj {
        writeln!(
            out,
            "    <velocity name=\"{}\" joint=\"{}\" kv=\"{}\" forcelimited=\"true\" forcerange=\"{} {}\"/>",
            names::actuator(ControlMethod::Velocity, j),
            names::joint(j),
            n(gain(ControlMethod::Velocity, c.velocity_kv_nm_s_per_rad)),
            n(t_lo),
            n(t_hi),
        )?;
    }
    for j in 1..=nj {
        writeln!(
            out,
            "    <intvelocity name=\"{}\" joint=\"{}\" kp=\"{}\" actrange=\"{} {}\" forcelimited=\"true\" \
             forcerange=\"{} {}\"/>",
            names::actuator(ControlMethod::Intvelocity, j),
            names::joint(j),
            n(gain(ControlMethod::Intvelocity, c.intvelocity_kp_nm_per_rad)),
            n(-range),
            n(range),
            n(t_lo),
            n(t_hi),
        )?;
    }
    out.push_str("  </actuator>\n");
    Ok(())
}

/// Writes the `<sensor>` section.
pub(crate) fn write_sensors(out: &mut String, cfg: &Config) -> fmt::Result {
    out.push_str("  <sensor>\n");
    for i in 0..cfg.snake.n_links {
        let site = names::link_site(i);
        for kind in SensorKind::LINK {
            let target = match kind {
                SensorKind::LinkPosition | SensorKind::LinkQuat => {
                    format!("objtype=\"site\" objname=\"{site}\"")
                }
                _ => format!("site=\"{site}\""),
            };
            writeln!(out, "    <{} name=\"{}\" {target}/>", kind.mjcf_element(), names::sensor(kind, i))?;
        }
    }
    for j in 1..=cfg.snake.n_joints() {
        for kind in SensorKind::JOINT {
            let target = match kind {
                SensorKind::JointForce | SensorKind::JointTorque => {
                    format!("site=\"{}\"", names::joint_site(j))
                }
                _ => format!("joint=\"{}\"", names::joint(j)),
            };
            writeln!(out, "    <{} name=\"{}\" {target}/>", kind.mjcf_element(), names::sensor(kind, j))?;
        }
    }
    out.push_str("  </sensor>\n");
    Ok(())
}

/// Writes the `<keyframe>` section: key `initial` with the head pose and the initial joint
/// angles in `qpos`; `ctrl` holds the initial angles as position-servo set-points (zero for the
/// other kinds) and `act` the initial angles as the integrated set-points of the intvelocity
/// servos, so that the starting pose is also the servos' rest pose.
pub(crate) fn write_keyframe(out: &mut String, cfg: &Config, angles: &[f64]) -> fmt::Result {
    let tip = super::geometry::head_tip(cfg);
    let quat = super::geometry::euler_xyz_quat(super::geometry::head_rotation_rad(cfg));
    let mut qpos: Vec<f64> = tip.to_vec();
    qpos.extend_from_slice(&quat);
    qpos.extend_from_slice(angles);
    write!(out, "  <keyframe>\n    <key name=\"{}\" qpos=\"{}\"", names::INITIAL_KEYFRAME, Nums(&qpos))?;
    // `[initial_state]` velocities: the free joint's qvel is the linear velocity of the head's
    // frame origin in the world frame and the angular velocity in the head's own frame.
    let init = &cfg.initial_state;
    if init.linear_velocity_m_per_s != [0.0; 3] || init.angular_velocity_rad_per_s != [0.0; 3] {
        let r = super::geometry::euler_xyz_matrix(super::geometry::head_rotation_rad(cfg));
        let w = init.angular_velocity_rad_per_s;
        // Rᵀ·ω: world to head frame.
        let local = [0, 1, 2].map(|k| r[0][k] * w[0] + r[1][k] * w[1] + r[2][k] * w[2]);
        let mut qvel: Vec<f64> = init.linear_velocity_m_per_s.to_vec();
        qvel.extend_from_slice(&local);
        qvel.resize(6 + angles.len(), 0.0);
        write!(out, " qvel=\"{}\"", Nums(&qvel))?;
    }
    if !angles.is_empty() {
        let nj = angles.len();
        let mut ctrl = vec![0.0; 4 * nj];
        ctrl[nj..2 * nj].copy_from_slice(angles);
        write!(out, " ctrl=\"{}\" act=\"{}\"", Nums(&ctrl), Nums(angles))?;
    }
    out.push_str("/>\n  </keyframe>\n");
    Ok(())
}
