//! A user's robot (`run --robot FILE`, MJCF or URDF) made ready for a run: its base made free
//! (`robot.floating_base`), its start pose (`robot.position_m`, `robot.rotation_deg`) and its
//! height (`robot.place_on_floor`), all written into the robot's MJCF, so that the `robot.xml`
//! in the run folder starts exactly where the run started.
//!
//! Why: MuJoCo's URDF importer welds the root link to the world (it fuses it into the world
//! body, mass included), so a URDF robot sat welded at z = 0, half inside the floor, with
//! kilonewtons of contact force and nowhere to go.

use crate::config::Config;
use mujoco_rs::prelude::*;
use mujoco_rs::wrappers::mj_editing::{MjtLimited, PositionConfig};
use mujoco_rs::wrappers::mj_model::MjtGeomBase;
use std::path::Path;

/// Whether `path` is a URDF file (MuJoCo decides by the root element; so do we, by the name
/// first and the text second).
fn is_urdf(path: &Path) -> bool {
    if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("urdf")) {
        return true;
    }
    std::fs::read_to_string(path).is_ok_and(|text| {
        let body = text.trim_start_matches('\u{feff}');
        // The first element that is not the XML declaration or a comment.
        let mut rest = body;
        loop {
            rest = rest.trim_start();
            if let Some(r) = rest.strip_prefix("<?") {
                rest = r.split_once("?>").map_or("", |(_, after)| after);
            } else if let Some(r) = rest.strip_prefix("<!--") {
                rest = r.split_once("-->").map_or("", |(_, after)| after);
            } else {
                return rest.starts_with("<robot");
            }
        }
    })
}

/// The robot of `robot` as MJCF text, with the `[robot]` keys applied: root bodies without a
/// joint get a free joint (`floating_base`), every root body is rotated and moved
/// (`rotation_deg`, `position_m`), and with `place_on_floor` the whole robot is moved
/// vertically so that its lowest colliding geom touches z = 0. `scratch` is a private folder
/// for MuJoCo's files. Returns the problem in words (the caller names the file).
pub(super) fn prepared_mjcf(config: &Config, robot: &Path, scratch: &Path) -> Result<String, String> {
    let r = &config.robot;
    let mut spec = MjSpec::from_xml(robot).map_err(|e| format!("MuJoCo cannot load the robot ({e})"))?;
    if is_urdf(robot) {
        // Keep the base link a body of its own (with its mass), so that it can float or be placed.
        spec.compiler_mut().set_fusestatic(false);
    }
    // The pose of each root body as compiled (whatever notation the file used for it).
    let compiled = spec.compile().map_err(|e| format!("MuJoCo cannot compile the robot ({e})"))?;
    let roots: Vec<usize> = (1..compiled.nbody() as usize).filter(|&b| compiled.body_parentid()[b] == 0).collect();
    let poses: Vec<([f64; 3], [f64; 4])> =
        roots.iter().map(|&b| (compiled.body_pos()[b], compiled.body_quat()[b])).collect();
    drop(compiled);
    let turn = crate::model::euler_xyz_deg_quat(r.rotation_deg);
    let mut n_roots = 0;
    for (body, (pos, quat)) in spec.world_body_mut().body_iter_mut().zip(&poses) {
        n_roots += 1;
        if r.floating_base && body.joint_iter(false).next().is_none() {
            body.add_free_joint();
        }
        let p = rotate(turn, *pos);
        *body.pos_mut() = [p[0] + r.position_m[0], p[1] + r.position_m[1], p[2] + r.position_m[2]];
        *body.quat_mut() = quat_mul(turn, *quat);
        body.alt_mut().switch_quat();
    }
    if n_roots != poses.len() {
        return Err(format!(
            "its root bodies could not be matched with the compiled model ({n_roots} in the file, {} compiled); \
             root bodies inside a <frame> are not supported with [robot] placement",
            poses.len()
        ));
    }
    if r.place_on_floor {
        let model = spec.compile().map_err(|e| format!("MuJoCo cannot compile the placed robot ({e})"))?;
        let lowest = lowest_colliding_point_m(&model)
            .ok_or("robot.place_on_floor = true, but the robot has no geom that collides with the floor")?;
        drop(model);
        for body in spec.world_body_mut().body_iter_mut() {
            body.pos_mut()[2] -= lowest;
        }
    }
    if r.position_servos {
        add_position_servos(config, &mut spec)?;
    }
    spec.compile().map_err(|e| format!("MuJoCo cannot compile the placed robot ({e})"))?;
    let path = scratch.join("robot_placed.xml");
    spec.save_xml(&path).map_err(|e| format!("cannot write the robot as MJCF ({e})"))?;
    std::fs::read_to_string(&path).map_err(|e| format!("cannot read back {} ({e})", path.display()))
}

