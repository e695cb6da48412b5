//! Floor surfaces (`[[ground.surfaces]]`): a link crossing from one region into another meets the
//! configured friction of each, with every ground model; presets resolve to their documented
//! values; surfaces the snake never reaches change nothing.

use crate::common::G;
use simserpent::config::{Config, ConfigSource, GaitKind, GroundModel, TerrainKind, load_config_str};
use simserpent::model::SurfaceMap;
use simserpent::sim::{Simulation, Snapshot, World};

/// Steps the link rests before it is launched: 0.2 s, 10 contact time constants.
const SETTLE_STEPS: usize = 200;

/// One 0.3 kg link lying along x (head tip at the origin, centre at x = −0.1 m), no gait, no
/// obstacles, with `ground` and `surfaces` as TOML (keys of `[ground]`, then surface tables).
fn link_on_surfaces(ground: &str, surfaces: &str) -> Config {
    let text = format!(
        "[snake]\nn_links = 1\nground_friction = [0.5, 0.0, 0.0]\n[terrain]\nkind = \"none\"\n[gait]\nkind = \
         \"none\"\n[ground]\n{ground}\n{surfaces}"
    );
    let c = load_config_str(&text, ConfigSource::Toml, &[]).unwrap();
    assert_eq!(c.terrain.kind, TerrainKind::None);
    assert_eq!(c.gait.kind, GaitKind::None);
    c
}

/// Two rectangles side by side along x: `[-1, border]` and `[border, 3]` (y within ±1 m).
fn two_regions(border: f64, first: &str, second: &str) -> String {
    format!(
        "[[ground.surfaces]]\nshape = \"rectangle\"\ncenter_m = [{c0}, 0.0]\nsize_m = [{s0}, 2.0]\n{first}\n\
         [[ground.surfaces]]\nshape = \"rectangle\"\ncenter_m = [{c1}, 0.0]\nsize_m = [{s1}, 2.0]\n{second}\n",
        c0 = (border - 1.0) / 2.0,
        s0 = border + 1.0,
        c1 = (border + 3.0) / 2.0,
        s1 = 3.0 - border,
    )
}

/// Per step of a launched link: time, centre x and y, velocity along `dir`, the region under
/// the link, and the ratio of horizontal floor force to normal force.
#[derive(Debug, Clone, Copy)]
struct Sample {
    t: f64,
    x: f64,
    y: f64,
    v: f64,
    vz: f64,
    region: usize,
    ratio: f64,
}

/// Launches the link with `speed` along `dir` (unit, in the floor plane) and samples `steps` steps.
fn launch(config: &Config, dir: [f64; 2], speed: f64, steps: usize) -> Vec<Sample> {
    let mut sim = Simulation::new(config, World::from_config(config).unwrap());
    // Settle into the soft contact first (the link starts touching the floor without load).
    for _ in 0..SETTLE_STEPS {
        sim.step().unwrap();
    }
    let qvel = sim.world_mut().qvel_mut();
    qvel[0] = speed * dir[0];
    qvel[1] = speed * dir[1];
    sim.world_mut().forward();
    let mut s = Snapshot::new(1, 0);
    let mut out = Vec::with_capacity(steps);
    for _ in 0..steps {
        sim.control();
        sim.snapshot(&mut s);
        let p = s.link_position_m[0];
        let v = s.link_velocity_m_per_s[0];
        let f = s.link_floor_force_n[0];
        out.push(Sample {
            t: s.time_secs,
            x: p[0],
            y: p[1],
            v: v[0] * dir[0] + v[1] * dir[1],
            vz: v[2],
            region: s.link_region[0],
            ratio: if f[2] > 1e-6 { f[0].hypot(f[1]) / f[2] } else { 0.0 },
        });
        sim.advance().unwrap();
    }
    out
}

/// Mean deceleration (m/s²) between the first and the last sample with `keep`, and the
/// allowance for the check against μ·g.
///
/// A lone capsule sliding on the floor chatters: its normal force swings between 0 (it leaves the
/// floor for a few ms) and several times its weight, with or without surfaces (the same happens
/// with the plain isotropic floor geom, bit for bit). So over a window of length Δt the mean
/// normal force is m·(g + Δv_z/Δt), not m·g, and Coulomb friction gives a mean deceleration
/// μ·(g + Δv_z/Δt). The allowance is that vertical-momentum term, μ·|Δv_z|/Δt, plus 1% of μ·g for
/// the contact softness and the integrator.
fn deceleration(samples: &[Sample], mu: f64, keep: impl Fn(&Sample) -> bool) -> (f64, f64) {
    let first = samples.iter().find(|s| keep(s)).unwrap();
    let last = samples.iter().rev().find(|s| keep(s)).unwrap();
    let dt = last.t - first.t;
    assert!(dt > 0.03, "window of {dt} s is too short");
    ((first.v - last.v) / dt, mu * (last.vz - first.vz).abs() / dt + 0.01 * mu * G)
}

