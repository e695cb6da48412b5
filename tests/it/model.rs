//! The generated MJCF, checked numerically against MuJoCo 3.17 (the only place MuJoCo meets
//! `simserpent::model`).

use crate::common::bare_floor;
use mujoco_rs::prelude::*;
use mujoco_rs::wrappers::mj_model::{MjtCone, MjtGeomBase, MjtJoint, MjtObjBase, MjtSensor};
use simserpent::config::{
    Config, ConfigError, ControlMethod, FloorFriction, FrictionCone, GaitKind, JointAxes, TerrainKind,
};
use simserpent::model::{self, GeneratedModel, ModelError, link_axis_segments_m, names};

const TOL: f64 = 1e-9;

fn load(xml: &str) -> MjModel {
    MjModel::from_xml_string(xml).unwrap_or_else(|e| panic!("MuJoCo rejected the model: {e}\n{xml}"))
}

fn gen_load(cfg: &Config) -> (GeneratedModel, MjModel) {
    let g = model::generate(cfg).unwrap();
    let m = load(&g.xml);
    (g, m)
}

fn id(m: &MjModel, t: MjtObjBase, name: &str) -> usize {
    m.name_to_id(t, name).unwrap_or_else(|| panic!("no {t:?} named {name}"))
}

/// Data reset to the `initial` keyframe, forward computed.
fn initial_data(m: &MjModel) -> MjData<&MjModel> {
    let mut d = MjData::new(m);
    d.reset_keyframe(id(m, MjtObjBase::mjOBJ_KEY, names::INITIAL_KEYFRAME)).unwrap();
    d.forward();
    d
}

fn assert_close(a: &[f64], b: &[f64], tol: f64, what: &str) {
    assert_eq!(a.len(), b.len(), "{what}: lengths");
    for (x, y) in a.iter().zip(b) {
        assert!((x - y).abs() <= tol, "{what}: {a:?} != {b:?}");
    }
}

/// Independent Rx(a)·Ry(b)·Rz(c) applied to v.
fn rotate(e_deg: [f64; 3], v: [f64; 3]) -> [f64; 3] {
    let [a, b, c] = e_deg.map(f64::to_radians);
    let rz = [c.cos() * v[0] - c.sin() * v[1], c.sin() * v[0] + c.cos() * v[1], v[2]];
    let ry = [b.cos() * rz[0] + b.sin() * rz[2], rz[1], -b.sin() * rz[0] + b.cos() * rz[2]];
    [ry[0], a.cos() * ry[1] - a.sin() * ry[2], a.sin() * ry[1] + a.cos() * ry[2]]
}

fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// xy-distance from p to segment [a, b].
fn dist_seg(p: [f64; 2], a: [f64; 3], b: [f64; 3]) -> f64 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let l2 = dx * dx + dy * dy;
    let t = if l2 > 0.0 { (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / l2).clamp(0.0, 1.0) } else { 0.0 };
    (p[0] - a[0] - t * dx).hypot(p[1] - a[1] - t * dy)
}

fn dist_body(p: [f64; 2], segs: &[[[f64; 3]; 2]]) -> f64 {
    segs.iter().map(|s| dist_seg(p, s[0], s[1])).fold(f64::INFINITY, f64::min)
}

fn config_error(r: Result<GeneratedModel, ModelError>) -> (String, String) {
    match r {
        Err(ModelError::Config(ConfigError::InvalidValue { key, allowed, .. })) => (key, allowed),
        Err(e) => panic!("unexpected error {e}"),
        Ok(_) => panic!("expected a config error"),
    }
}

/// Thesis table 5 (experiment I). The thesis' "link length" was the capsule's *half* length
/// (its MJCF used it as the capsule half-length, links 2 × value apart), so the full link length
/// here is twice the table value. Configuration C then has L = 2r exactly: sphere links.
/// Label, links, "link length" (half length), radius, head position, head rotation, colour.
type Row = (&'static str, usize, f64, f64, [f64; 3], [f64; 3], [f64; 4]);

fn experiment_one() -> Vec<(&'static str, Config)> {
    let rows: [Row; 3] = [
        ("A", 2, 0.8, 0.25, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.8, 1.0]),
        ("B", 5, 2.0, 0.5, [10.0, 5.0, 0.0], [0.0, 0.0, 180.0], [1.0, 0.0, 0.0, 1.0]),
        ("C", 15, 1.0, 1.0, [0.0, 0.0, 5.0], [180.0, 0.0, 0.0], [0.0, 1.0, 0.0, 1.0]),
    ];
    rows.into_iter()
        .map(|(name, n, half_len, r, pos, rot, rgba)| {
            let mut cfg = bare_floor();
            cfg.snake.n_links = n;
            cfg.snake.link_mass_kg = 0.3;
            cfg.snake.link_length_m = 2.0 * half_len;
            cfg.snake.link_radius_m = r;
            cfg.snake.head_position_m = pos;
            cfg.snake.head_rotation_deg = rot;
            cfg.snake.color_rgba = rgba;
            (name, cfg)
        })
        .collect()
}