/// The names of the hinge and slide joints of `model` that no actuator drives directly.
pub(super) fn unactuated_joints(model: &MjModel) -> Vec<String> {
    let mut driven = vec![false; model.njnt() as usize];
    for (id, t) in model.actuator_trnid().iter().zip(model.actuator_trntype()) {
        if matches!(t, MjtTrn::mjTRN_JOINT | MjtTrn::mjTRN_JOINTINPARENT)
            && let Some(d) = usize::try_from(id[0]).ok().and_then(|j| driven.get_mut(j))
        {
            *d = true;
        }
    }
    (0..model.njnt() as usize)
        .filter(|&j| matches!(model.jnt_type()[j], MjtJoint::mjJNT_HINGE | MjtJoint::mjJNT_SLIDE))
        .filter(|&j| !driven[j])
        .map(|j| model.id_to_name(MjtObjBase::mjOBJ_JOINT, j).unwrap_or_default().to_string())
        .collect()
}

/// `robot.position_servos`: a position servo (`<position>`, kp and kv of `[control]`, force
/// range `snake.torque_range_nm`) on every hinge and slide joint that no actuator drives.
fn add_position_servos(config: &Config, spec: &mut MjSpec) -> Result<(), String> {
    let model = spec.compile().map_err(|e| format!("MuJoCo cannot compile the robot ({e})"))?;
    let joints = unactuated_joints(&model);
    drop(model);
    if let Some(unnamed) = joints.iter().position(String::is_empty) {
        return Err(format!(
            "robot.position_servos = true needs a name on every joint it drives; joint {unnamed} has none"
        ));
    }
    let c = &config.control;
    for joint in &joints {
        let servo = spec.add_actuator().with_trntype(MjtTrn::mjTRN_JOINT);
        servo.set_target(joint);
        servo
            .set_to_position(PositionConfig {
                kp: c.position_kp_nm_per_rad,
                kv: Some(c.position_kv_nm_s_per_rad),
                ..PositionConfig::default()
            })
            .map_err(|e| format!("cannot give joint `{joint}` a position servo ({e})"))?;
        servo.set_forcelimited(MjtLimited::mjLIMITED_TRUE);
        *servo.forcerange_mut() = config.snake.torque_range_nm;
        servo
            .set_name(&format!("{joint}_position_servo"))
            .map_err(|e| format!("cannot name the position servo of joint `{joint}` ({e})"))?;
    }
    Ok(())
}

/// `q` applied to `v`.
fn rotate(q: [f64; 4], v: [f64; 3]) -> [f64; 3] {
    let p = quat_mul(quat_mul(q, [0.0, v[0], v[1], v[2]]), [q[0], -q[1], -q[2], -q[3]]);
    [p[1], p[2], p[3]]
}

fn quat_mul(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ]
}