/// Asserts the deceleration between the samples with `keep` is μ·g (see [`deceleration`]).
fn assert_coulomb(samples: &[Sample], mu: f64, what: &str, keep: impl Fn(&Sample) -> bool) {
    let (a, allowance) = deceleration(samples, mu, keep);
    eprintln!("{what}: deceleration {a:.4} m/s², mu g = {:.4}, allowance {allowance:.4}", mu * G);
    assert!((a - mu * G).abs() < allowance, "{what}: deceleration {a} m/s², expected {} ± {allowance}", mu * G);
    assert!(allowance < 0.1 * mu * G, "{what}: allowance {allowance} too wide for a test");
}

#[test]
fn presets_resolve_to_their_documented_values() {
    let expected = [
        ("concrete", 0.7),
        ("wet_concrete", 0.5),
        ("asphalt", 0.72),
        ("wood", 0.3),
        ("steel", 0.47),
        ("grass", 0.35),
        ("carpet", 0.2),
        ("ptfe", 0.04),
        ("ice", 0.03),
    ];
    assert_eq!(simserpent::config::PRESETS.len(), expected.len(), "a preset without a test value");
    for (name, mu) in expected {
        let surface = format!(
            "[[ground.surfaces]]\nshape = \"circle\"\ncenter_m = [1.0, 1.0]\nradius_m = 0.5\npreset = \"{name}\"\n"
        );
        // Isotropic: the preset's μ itself. Anisotropic: [ground] scaled by μ / μ0 (μ0 = 0.5).
        let iso = SurfaceMap::from_config(&link_on_surfaces("model = \"isotropic\"", &surface));
        assert_eq!(iso.friction(1).sliding, mu, "{name}");
        assert_eq!(iso.friction(0).sliding, 0.5, "the plain floor");
        let aniso = SurfaceMap::from_config(&link_on_surfaces(
            "model = \"directional\"\naxial_friction = 0.1\nlateral_friction = 1.0\nbackward_friction = 0.3\n\
             viscous_tangential_n_s_per_m = 2.0\nviscous_normal_n_s_per_m = 20.0",
            &surface,
        ));
        let f = aniso.friction(1);
        let k = mu / 0.5;
        for (got, want) in [
            (f.axial, 0.1 * k),
            (f.lateral, 1.0 * k),
            (f.backward, 0.3 * k),
            (f.viscous_tangential, 2.0 * k),
            (f.viscous_normal, 20.0 * k),
        ] {
            assert!((got - want).abs() < 1e-12, "{name}: {got} != {want}");
        }
    }
    // Explicit values replace the scaled ones.
    let c = link_on_surfaces(
        "model = \"anisotropic\"",
        "[[ground.surfaces]]\nshape = \"circle\"\ncenter_m = [1.0, 1.0]\nradius_m = 0.5\npreset = \"ice\"\n\
         lateral_friction = 0.9\n",
    );
    let f = *SurfaceMap::from_config(&c).friction(1);
    assert_eq!((f.lateral, f.axial), (0.9, 0.1 * 0.03 / 0.5));
}

#[test]
fn later_surfaces_win_where_they_overlap() {
    let c = link_on_surfaces(
        "model = \"isotropic\"",
        "[[ground.surfaces]]\nshape = \"rectangle\"\ncenter_m = [0.0, 0.0]\nsize_m = [2.0, 2.0]\npreset = \"wood\"\n\
         [[ground.surfaces]]\nshape = \"circle\"\ncenter_m = [0.5, 0.0]\nradius_m = 0.25\npreset = \"ice\"\n",
    );
    let map = SurfaceMap::from_config(&c);
    assert_eq!(map.region_at(0.5, 0.0), 2);
    assert_eq!(map.region_at(0.75, 0.0), 2, "the border belongs to the surface");
    assert_eq!(map.region_at(0.8, 0.0), 1);
    assert_eq!(map.region_at(1.0, 1.0), 1);
    assert_eq!(map.region_at(1.01, 0.0), 0);
}