#[test]
fn experiment_one_configurations_are_placed_exactly() {
    for (label, cfg) in experiment_one() {
        let (g, m) = gen_load(&cfg);
        let d = initial_data(&m);
        let s = &cfg.snake;
        let (n, l, r) = (s.n_links, s.link_length_m, s.link_radius_m);
        let tip = add(s.head_position_m, [0.0, 0.0, r]);
        let anchor = |i: usize| add(tip, rotate(s.head_rotation_deg, [-(i as f64) * l, 0.0, 0.0]));
        let centre = |i: usize| add(tip, rotate(s.head_rotation_deg, [-(i as f64 + 0.5) * l, 0.0, 0.0]));
        let axis = rotate(s.head_rotation_deg, [0.0, 0.0, 1.0]);
        let what = |x: &str| format!("config {label}: {x}");

        assert_eq!(m.ffi().nbody as usize, n + 1, "{}", what("bodies"));
        assert_eq!(m.ffi().njnt as usize, n, "{}", what("joints"));
        assert_eq!(g.initial_joint_angles_rad, vec![0.0; n - 1]);
        let segs = link_axis_segments_m(&cfg, &[]);
        let mut total = 0.0;
        assert_eq!(segs.len(), n);
        for (i, seg) in segs.iter().enumerate() {
            let b = id(&m, MjtObjBase::mjOBJ_BODY, &names::link_body(i));
            assert_close(&d.xpos()[b], &anchor(i), TOL, &what(&format!("link {i} position")));
            assert_close(&seg[0], &anchor(i), TOL, &what(&format!("segment {i} front")));
            assert_close(&seg[1], &anchor(i + 1), TOL, &what(&format!("segment {i} back")));
            let site = id(&m, MjtObjBase::mjOBJ_SITE, &names::link_site(i));
            assert_close(&d.site_xpos()[site], &centre(i), TOL, &what(&format!("imu site {i}")));
            let geom = id(&m, MjtObjBase::mjOBJ_GEOM, &names::link_geom(i));
            assert_eq!(m.geom_bodyid()[geom] as usize, b);
            assert_close(&d.geom_xpos()[geom], &centre(i), TOL, &what(&format!("geom {i} centre")));
            if l == 2.0 * r {
                assert_eq!(m.geom_type()[geom], MjtGeomBase::mjGEOM_SPHERE, "{}", what("sphere"));
                assert!((m.geom_size()[geom][0] - r).abs() <= TOL);
            } else {
                assert_eq!(m.geom_type()[geom], MjtGeomBase::mjGEOM_CAPSULE, "{}", what("capsule"));
                assert_close(&m.geom_size()[geom][..2], &[r, l / 2.0 - r], TOL, &what("capsule size"));
                // The capsule's axis (geom z) lies along the link's x axis.
                let gm = d.geom_xmat()[geom];
                let link_x = rotate(s.head_rotation_deg, [1.0, 0.0, 0.0]);
                let gz = [gm[2], gm[5], gm[8]];
                let dot = gz[0] * link_x[0] + gz[1] * link_x[1] + gz[2] * link_x[2];
                assert!((dot.abs() - 1.0).abs() <= TOL, "{}", what("capsule axis"));
            }
            let rgba: Vec<f64> = m.geom_rgba()[geom].iter().map(|&x| f64::from(x)).collect();
            assert_close(&rgba, &s.color_rgba, 1e-7, &what("rgba"));
            assert!((m.body_mass()[b] - s.link_mass_kg).abs() <= TOL, "{}", what("mass"));
            total += m.body_mass()[b];
            if i > 0 {
                let js = id(&m, MjtObjBase::mjOBJ_SITE, &names::joint_site(i));
                assert_close(&d.site_xpos()[js], &anchor(i), TOL, &what(&format!("joint site {i}")));
                let jid = id(&m, MjtObjBase::mjOBJ_JOINT, &names::joint(i));
                assert_eq!(m.jnt_type()[jid], MjtJoint::mjJNT_HINGE);
                assert_eq!(m.jnt_bodyid()[jid] as usize, b);
                assert_close(&d.xanchor()[jid], &anchor(i), TOL, &what(&format!("joint {i} anchor")));
                assert_close(&d.xaxis()[jid], &axis, TOL, &what(&format!("joint {i} axis")));
                let range = s.joint_range_deg.to_radians();
                assert_close(&m.jnt_range()[jid], &[-range, range], TOL, &what("joint range"));
            }
        }
        assert!((total - n as f64 * s.link_mass_kg).abs() <= TOL);
        let head = id(&m, MjtObjBase::mjOBJ_BODY, &names::link_body(0));
        assert!((m.body_subtreemass()[head] - n as f64 * s.link_mass_kg).abs() <= TOL);
        let free = id(&m, MjtObjBase::mjOBJ_JOINT, names::HEAD_FREE_JOINT);
        assert_eq!(m.jnt_type()[free], MjtJoint::mjJNT_FREE);
        if label == "C" {
            assert_close(&axis, &[0.0, 0.0, -1.0], TOL, "C is upside down");
        }

        check_actuators(&cfg, &m, label);
        check_sensors(&cfg, &m, label);

        // No start-up failure: a second of simulation stays finite and near the start.
        let mut d = initial_data(&m);
        for _ in 0..200 {
            d.step();
        }
        assert!(d.qpos().iter().all(|x| x.is_finite()), "{}", what("finite after steps"));
    }
}

fn check_actuators(cfg: &Config, m: &MjModel, label: &str) {
    let nj = cfg.snake.n_joints();
    assert_eq!(m.ffi().nu as usize, 4 * nj, "config {label}: actuators");
    let c = &cfg.control;
    let [lo, hi] = cfg.snake.torque_range_nm;
    let range = cfg.snake.joint_range_deg.to_radians();
    for (block, kind) in ControlMethod::ALL.into_iter().enumerate() {
        let on = c.method == kind;
        for j in 1..=nj {
            let a = id(m, MjtObjBase::mjOBJ_ACTUATOR, &names::actuator(kind, j));
            assert_eq!(a, block * nj + j - 1, "thesis ordering: blocks of kinds");
            assert_eq!(m.actuator_trnid()[a][0] as usize, id(m, MjtObjBase::mjOBJ_JOINT, &names::joint(j)));
            assert!(m.actuator_forcelimited()[a]);
            let gain = m.actuator_gainprm()[a][0];
            let bias = &m.actuator_biasprm()[a][..3];
            match kind {
                ControlMethod::Torque => {
                    let g = c.torque_gear;
                    assert_eq!(gain, 1.0);
                    assert_eq!(m.actuator_gear()[a][0], g);
                    assert_close(&m.actuator_ctrlrange()[a], &[lo / g, hi / g], TOL, "motor ctrlrange");
                    assert_close(&m.actuator_forcerange()[a], &[lo / g, hi / g], TOL, "motor forcerange");
                }
                ControlMethod::Position => {
                    let (kp, kv) = if on { (c.position_kp_nm_per_rad, c.position_kv_nm_s_per_rad) } else { (0.0, 0.0) };
                    assert_eq!(gain, kp, "config {label}: position kp");
                    assert_close(bias, &[0.0, -kp, -kv], 0.0, "position bias");
                    assert_close(&m.actuator_ctrlrange()[a], &[-range, range], TOL, "position ctrlrange");
                }
                ControlMethod::Velocity => {
                    let kv = if on { c.velocity_kv_nm_s_per_rad } else { 0.0 };
                    assert_eq!(gain, kv, "config {label}: velocity kv");
                    assert_close(bias, &[0.0, 0.0, -kv], 0.0, "velocity bias");
                }
                ControlMethod::Intvelocity => {
                    let kp = if on { c.intvelocity_kp_nm_per_rad } else { 0.0 };
                    assert_eq!(gain, kp, "config {label}: intvelocity kp");
                    assert_close(bias, &[0.0, -kp, 0.0], 0.0, "intvelocity bias");
                    assert_close(&m.actuator_actrange()[a], &[-range, range], TOL, "intvelocity actrange (rad)");
                }
            }
            if kind != ControlMethod::Torque {
                assert_close(&m.actuator_forcerange()[a], &[lo, hi], TOL, "servo forcerange");
            }
        }
    }
}