/// The lowest point (world z, m) of the geoms of `model`'s bodies (not the world body's) that
/// collide with the floor (contype 2, conaffinity 1 in every generated scene), at the model's
/// reference pose; `None` when there are none. Exact for spheres, capsules, cylinders,
/// ellipsoids, boxes and meshes (their vertices); planes, heightfields and SDFs are skipped.
pub(super) fn lowest_colliding_point_m(model: &MjModel) -> Option<f64> {
    let mut data = MjData::new(model);
    data.forward();
    let (floor_contype, floor_conaffinity) = (2, 1);
    let mut lowest: Option<f64> = None;
    for g in 0..model.ngeom() as usize {
        let collides =
            (model.geom_contype()[g] & floor_conaffinity) != 0 || (model.geom_conaffinity()[g] & floor_contype) != 0;
        if model.geom_bodyid()[g] == 0 || !collides {
            continue;
        }
        let z = data.geom_xpos()[g][2];
        let m = data.geom_xmat()[g];
        // World z of the geom's local axes: the third row of its rotation matrix.
        let (ax, ay, az) = (m[6], m[7], m[8]);
        let s = model.geom_size()[g];
        let low = match model.geom_type()[g] {
            MjtGeomBase::mjGEOM_SPHERE => z - s[0],
            MjtGeomBase::mjGEOM_CAPSULE => z - az.abs() * s[1] - s[0],
            MjtGeomBase::mjGEOM_CYLINDER => z - az.abs() * s[1] - s[0] * (1.0 - az * az).max(0.0).sqrt(),
            MjtGeomBase::mjGEOM_ELLIPSOID => {
                z - ((ax * s[0]).powi(2) + (ay * s[1]).powi(2) + (az * s[2]).powi(2)).sqrt()
            }
            MjtGeomBase::mjGEOM_BOX => z - (ax.abs() * s[0] + ay.abs() * s[1] + az.abs() * s[2]),
            MjtGeomBase::mjGEOM_MESH => {
                let Ok(mesh) = usize::try_from(model.geom_dataid()[g]) else { continue };
                let start = model.mesh_vertadr()[mesh] as usize;
                let count = model.mesh_vertnum()[mesh] as usize;
                model.mesh_vert()[start..start + count]
                    .iter()
                    .map(|v| z + ax * f64::from(v[0]) + ay * f64::from(v[1]) + az * f64::from(v[2]))
                    .fold(f64::INFINITY, f64::min)
            }
            _ => continue,
        };
        lowest = Some(lowest.map_or(low, |l| l.min(low)));
    }
    lowest
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lowest_points_of_turned_shapes() {
        // A box turned 90° about x (its 0.3 half-height now along y, 0.2 along z), a capsule
        // tilted 30° from the vertical, and a sphere; bodies at known heights.
        let xml = r#"<mujoco><compiler angle="radian"/><worldbody>
            <body pos="0 0 1" euler="1.5707963267948966 0 0"><geom type="box" size="0.1 0.2 0.3"/></body>
            <body pos="1 0 2" euler="0.5235987755982988 0 0"><geom type="capsule" size="0.05 0.4"/></body>
            <body pos="2 0 0.5"><geom type="sphere" size="0.25"/></body>
            <body pos="3 0 -5"><geom type="sphere" size="0.1" contype="0" conaffinity="0"/></body>
        </worldbody></mujoco>"#;
        let model = MjModel::from_xml_string(xml).expect("model");
        let low = lowest_colliding_point_m(&model).expect("geoms");
        // Box: 1 − 0.2 (turned about x, its y half-size 0.2 points along z). Capsule:
        // 2 − cos 30°·0.4 − 0.05 = 1.6036. Sphere: 0.25. The non-colliding sphere is ignored.
        assert!((low - 0.25).abs() < 1e-12, "{low}");
        let one = MjModel::from_xml_string(
            r#"<mujoco><compiler angle="radian"/><worldbody><body pos="1 0 2" euler="0.5235987755982988 0 0"><geom type="capsule" size="0.05 0.4"/></body></worldbody></mujoco>"#,
        )
        .expect("model");
        let expected = 2.0 - 30f64.to_radians().cos() * 0.4 - 0.05;
        assert!((lowest_colliding_point_m(&one).expect("capsule") - expected).abs() < 1e-12);
        let turned_box = MjModel::from_xml_string(
            r#"<mujoco><compiler angle="radian"/><worldbody><body pos="0 0 1" euler="1.5707963267948966 0 0"><geom type="box" size="0.1 0.2 0.3"/></body></worldbody></mujoco>"#,
        )
        .expect("model");
        assert!((lowest_colliding_point_m(&turned_box).expect("box") - 0.8).abs() < 1e-12);
    }

    #[test]
    fn urdf_is_recognised_by_name_or_root() {
        let dir = tempfile::tempdir().expect("folder");
        let p = dir.path().join("robot.xml");
        std::fs::write(&p, "<?xml version=\"1.0\"?>\n<!-- a robot -->\n<robot name=\"r\"/>").expect("write");
        assert!(is_urdf(&p));
        std::fs::write(&p, "<mujoco/>").expect("write");
        assert!(!is_urdf(&p));
        assert!(is_urdf(Path::new("x.URDF")));
    }
}