/// Isotropic friction: a link sliding along x from concrete (μ = 0.7) onto ice (μ = 0.03)
/// decelerates at μ·g on each, and the switch happens in the step where its centre crosses the
/// border.
#[test]
fn crossing_onto_ice_changes_the_deceleration_from_mu1_g_to_mu2_g() {
    let border = 0.2;
    let c =
        link_on_surfaces("model = \"isotropic\"", &two_regions(border, "preset = \"concrete\"", "preset = \"ice\""));
    let samples = launch(&c, [1.0, 0.0], 3.0, 350);
    let crossing = samples.iter().position(|s| s.x > border).expect("the link reaches the ice");
    // The region recorded at every step is the one its centre is in.
    for s in &samples {
        assert_eq!(s.region, if s.x > border { 2 } else { 1 }, "{s:?}");
    }
    // Coulomb sliding: on concrete a = 0.7 g, on ice 0.03 g; 5 ms either side of the crossing
    // left out.
    let t_cross = samples[crossing].t;
    assert_coulomb(&samples, 0.7, "concrete", |s| s.t < t_cross - 0.005);
    assert_coulomb(&samples, 0.03, "ice", |s| s.t > t_cross + 0.005);
    // The friction force over the normal force is μ of the region the link is on at every step.
    for s in samples.iter().filter(|s| s.v > 0.01 && s.ratio > 0.0) {
        let mu = if s.region == 2 { 0.03 } else { 0.7 };
        assert!((s.ratio - mu).abs() < 0.001 * mu, "{s:?}: ratio {} != {mu}", s.ratio);
    }
}

/// Anisotropic friction, derived from a surface's base μ: on the floor (μ0 = 0.5) axial 0.1 and
/// lateral 1.0; on a surface with friction 0.1 both scaled by 0.2: axial 0.02, lateral 0.2.
#[test]
fn anisotropic_crossing_changes_axial_and_lateral_friction() {
    let ground = "model = \"anisotropic\"\naxial_friction = 0.1\nlateral_friction = 1.0";
    // Along the link (x): the floor up to x = 0.1, then the surface.
    let c = link_on_surfaces(
        ground,
        "[[ground.surfaces]]\nshape = \"rectangle\"\ncenter_m = [1.1, 0.0]\nsize_m = [2.0, 2.0]\nfriction = 0.1\n",
    );
    let samples = launch(&c, [1.0, 0.0], 1.5, 300);
    let crossing = samples.iter().position(|s| s.x > 0.1).expect("the link reaches the surface");
    let t_cross = samples[crossing].t;
    assert_coulomb(&samples, 0.1, "floor, axial", |s| s.t < t_cross - 0.005);
    assert_coulomb(&samples, 0.02, "surface, axial", |s| s.t > t_cross + 0.005);

    // Across the link (y): the surface starts 5 mm beside the link's centre. A link sliding
    // sideways starts to roll (about v/(3 μ g) ≈ 70 ms at 2 m/s for μ = 1), so only the first
    // steps show sliding friction: compare the force ratio per step.
    let c = link_on_surfaces(
        ground,
        "[[ground.surfaces]]\nshape = \"rectangle\"\ncenter_m = [0.0, 1.005]\nsize_m = [2.0, 2.0]\nfriction = 0.1\n",
    );
    let samples = launch(&c, [0.0, 1.0], 2.0, 12);
    let mut seen = [false; 2];
    for s in samples[1..].iter().filter(|s| s.ratio > 0.0) {
        let on_surface = s.y >= 0.005;
        assert_eq!(s.region, usize::from(on_surface), "{s:?}");
        let mu = if on_surface { 0.2 } else { 1.0 };
        assert!((s.ratio - mu).abs() < 0.03 * mu, "{s:?}: lateral ratio {} != {mu}", s.ratio);
        seen[usize::from(on_surface)] = true;
    }
    assert_eq!(seen, [true, true], "both regions sampled");
}