fn check_sensors(cfg: &Config, m: &MjModel, label: &str) {
    use names::SensorKind as K;
    let (n, nj) = (cfg.snake.n_links, cfg.snake.n_joints());
    assert_eq!(m.ffi().nsensor as usize, 5 * n + 4 * nj, "config {label}: sensors");
    let types = m.sensor_type();
    let count = |t: MjtSensor| types.iter().filter(|&&x| x == t).count();
    assert_eq!(count(MjtSensor::mjSENS_VELOCIMETER), n);
    assert_eq!(count(MjtSensor::mjSENS_ACCELEROMETER), n);
    assert_eq!(count(MjtSensor::mjSENS_GYRO), n);
    assert_eq!(count(MjtSensor::mjSENS_FRAMEPOS), n);
    assert_eq!(count(MjtSensor::mjSENS_FRAMEQUAT), n);
    assert_eq!(count(MjtSensor::mjSENS_FORCE), nj);
    assert_eq!(count(MjtSensor::mjSENS_TORQUE), nj);
    assert_eq!(count(MjtSensor::mjSENS_JOINTPOS), nj);
    assert_eq!(count(MjtSensor::mjSENS_JOINTVEL), nj);
    let mut expected_id = 0;
    for i in 0..n {
        let site = id(m, MjtObjBase::mjOBJ_SITE, &names::link_site(i));
        for kind in K::LINK {
            let s = id(m, MjtObjBase::mjOBJ_SENSOR, &names::sensor(kind, i));
            assert_eq!(s, expected_id, "sensor order");
            expected_id += 1;
            assert_eq!(m.sensor_objtype()[s], MjtObjBase::mjOBJ_SITE);
            assert_eq!(m.sensor_objid()[s] as usize, site, "{} on its site", names::sensor(kind, i));
            assert_eq!(m.sensor_dim()[s] as usize, kind.dim());
        }
    }
    for j in 1..=nj {
        let site = id(m, MjtObjBase::mjOBJ_SITE, &names::joint_site(j));
        let joint = id(m, MjtObjBase::mjOBJ_JOINT, &names::joint(j));
        for kind in K::JOINT {
            let s = id(m, MjtObjBase::mjOBJ_SENSOR, &names::sensor(kind, j));
            assert_eq!(s, expected_id, "sensor order");
            expected_id += 1;
            let (t, obj) = match kind {
                K::JointForce | K::JointTorque => (MjtObjBase::mjOBJ_SITE, site),
                _ => (MjtObjBase::mjOBJ_JOINT, joint),
            };
            assert_eq!(m.sensor_objtype()[s], t);
            assert_eq!(m.sensor_objid()[s] as usize, obj);
            assert_eq!(m.sensor_dim()[s] as usize, kind.dim());
        }
    }
    assert_eq!(names::link_velocimeter(1), names::sensor(K::LinkVelocity, 1));
    assert_eq!(names::joint_angvel(2), "joint_02_angvel");
}

#[test]
fn only_the_chosen_actuator_kind_has_gains_and_zero_gain_servos_give_zero_force() {
    for method in ControlMethod::ALL {
        let mut cfg = bare_floor();
        cfg.control.method = method;
        cfg.control.torque_gear = 2.0;
        let (_, m) = gen_load(&cfg);
        check_actuators(&cfg, &m, method.name());
        // Joints bent and moving, zero command: only the chosen kind may push.
        let mut d = initial_data(&m);
        let nj = cfg.snake.n_joints();
        for k in 0..nj {
            d.qpos_mut()[7 + k] = 0.3;
            d.qvel_mut()[6 + k] = 1.0;
        }
        d.forward();
        for (a, f) in d.actuator_force().iter().enumerate() {
            let kind = ControlMethod::ALL[a / nj];
            if kind != method {
                assert_eq!(*f, 0.0, "{method:?}: actuator {a} ({kind:?}) must not act");
            }
        }
    }
}

#[test]
fn motor_limits_joint_torque_to_torque_range_for_any_gear() {
    let mut cfg = bare_floor();
    cfg.control.method = ControlMethod::Torque;
    cfg.control.torque_gear = 0.5;
    let (_, m) = gen_load(&cfg);
    let mut d = initial_data(&m);
    let a = id(&m, MjtObjBase::mjOBJ_ACTUATOR, &names::actuator(ControlMethod::Torque, 1));
    d.ctrl_mut()[a] = 1e6; // clamped by ctrlrange
    d.forward();
    let dof = m.jnt_dofadr()[id(&m, MjtObjBase::mjOBJ_JOINT, &names::joint(1))] as usize;
    assert!((d.qfrc_actuator()[dof] - cfg.snake.torque_range_nm[1]).abs() <= TOL);
}

#[test]
fn round_trip_through_a_file_gives_the_same_model() {
    let mut cfg = bare_floor();
    cfg.terrain.kind = TerrainKind::CylinderPath;
    cfg.gait.kind = GaitKind::FormClosure;
    cfg.snake.head_rotation_deg = [0.0, 0.0, 33.0];
    let (g, a) = gen_load(&cfg);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("model.xml");
    std::fs::write(&path, &g.xml).unwrap();
    let b = MjModel::from_xml(&path).unwrap();
    let (fa, fb) = (a.ffi(), b.ffi());
    assert_eq!(
        (fa.nbody, fa.njnt, fa.ngeom, fa.nsite, fa.nu, fa.nsensor, fa.nkey, fa.nq),
        (fb.nbody, fb.njnt, fb.ngeom, fb.nsite, fb.nu, fb.nsensor, fb.nkey, fb.nq)
    );
    assert_eq!(a.body_pos(), b.body_pos());
    assert_eq!(a.body_quat(), b.body_quat());
    assert_eq!(a.body_mass(), b.body_mass());
    assert_eq!(a.geom_size(), b.geom_size());
    assert_eq!(a.geom_pos(), b.geom_pos());
    assert_eq!(a.actuator_gainprm(), b.actuator_gainprm());
    assert_eq!(a.actuator_biasprm(), b.actuator_biasprm());
    assert_eq!(a.key_qpos(), b.key_qpos());
    // The keyframe holds the head pose and the bent start.
    let key = a.key_qpos();
    let tip = add(cfg.snake.head_position_m, [0.0, 0.0, cfg.snake.link_radius_m]);
    assert_close(&key[..3], &tip, 0.0, "key head position");
    let half = 33f64.to_radians() / 2.0;
    assert_close(&key[3..7], &[half.cos(), 0.0, 0.0, half.sin()], 1e-15, "key head quaternion");
    assert_close(&key[7..], &g.initial_joint_angles_rad, 0.0, "key joint angles");
    let pattern = &cfg.gait.form_closure.pattern_deg;
    for (k, q) in g.initial_joint_angles_rad.iter().enumerate() {
        assert_eq!(*q, pattern[k % pattern.len()].to_radians());
    }
    // Bent start: body positions follow link_axis_segments_m.
    let d = initial_data(&a);
    let segs = link_axis_segments_m(&cfg, &g.initial_joint_angles_rad);
    for (i, s) in segs.iter().enumerate() {
        let body = id(&a, MjtObjBase::mjOBJ_BODY, &names::link_body(i));
        assert_close(&d.xpos()[body], &s[0], TOL, "bent start");
        let site = id(&a, MjtObjBase::mjOBJ_SITE, &names::link_site(i));
        let mid = [(s[0][0] + s[1][0]) / 2.0, (s[0][1] + s[1][1]) / 2.0, (s[0][2] + s[1][2]) / 2.0];
        assert_close(&d.site_xpos()[site], &mid, TOL, "bent start centre");
    }
}

fn check_obstacles_in_model(g: &GeneratedModel, m: &MjModel) {
    for (k, c) in g.obstacles.iter().enumerate() {
        assert_eq!(c.name, names::obstacle(k));
        let geom = id(m, MjtObjBase::mjOBJ_GEOM, &c.name);
        assert_eq!(m.geom_type()[geom], MjtGeomBase::mjGEOM_CYLINDER);
        assert_close(&m.geom_pos()[geom], &[c.center_m[0], c.center_m[1], c.height_m / 2.0], 0.0, "obstacle pos");
        assert_close(&m.geom_size()[geom][..2], &[c.radius_m, c.height_m / 2.0], 0.0, "obstacle size");
    }
}

fn form_closure_cfg(order: u8) -> Config {
    let mut cfg = bare_floor();
    cfg.snake.n_links = 16;
    cfg.terrain.kind = TerrainKind::FormClosure;
    cfg.gait.kind = GaitKind::FormClosure;
    cfg.terrain.form_closure.order = order;
    cfg
}

#[test]
fn every_terrain_kind_compiles() {
    for kind in [
        TerrainKind::None,
        TerrainKind::TwoCylinders,
        TerrainKind::RandomCylinders,
        TerrainKind::CylinderPath,
        TerrainKind::FormClosure,
    ] {
        let mut cfg = form_closure_cfg(2);
        cfg.terrain.kind = kind;
        let (g, m) = gen_load(&cfg);
        check_obstacles_in_model(&g, &m);
        assert_eq!(m.ffi().ngeom as usize, 1 + cfg.snake.n_links + g.obstacles.len());
        let floor = id(&m, MjtObjBase::mjOBJ_GEOM, names::FLOOR);
        assert_eq!(m.geom_type()[floor], MjtGeomBase::mjGEOM_PLANE);
        assert_close(&m.geom_size()[floor][..2], &[cfg.terrain.floor_size_m; 2], 0.0, "floor size");
    }
}

#[test]
fn random_cylinders_are_seeded_clear_and_inside() {
    let mut cfg = bare_floor();
    cfg.terrain.kind = TerrainKind::RandomCylinders;
    cfg.snake.head_position_m = [1.0, -2.0, 0.0];
    cfg.snake.head_rotation_deg = [0.0, 0.0, 40.0];
    let a = model::generate(&cfg).unwrap();
    let b = model::generate(&cfg).unwrap();
    assert_eq!(a.obstacles, b.obstacles, "same seed, same terrain");
    cfg.general.seed = 2;
    let c = model::generate(&cfg).unwrap();
    assert_ne!(a.obstacles, c.obstacles, "different seed, different terrain");
    let rc = &cfg.terrain.random_cylinders;
    let r = cfg.snake.link_radius_m;
    let segs = link_axis_segments_m(&cfg, &[]);
    let tip = [cfg.snake.head_position_m[0], cfg.snake.head_position_m[1]];
    for g in [&a, &c] {
        assert_eq!(g.obstacles.len(), rc.count);
        for (k, o) in g.obstacles.iter().enumerate() {
            assert!(o.radius_m >= rc.radius_range_m[0] && o.radius_m <= rc.radius_range_m[1]);
            assert!(
                (o.center_m[0] - tip[0]).abs() <= rc.half_size_m && (o.center_m[1] - tip[1]).abs() <= rc.half_size_m
            );
            assert!(dist_body(o.center_m, &segs) - r - o.radius_m >= rc.min_gap_m, "{} clear of the snake", o.name);
            for p in &g.obstacles[k + 1..] {
                let gap =
                    (o.center_m[0] - p.center_m[0]).hypot(o.center_m[1] - p.center_m[1]) - o.radius_m - p.radius_m;
                assert!(gap >= rc.min_gap_m, "{} and {} gap {gap}", o.name, p.name);
            }
        }
        check_obstacles_in_model(g, &load(&g.xml));
    }
    // Too many to fit: an error on the count that says how many fit.
    cfg.terrain.random_cylinders.count = 50;
    cfg.terrain.random_cylinders.half_size_m = 0.5;
    let (key, msg) = config_error(model::generate(&cfg));
    assert_eq!(key, "terrain.random_cylinders.count");
    assert!(msg.contains("of 50 cylinders fit"), "{msg}");
}