/// Directional friction: sliding backward (toward the tail, −x) the link meets
/// backward_friction, scaled on a surface; forward the axial (forward) coefficient.
#[test]
fn directional_crossing_changes_forward_and_backward_friction() {
    let ground = "model = \"directional\"\naxial_friction = 0.1\nlateral_friction = 1.0\nbackward_friction = 0.3";
    // Backward: from the floor onto a surface that starts at x = −0.3 (friction 0.1: ×0.2).
    let c = link_on_surfaces(
        ground,
        "[[ground.surfaces]]\nshape = \"rectangle\"\ncenter_m = [-1.3, 0.0]\nsize_m = [2.0, 2.0]\nfriction = 0.1\n",
    );
    let samples = launch(&c, [-1.0, 0.0], 2.0, 300);
    let crossing = samples.iter().position(|s| s.x < -0.3).expect("the link reaches the surface");
    let t_cross = samples[crossing].t;
    assert_coulomb(&samples, 0.3, "floor, backward", |s| s.t < t_cross - 0.005);
    assert_coulomb(&samples, 0.06, "surface, backward", |s| s.t > t_cross + 0.005);
    // Forward onto a surface with explicit coefficients.
    let c = link_on_surfaces(
        ground,
        "[[ground.surfaces]]\nshape = \"rectangle\"\ncenter_m = [1.1, 0.0]\nsize_m = [2.0, 2.0]\nfriction = 0.5\n\
         axial_friction = 0.04\nbackward_friction = 0.5\n",
    );
    let samples = launch(&c, [1.0, 0.0], 1.5, 300);
    let crossing = samples.iter().position(|s| s.x > 0.1).expect("the link reaches the surface");
    let t_cross = samples[crossing].t;
    assert_coulomb(&samples, 0.1, "floor, forward", |s| s.t < t_cross - 0.005);
    assert_coulomb(&samples, 0.04, "surface, forward", |s| s.t > t_cross + 0.005);
}

/// Viscous friction: m dv/dt = −c_t v along the link, with c_t of the region the link is on.
#[test]
fn viscous_crossing_changes_the_damping() {
    let ground = "model = \"viscous\"\nviscous_tangential_n_s_per_m = 1.0\nviscous_normal_n_s_per_m = 10.0";
    let c = link_on_surfaces(
        ground,
        "[[ground.surfaces]]\nshape = \"rectangle\"\ncenter_m = [1.1, 0.0]\nsize_m = [2.0, 2.0]\nfriction = 0.05\n",
    );
    // Surface: c_t = 1 × 0.05 / 0.5 = 0.1 N·s/m.
    let samples = launch(&c, [1.0, 0.0], 1.5, 600);
    let crossing = samples.iter().position(|s| s.x > 0.1).expect("the link reaches the surface");
    let rate = |a: &Sample, b: &Sample| (a.v / b.v).ln() / (b.t - a.t);
    let m = 0.3;
    let before = rate(&samples[10], &samples[crossing - 5]);
    let after = rate(&samples[crossing + 5], &samples[samples.len() - 1]);
    assert!((before - 1.0 / m).abs() < 0.01 * 1.0 / m, "floor: decay rate {before} 1/s");
    assert!((after - 0.1 / m).abs() < 0.01 * 0.1 / m, "surface: decay rate {after} 1/s");
}

/// Surfaces that no link reaches change nothing: the default job (anisotropic friction, gait,
/// cylinder path) with a far-away surface follows the same trajectory, bit for bit.
#[test]
fn a_surface_no_link_reaches_leaves_the_trajectory_unchanged() {
    let mut plain = Config::default();
    plain.general.duration_secs = 0.5;
    let far = load_config_str(
        "[general]\nduration_secs = 0.5\n[[ground.surfaces]]\nshape = \"circle\"\ncenter_m = [-20.0, 20.0]\n\
         radius_m = 1.0\npreset = \"ice\"\n",
        ConfigSource::Toml,
        &[],
    )
    .unwrap();
    assert_eq!(plain.ground.model, GroundModel::Anisotropic);
    let run = |c: &Config| {
        let mut sim = Simulation::new(c, World::from_config(c).unwrap());
        for _ in 0..500 {
            sim.step().unwrap();
        }
        sim.world().data().qpos().to_vec()
    };
    let (a, b) = (run(&plain), run(&far));
    assert!(a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()), "{a:?} != {b:?}");
    // No surfaces: no tiles and no extra pairs in the model.
    let xml = simserpent::model::generate(&plain).unwrap().xml;
    assert!(!xml.contains("surface_"));
    let xml = simserpent::model::generate(&far).unwrap().xml;
    assert!(xml.contains("name=\"surface_00\" type=\"cylinder\"") && xml.contains("contype=\"0\" conaffinity=\"0\""));
}