#[test]
fn cylinder_path_positions_are_exact() {
    for yaw in [0.0, 90.0] {
        let mut cfg = bare_floor();
        cfg.terrain.kind = TerrainKind::CylinderPath;
        cfg.snake.head_position_m = [0.5, 0.25, 0.0];
        cfg.snake.head_rotation_deg = [0.0, 0.0, yaw];
        let (g, m) = gen_load(&cfg);
        let cp = &cfg.terrain.cylinder_path;
        assert_eq!(g.obstacles.len(), 2 * cp.n_pairs);
        let h = rotate([0.0, 0.0, yaw], [1.0, 0.0, 0.0]);
        let n = [-h[1], h[0]];
        for k in 0..cp.n_pairs {
            let along = cp.start_m + k as f64 * cp.spacing_m;
            for (o, side) in [(2 * k, 1.0), (2 * k + 1, -1.0)] {
                let want = [
                    0.5 + h[0] * along + side * n[0] * cp.width_m / 2.0,
                    0.25 + h[1] * along + side * n[1] * cp.width_m / 2.0,
                ];
                assert_close(&g.obstacles[o].center_m, &want, 1e-12, "peg position");
                assert_eq!(g.obstacles[o].radius_m, cp.radius_m);
            }
        }
        check_obstacles_in_model(&g, &m);
    }
}

#[test]
fn two_cylinders_gaps_are_exact() {
    let mut cfg = bare_floor();
    cfg.terrain.kind = TerrainKind::TwoCylinders;
    cfg.terrain.two_cylinders.distance_m = 0.5;
    // 1 link: thesis experiment II, configuration A; 9 links: the middle of the body is the middle
    // of link 4; 10 links: the middle of the body is joint 5.
    for n_links in [1, 9, 10] {
        cfg.snake.n_links = n_links;
        let (g, m) = gen_load(&cfg);
        let tc = &cfg.terrain.two_cylinders;
        let r = cfg.snake.link_radius_m;
        let l = cfg.snake.link_length_m;
        let [a, b] = [&g.obstacles[0], &g.obstacles[1]];
        // Ahead: surface gap to the head tip (which is the capsule's front surface point).
        assert_close(&a.center_m, &[tc.distance_m + tc.radius_m, 0.0], 1e-12, "ahead");
        // Beside the middle of the body, on the left (+y): surface gap to the body axis ± r.
        assert_close(&b.center_m, &[-(n_links as f64) * l / 2.0, r + tc.distance_m + tc.radius_m], 1e-12, "beside");
        let segs = link_axis_segments_m(&cfg, &[]);
        assert!((dist_body(b.center_m, &segs) - r - tc.radius_m - tc.distance_m).abs() <= TOL);
        // MuJoCo's own distance between the geoms equals the configured gap.
        let mut d = initial_data(&m);
        let geom = |name: &str| id(&m, MjtObjBase::mjOBJ_GEOM, name);
        let (ga, gb) = (geom(&a.name), geom(&b.name));
        let da = d.geom_distance(geom(&names::link_geom(0)), ga, 10.0, None);
        assert!((da - tc.distance_m).abs() < 1e-6, "gap ahead {da}");
        let db = (0..n_links)
            .map(|i| d.geom_distance(geom(&names::link_geom(i)), gb, 10.0, None))
            .fold(f64::INFINITY, f64::min);
        if n_links % 2 == 1 {
            assert!((db - tc.distance_m).abs() < 1e-6, "gap beside {db}");
        } else {
            // Beside a joint the two rounded caps leave a slightly larger gap.
            assert!(db > tc.distance_m && db < tc.distance_m + 0.002, "gap beside {db}");
        }
    }
}

#[test]
fn form_closure_pegs_touch_the_body() {
    let two = model::generate(&form_closure_cfg(2)).unwrap();
    let one = model::generate(&form_closure_cfg(1)).unwrap();
    assert_eq!(one.obstacles.len(), two.obstacles.len() + 2);
    assert_eq!(one.obstacles[..two.obstacles.len()], two.obstacles[..], "order 1 = order 2 + head and tail pegs");
    // Default pattern [0, 35, 35, 0, -35, -35] over 15 joints: bends (2,3), (5,6), (8,9), (11,12), (14,15).
    assert_eq!(two.obstacles.len(), 5);
    for (order, g) in [(2, &two), (1, &one)] {
        let cfg = form_closure_cfg(order);
        let segs = link_axis_segments_m(&cfg, &g.initial_joint_angles_rad);
        let want = cfg.snake.link_radius_m + cfg.terrain.form_closure.radius_m + 0.001;
        for o in &g.obstacles {
            let dist = dist_body(o.center_m, &segs);
            assert!((dist - want).abs() <= TOL, "{}: {dist} from the body axis, want {want}", o.name);
        }
        let m = load(&g.xml);
        check_obstacles_in_model(g, &m);
        // MuJoCo agrees: nothing touches at the start.
        let d = initial_data(&m);
        let floor = id(&m, MjtObjBase::mjOBJ_GEOM, names::FLOOR) as i32;
        assert!(d.contact().iter().all(|c| c.geom[0] == floor || c.geom[1] == floor), "only floor contacts");
    }
    // Pegs on the concave side: the bend at joints 2-3 (positive angles) turns the tail toward -y
    // for a snake facing +x, so its peg is at negative y.
    assert!(two.obstacles[0].center_m[1] < 0.0);
    check_concave(&form_closure_cfg(2), &two, &[(2, 3), (5, 6), (8, 9), (11, 12), (14, 15)]);
    // Odd runs: the apex is a joint; the peg touches both links that meet there.
    let mut cfg = form_closure_cfg(1);
    cfg.gait.form_closure.pattern_deg = vec![0.0, 30.0, 30.0, 30.0, 0.0, -30.0, -30.0, -30.0];
    let g = model::generate(&cfg).unwrap();
    assert_eq!(g.obstacles.len(), 4 + 2);
    let segs = link_axis_segments_m(&cfg, &g.initial_joint_angles_rad);
    let want = cfg.snake.link_radius_m + cfg.terrain.form_closure.radius_m + 0.001;
    for o in &g.obstacles {
        assert!((dist_body(o.center_m, &segs) - want).abs() <= TOL, "{}", o.name);
    }
    check_concave(&cfg, &g, &[(2, 4), (6, 8), (10, 12), (14, 15)]);
    for (peg, joint) in g.obstacles.iter().zip([3, 7, 11]) {
        // Equal distance to the two links meeting at the apex joint.
        let before = dist_seg(peg.center_m, segs[joint - 1][0], segs[joint - 1][1]);
        let after = dist_seg(peg.center_m, segs[joint][0], segs[joint][1]);
        assert!((before - want).abs() <= TOL && (after - want).abs() <= TOL, "{}", peg.name);
    }
    gen_load(&cfg);
}

/// Each bend's peg lies on the side the body turns to (head to tail).
fn check_concave(cfg: &Config, g: &GeneratedModel, bends: &[(usize, usize)]) {
    let segs = link_axis_segments_m(cfg, &g.initial_joint_angles_rad);
    let dir = |i: usize| [segs[i][1][0] - segs[i][0][0], segs[i][1][1] - segs[i][0][1]];
    let cross = |a: [f64; 2], b: [f64; 2]| a[0] * b[1] - a[1] * b[0];
    for (&(first, last), peg) in bends.iter().zip(&g.obstacles) {
        // Joint j is the front of link j: the run turns from link first-1 to link last.
        let turn = cross(dir(first - 1), dir(last));
        let apex = segs[(first + last) / 2][0];
        let side = cross(dir(first - 1), [peg.center_m[0] - apex[0], peg.center_m[1] - apex[1]]);
        assert!(turn * side > 0.0, "{} on the concave side of bend {first}-{last}", peg.name);
    }
}

#[test]
fn form_closure_needs_a_bent_start() {
    let mut cfg = form_closure_cfg(2);
    cfg.gait.kind = GaitKind::SineWave;
    assert_eq!(config_error(model::generate(&cfg)).0, "terrain.kind");
    let mut cfg = form_closure_cfg(2);
    cfg.gait.form_closure.pattern_deg = vec![0.0];
    assert_eq!(config_error(model::generate(&cfg)).0, "gait.form_closure.pattern_deg");
}

#[test]
fn obstacles_inside_the_snake_are_rejected_with_the_key() {
    // A corridor starting just ahead of the head, narrower than the snake.
    let mut cfg = bare_floor();
    cfg.terrain.kind = TerrainKind::CylinderPath;
    cfg.terrain.cylinder_path.start_m = 0.01;
    cfg.terrain.cylinder_path.width_m = 0.05;
    cfg.terrain.cylinder_path.radius_m = 0.02;
    let (key, msg) = config_error(model::generate(&cfg));
    assert_eq!(key, "terrain.cylinder_path.width_m");
    assert!(msg.contains("obstacle_00") && msg.contains("link_00"), "{msg}");
    // A bent snake (form-closure start) reaching the side cylinder.
    let mut cfg = bare_floor();
    cfg.terrain.kind = TerrainKind::TwoCylinders;
    cfg.gait.kind = GaitKind::FormClosure;
    // Only joint 1 bent (pattern as long as the joint list): the whole body swings to the left.
    cfg.gait.form_closure.pattern_deg = vec![-20.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    cfg.terrain.two_cylinders.distance_m = 0.1;
    let (key, msg) = config_error(model::generate(&cfg));
    assert_eq!(key, "terrain.two_cylinders.distance_m");
    assert!(msg.contains("obstacle_01"), "{msg}");
}

#[test]
fn snake_below_the_floor_is_rejected() {
    let mut cfg = bare_floor();
    cfg.snake.head_position_m = [0.0, 0.0, -0.01];
    assert_eq!(config_error(model::generate(&cfg)).0, "snake.head_position_m");
    // Pitched so that the body goes down behind the head.
    let mut cfg = bare_floor();
    cfg.snake.head_rotation_deg = [0.0, -30.0, 0.0];
    assert_eq!(config_error(model::generate(&cfg)).0, "snake.head_position_m");
    // Lifted high enough, the same pitch is fine.
    cfg.snake.head_position_m = [0.0, 0.0, 1.0];
    gen_load(&cfg);
    // Exactly on the floor is fine.
    gen_load(&bare_floor());
}

#[test]
fn self_collision_cone_and_axes() {
    // The default floor friction (SimSerpent's own, "stick_slip"): frictionless condim-1
    // link-floor contacts through the floor geom, no pairs.
    let (_, m) = gen_load(&bare_floor());
    let floor = id(&m, MjtObjBase::mjOBJ_GEOM, names::FLOOR);
    assert_eq!(bare_floor().physics.floor_friction, FloorFriction::StickSlip);
    assert_eq!(m.npair(), 0);
    assert_eq!(m.geom_condim()[floor], 1, "frictionless link-floor contacts");
    // Below: MuJoCo's friction constraints, with the pairs of the anisotropic model.
    let mut cfg = bare_floor();
    cfg.physics.floor_friction = FloorFriction::Mujoco;
    cfg.physics.self_collision = false;
    cfg.physics.friction_cone = FrictionCone::Pyramidal;
    let (_, m) = gen_load(&cfg);
    assert_eq!(m.opt().cone, MjtCone::mjCONE_PYRAMIDAL as i32);
    let floor = id(&m, MjtObjBase::mjOBJ_GEOM, names::FLOOR);
    let collide = |a: usize, b: usize| {
        (m.geom_contype()[a] & m.geom_conaffinity()[b]) != 0 || (m.geom_contype()[b] & m.geom_conaffinity()[a]) != 0
    };
    let links: Vec<usize> =
        (0..cfg.snake.n_links).map(|i| id(&m, MjtObjBase::mjOBJ_GEOM, &names::link_geom(i))).collect();
    assert!(!collide(links[0], links[2]), "no link-link contacts without self-collision");
    // Anisotropic ground friction: the floor meets the links only through explicit pairs.
    assert_eq!(cfg.ground.model, simserpent::config::GroundModel::Anisotropic);
    assert!(!collide(links[0], floor), "no geom-based link-floor contacts next to the pairs");
    assert_eq!(m.npair() as usize, cfg.snake.n_links);
    assert_eq!(m.pair_friction()[0][..2], [cfg.ground.axial_friction, cfg.ground.lateral_friction]);
    let mut iso = cfg.clone();
    iso.ground.model = simserpent::config::GroundModel::Isotropic;
    let (_, m_iso) = gen_load(&iso);
    assert_eq!(m_iso.npair(), 0);
    let floor_iso = id(&m_iso, MjtObjBase::mjOBJ_GEOM, names::FLOOR);
    assert!(
        (m_iso.geom_contype()[links[0]] & m_iso.geom_conaffinity()[floor_iso]) != 0
            || (m_iso.geom_contype()[floor_iso] & m_iso.geom_conaffinity()[links[0]]) != 0
    );
    cfg.physics.self_collision = true;
    cfg.physics.friction_cone = FrictionCone::Elliptic;
    cfg.terrain.kind = TerrainKind::CylinderPath;
    let (_, m) = gen_load(&cfg);
    assert_eq!(m.opt().cone, MjtCone::mjCONE_ELLIPTIC as i32);
    let links: Vec<usize> =
        (0..cfg.snake.n_links).map(|i| id(&m, MjtObjBase::mjOBJ_GEOM, &names::link_geom(i))).collect();
    let collide = |a: usize, b: usize| {
        (m.geom_contype()[a] & m.geom_conaffinity()[b]) != 0 || (m.geom_contype()[b] & m.geom_conaffinity()[a]) != 0
    };
    let floor = id(&m, MjtObjBase::mjOBJ_GEOM, names::FLOOR);
    let peg = id(&m, MjtObjBase::mjOBJ_GEOM, &names::obstacle(0));
    assert!(collide(links[0], links[2]), "link-link contacts with self-collision");
    assert!(collide(links[0], peg) && !collide(peg, floor));
    // Friction and condim per geom, priorities: floor and obstacles win over links.
    assert_eq!(m.geom_priority()[floor], 1);
    assert_eq!(m.geom_priority()[peg], 1);
    assert_eq!(m.geom_priority()[links[0]], 0);
    assert_close(&m.geom_friction()[floor], &cfg.snake.ground_friction, 0.0, "floor friction");
    assert_close(&m.geom_friction()[peg], &cfg.terrain.obstacle_friction, 0.0, "peg friction");
    assert_close(&m.geom_friction()[links[0]], &cfg.snake.link_friction, 0.0, "link friction");
    assert_eq!(m.geom_condim()[floor], 3, "default: sliding friction only");
    // The floor's own friction and condim are used with isotropic ground friction.
    cfg.ground.model = simserpent::config::GroundModel::Isotropic;
    cfg.snake.ground_friction = [0.5, 0.005, 0.0001];
    let (_, m) = gen_load(&cfg);
    let floor = id(&m, MjtObjBase::mjOBJ_GEOM, names::FLOOR);
    assert_eq!(m.geom_condim()[floor], 6, "rolling friction > 0");
    cfg.snake.ground_friction = [0.5, 0.01, 0.0];
    cfg.snake.link_friction = [0.5, 0.0, 0.0];
    let (_, m) = gen_load(&cfg);
    let floor = id(&m, MjtObjBase::mjOBJ_GEOM, names::FLOOR);
    assert_eq!(m.geom_condim()[floor], 4);
    assert_eq!(m.geom_condim()[links[0]], 3);
    // solref: links from the contact settings, floor and obstacles from the environment contact
    // settings ("auto": max(2 ms, 2 timesteps) = 2 ms at 1 ms steps; damping ratio 0.5).
    assert_close(&m.geom_solref()[links[0]], &[0.02, 1.0], 0.0, "link solref");
    assert_close(&m.geom_solref()[floor], &[0.002, 0.5], 0.0, "floor solref");
    let peg = id(&m, MjtObjBase::mjOBJ_GEOM, &names::obstacle(0));
    assert_close(&m.geom_solref()[peg], &[0.002, 0.5], 0.0, "obstacle solref");
    cfg.general.timestep_secs = 0.004;
    let (_, m) = gen_load(&cfg);
    assert_close(&m.geom_solref()[id(&m, MjtObjBase::mjOBJ_GEOM, names::FLOOR)], &[0.008, 0.5], 0.0, "auto");

    let mut cfg = bare_floor();
    cfg.snake.joint_axes = JointAxes::Alternating;
    let (_, m) = gen_load(&cfg);
    for j in 1..cfg.snake.n_links {
        let jid = id(&m, MjtObjBase::mjOBJ_JOINT, &names::joint(j));
        let want = if j % 2 == 0 { [0.0, 1.0, 0.0] } else { [0.0, 0.0, 1.0] };
        assert_eq!(m.jnt_axis()[jid], want, "joint {j} axis");
    }
}

#[test]
fn one_link_and_many_links() {
    let mut cfg = bare_floor();
    cfg.snake.n_links = 1;
    let (g, m) = gen_load(&cfg);
    assert!(g.initial_joint_angles_rad.is_empty());
    assert_eq!((m.ffi().njnt, m.ffi().nu, m.ffi().nsensor), (1, 0, 5));
    initial_data(&m);

    let mut cfg = bare_floor();
    cfg.snake.n_links = 120;
    cfg.gait.kind = GaitKind::FormClosure;
    let (g, m) = gen_load(&cfg);
    assert_eq!(m.ffi().nbody, 121);
    assert_eq!(names::link_body(119), "link_119");
    id(&m, MjtObjBase::mjOBJ_JOINT, "joint_119");
    id(&m, MjtObjBase::mjOBJ_ACTUATOR, "intvelocity_119");
    id(&m, MjtObjBase::mjOBJ_SENSOR, "joint_119_angvel");
    id(&m, MjtObjBase::mjOBJ_SENSOR, "link_07_quat");
    assert_eq!(g.initial_joint_angles_rad.len(), 119);
    let d = initial_data(&m);
    let segs = link_axis_segments_m(&cfg, &g.initial_joint_angles_rad);
    let tail = id(&m, MjtObjBase::mjOBJ_BODY, &names::link_body(119));
    assert_close(&d.xpos()[tail], &segs[119][0], 1e-9, "tail of a long bent snake");

    let mut cfg = bare_floor();
    cfg.snake.n_links = model::MAX_LINKS;
    gen_load(&cfg);
    cfg.snake.n_links = 0;
    assert_eq!(config_error(model::generate(&cfg)).0, "snake.n_links");
}

#[test]
fn sphere_links_when_length_is_twice_the_radius() {
    let mut cfg = bare_floor();
    cfg.snake.link_length_m = 2.0 * cfg.snake.link_radius_m;
    let (_, m) = gen_load(&cfg);
    let geom = id(&m, MjtObjBase::mjOBJ_GEOM, &names::link_geom(3));
    assert_eq!(m.geom_type()[geom], MjtGeomBase::mjGEOM_SPHERE);
    // Barely longer than 2r: still a capsule, exact.
    cfg.snake.link_length_m = 2.0 * cfg.snake.link_radius_m + 1e-9;
    let (_, m) = gen_load(&cfg);
    assert_eq!(m.geom_type()[geom], MjtGeomBase::mjGEOM_CAPSULE);
    cfg.snake.link_length_m = 2.0 * cfg.snake.link_radius_m - 1e-9;
    assert_eq!(config_error(model::generate(&cfg)).0, "snake.link_length_m");
}

#[test]
fn the_initial_key_holds_the_servo_set_points() {
    let mut cfg = bare_floor();
    cfg.gait.kind = GaitKind::FormClosure;
    cfg.control.method = ControlMethod::Position;
    let (g, m) = gen_load(&cfg);
    let d = initial_data(&m);
    // The position servos start at rest: no actuator force at the bent start.
    for f in d.actuator_force() {
        assert!(f.abs() <= 1e-12, "{f}");
    }
    assert_close(d.act(), &g.initial_joint_angles_rad, 0.0, "intvelocity set-points");
}

#[test]
fn a_users_robot_in_the_terrain() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("robot.xml"),
        "<mujoco><worldbody><body name='ball' pos='0 0 0.5'><freejoint/><geom size='0.1'/></body></worldbody></mujoco>",
    )
    .unwrap();
    let mut cfg = bare_floor();
    cfg.terrain.kind = TerrainKind::TwoCylinders;
    let scene = model::scene_with_robot("robot.xml", &cfg).unwrap();
    let path = dir.path().join("model.xml");
    std::fs::write(&path, &scene.xml).unwrap();
    let m = MjModel::from_xml(&path).unwrap();
    id(&m, MjtObjBase::mjOBJ_BODY, "ball");
    id(&m, MjtObjBase::mjOBJ_GEOM, names::FLOOR);
    check_obstacles_in_model(&scene, &m);
    cfg.terrain.kind = TerrainKind::FormClosure;
    assert!(model::scene_with_robot("robot.xml", &cfg).is_err());
}

#[test]
fn strange_values_give_errors_not_panics() {
    type Edit = fn(&mut Config);
    let edits: &[(&str, Edit)] = &[
        ("snake.n_links", |c| c.snake.n_links = 0),
        ("snake.n_links", |c| c.snake.n_links = usize::MAX),
        ("snake.link_length_m", |c| c.snake.link_length_m = f64::NAN),
        ("snake.link_radius_m", |c| c.snake.link_radius_m = -1.0),
        ("snake.link_length_m", |c| c.snake.link_length_m = 0.01),
        ("control.torque_gear", |c| c.control.torque_gear = 0.0),
        ("snake.head_position_m", |c| c.snake.head_position_m[0] = f64::INFINITY),
        ("gait.form_closure.pattern_deg", |c| {
            c.gait.kind = GaitKind::FormClosure;
            c.gait.form_closure.pattern_deg.clear();
        }),
        ("gait.form_closure.pattern_deg", |c| {
            c.gait.kind = GaitKind::FormClosure;
            c.gait.form_closure.pattern_deg = vec![200.0];
        }),
        ("terrain.random_cylinders.radius_range_m", |c| {
            c.terrain.kind = TerrainKind::RandomCylinders;
            c.terrain.random_cylinders.radius_range_m = [0.2, 0.1];
        }),
        ("terrain.random_cylinders.half_size_m", |c| {
            c.terrain.kind = TerrainKind::RandomCylinders;
            c.terrain.random_cylinders.half_size_m = -1.0;
        }),
        ("terrain.random_cylinders.count", |c| {
            c.terrain.kind = TerrainKind::RandomCylinders;
            c.terrain.random_cylinders.count = usize::MAX;
        }),
        ("terrain.cylinder_path.n_pairs", |c| {
            c.terrain.kind = TerrainKind::CylinderPath;
            c.terrain.cylinder_path.n_pairs = usize::MAX;
        }),
        ("snake.head_rotation_deg", |c| {
            c.terrain.kind = TerrainKind::TwoCylinders;
            c.snake.head_rotation_deg = [0.0, 90.0, 0.0]; // standing on its head, body straight up
        }),
        ("snake.joint_axes", |c| {
            c.terrain.kind = TerrainKind::FormClosure;
            c.gait.kind = GaitKind::FormClosure;
            c.snake.joint_axes = JointAxes::Alternating;
            c.snake.head_position_m[2] = 2.0;
        }),
        ("terrain.form_closure.order", |c| {
            c.terrain.kind = TerrainKind::FormClosure;
            c.gait.kind = GaitKind::FormClosure;
            c.terrain.form_closure.order = 3;
        }),
        ("gait.form_closure.pattern_deg", |c| {
            c.terrain.kind = TerrainKind::FormClosure;
            c.gait.kind = GaitKind::FormClosure;
            c.snake.n_links = 1;
        }),
    ];
    for (key, edit) in edits {
        let mut cfg = bare_floor();
        edit(&mut cfg);
        assert_eq!(config_error(model::generate(&cfg)).0, *key);
    }
}
