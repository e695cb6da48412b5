//! Floor surfaces (`[[ground.surfaces]]`): regions of the floor with their own friction, and the
//! table of named material presets.
//!
//! # How a surface's friction is found
//! Every surface has a *base* sliding coefficient μ: the preset's (`preset = "ice"`) or the
//! explicit `friction = 0.05`. The floor outside every surface is the reference material: its
//! base coefficient is `snake.ground_friction[0]` (=: μ₀), which is what the isotropic model uses
//! there, and the `[ground]` coefficients describe the snake on it. On a surface every coefficient
//! of the ground model is scaled by k = μ / μ₀, so the snake keeps its own anisotropy ratios:
//!
//! | model | on the floor | on a surface |
//! |---|---|---|
//! | isotropic | μ₀ | μ |
//! | anisotropic | `axial_friction`, `lateral_friction` | k·axial, k·lateral |
//! | directional | forward = `axial_friction`, `backward_friction`, `lateral_friction` | k· each |
//! | viscous | c_t, c_n | k·c_t, k·c_n |
//!
//! A surface with μ = μ₀ is therefore indistinguishable from the floor. Explicit per-model keys of
//! a surface (`axial_friction`, `lateral_friction`, `backward_friction`,
//! `viscous_tangential_n_s_per_m`, `viscous_normal_n_s_per_m`) replace the scaled values. The
//! viscous scaling is a heuristic (the viscous model lumps skin and surface into two damping
//! coefficients; a surface that grips k times more is taken to damp k times more); give the
//! viscous keys explicitly when you know them.
//!
//! # Presets
//! Each preset's μ is a *kinetic* (sliding) coefficient of one specific material pair from a
//! published table, named in [`Preset::pair`] and [`Preset::source`]. Friction depends on both
//! materials, their finish, humidity and temperature: the presets are typical values to start from,
//! not properties of the surface alone. Sources:
//! - Engineering ToolBox, *Friction and Friction Coefficients for some Common Materials*
//!   (engineeringtoolbox.com, table of static and kinetic coefficients; also reproduced in
//!   eCampusOntario's *Physics Fundamentals*, appendix A, table A.1);
//! - R. A. Serway and R. J. Beichner, *Physics for Scientists and Engineers*, 5th ed., table 5.2;
//! - S. A. Hill, *Coefficients of friction* table (howwhy.nfshost.com), kinetic values;
//! - D. L. Hu, J. Nirody, T. Scott and M. J. Shelley, *The mechanics of slithering locomotion*,
//!   PNAS 106(25):10081–10085, 2009 (snake skin on cloth).
//!
//! Granular ground (sand, gravel) is not a preset: a Coulomb coefficient does not describe a body
//! that sinks into and pushes grains (resistive force theory would be needed).

use serde::{Deserialize, Serialize};

use super::text::{fmt_a, fmt_f};

/// A named floor material.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Preset {
    /// Name used in `ground.surfaces[i].preset`.
    pub name: &'static str,
    /// Kinetic (sliding) friction coefficient, the surface's base μ.
    pub friction: f64,
    /// The material pair the coefficient was measured for.
    pub pair: &'static str,
    /// Where the number comes from.
    pub source: &'static str,
    /// Colour of the surface in pictures [r, g, b, a].
    pub rgba: [f64; 4],
}

/// The preset table. Kinetic coefficients; where a source gives a range the value is inside it.
pub const PRESETS: &[Preset] = &[
    // Rubber on dry concrete: kinetic 0.6–0.85 (Engineering ToolBox), 0.8 (Serway & Beichner
    // table 5.2), 0.7 (Hill). 0.7: inside all of them.
    Preset {
        name: "concrete",
        friction: 0.7,
        pair: "rubber on dry concrete",
        source: "Engineering ToolBox (kinetic 0.6-0.85); Serway & Beichner table 5.2 (0.8); Hill (0.7)",
        rgba: [0.62, 0.62, 0.60, 1.0],
    },
    // Rubber on wet concrete: kinetic 0.45–0.75 (Engineering ToolBox), 0.5 (Hill).
    Preset {
        name: "wet_concrete",
        friction: 0.5,
        pair: "rubber on wet concrete",
        source: "Engineering ToolBox (kinetic 0.45-0.75); Hill (0.5)",
        rgba: [0.40, 0.42, 0.45, 1.0],
    },
    // Car tyre on dry asphalt: 0.72 (Engineering ToolBox).
    Preset {
        name: "asphalt",
        friction: 0.72,
        pair: "rubber (car tyre) on dry asphalt",
        source: "Engineering ToolBox (0.72)",
        rgba: [0.18, 0.18, 0.20, 1.0],
    },
    // Wood and metal on dry wood: kinetic 0.2 (wood-wood, Engineering ToolBox; metal-wood static
    // 0.2-0.6), 0.3 (wood on wood and metal on wood, Hill). 0.3.
    Preset {
        name: "wood",
        friction: 0.3,
        pair: "wood or metal on clean, dry wood",
        source: "Engineering ToolBox (wood-wood kinetic 0.2, static 0.25-0.5); Hill (wood-wood, metal-wood 0.3)",
        rgba: [0.60, 0.42, 0.22, 1.0],
    },
    // Aluminium on mild steel, clean and dry: kinetic 0.47 (Engineering ToolBox).
    Preset {
        name: "steel",
        friction: 0.47,
        pair: "aluminium on mild steel, clean and dry",
        source: "Engineering ToolBox (kinetic 0.47)",
        rgba: [0.55, 0.60, 0.68, 1.0],
    },
    // Car tyre on dry grass: 0.35 (Engineering ToolBox).
    Preset {
        name: "grass",
        friction: 0.35,
        pair: "rubber (car tyre) on dry grass",
        source: "Engineering ToolBox (0.35)",
        rgba: [0.25, 0.55, 0.20, 1.0],
    },
    // Snake skin on cloth: Hu et al. 2009 report a transverse coefficient of about 0.2 for
    // anaesthetised snakes on cloth (forward and backward lower). The transverse one is taken as
    // the base: it is the one that propels a snake.
    Preset {
        name: "carpet",
        friction: 0.2,
        pair: "snake skin on cloth (transverse)",
        source: "Hu, Nirody, Scott & Shelley, PNAS 106:10081 (2009), transverse coefficient ~0.2",
        rgba: [0.55, 0.15, 0.18, 1.0],
    },
    // PTFE on steel: 0.04 static and kinetic (Engineering ToolBox; Hill).
    Preset {
        name: "ptfe",
        friction: 0.04,
        pair: "PTFE (teflon) on steel",
        source: "Engineering ToolBox (0.04); Hill (0.04)",
        rgba: [0.95, 0.95, 0.92, 1.0],
    },
    // Metal on clean ice near 0 °C: brass 0.02 (Engineering ToolBox), steel 0.02 kinetic, ice on
    // ice 0.03 (Hill). 0.03.
    Preset {
        name: "ice",
        friction: 0.03,
        pair: "metal on clean ice near 0 degC",
        source: "Engineering ToolBox (brass-ice 0.02); Hill (steel-ice 0.02, ice-ice 0.03)",
        rgba: [0.70, 0.88, 1.0, 1.0],
    },
];

/// The preset called `name`, if there is one.
pub fn preset(name: &str) -> Option<&'static Preset> {
    PRESETS.iter().find(|p| p.name == name)
}

/// Every preset name, quoted and comma-separated (for messages).
pub fn preset_names() -> String {
    PRESETS.iter().map(|p| format!("\"{}\"", p.name)).collect::<Vec<_>>().join(", ")
}

/// Shape and size of a surface region (`shape` with `size_m` or `radius_m`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SurfaceShape {
    /// `shape = "rectangle"`: axis-aligned, with full side lengths along x and y, m.
    Rectangle {
        /// Full side lengths along x and y, m.
        size_m: [f64; 2],
    },
    /// `shape = "circle"`: a disc.
    Circle {
        /// Radius, m.
        radius_m: f64,
    },
}

impl SurfaceShape {
    /// Half the extent along x and y, m.
    pub fn half_extent_m(&self) -> [f64; 2] {
        match *self {
            Self::Rectangle { size_m: [sx, sy] } => [sx / 2.0, sy / 2.0],
            Self::Circle { radius_m } => [radius_m, radius_m],
        }
    }
}

/// Where a surface's base sliding coefficient μ comes from (`preset` or `friction`, never both).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FrictionSource {
    /// A named material (`preset = "ice"`): its μ and its colour.
    Preset(&'static Preset),
    /// An explicit coefficient (`friction = 0.05`).
    Coefficient(f64),
}

impl FrictionSource {
    /// The base sliding coefficient μ.
    pub fn coefficient(&self) -> f64 {
        match *self {
            Self::Preset(p) => p.friction,
            Self::Coefficient(mu) => mu,
        }
    }
}

/// A surface's explicit per-model coefficients: each one given replaces the scaled floor value.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ExplicitFriction {
    /// Axial (forward) coefficient (anisotropic, directional).
    pub axial_friction: Option<f64>,
    /// Lateral coefficient (anisotropic, directional).
    pub lateral_friction: Option<f64>,
    /// Backward coefficient (directional).
    pub backward_friction: Option<f64>,
    /// Viscous coefficient along the link, N·s/m (viscous).
    pub viscous_tangential_n_s_per_m: Option<f64>,
    /// Viscous coefficient across the link, N·s/m (viscous).
    pub viscous_normal_n_s_per_m: Option<f64>,
}

impl ExplicitFriction {
    /// Every coefficient with its key (in `ground.surfaces[i]`), in the order of the default file.
    pub fn by_key(&self) -> [(&'static str, Option<f64>); 5] {
        [
            ("axial_friction", self.axial_friction),
            ("lateral_friction", self.lateral_friction),
            ("backward_friction", self.backward_friction),
            ("viscous_tangential_n_s_per_m", self.viscous_tangential_n_s_per_m),
            ("viscous_normal_n_s_per_m", self.viscous_normal_n_s_per_m),
        ]
    }
}

/// One region of the floor with its own friction (`[[ground.surfaces]]`).
///
/// Only consistent surfaces exist: the shape carries its own size, and the base coefficient has
/// one source. Ranges (positive sizes, non-negative coefficients, on the floor) and the rules
/// that involve `[ground]` are checked by `Config::validate`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "RawSurface", into = "RawSurface")]
pub struct Surface {
    /// Label (free text, for your own reference).
    pub name: String,
    /// Shape and size.
    pub shape: SurfaceShape,
    /// Centre in the floor plane (world x, y), m.
    pub center_m: [f64; 2],
    /// The base coefficient μ; `None` when the surface gives only explicit per-model
    /// coefficients (valid when they are all that `ground.model` needs).
    pub base: Option<FrictionSource>,
    /// Explicit per-model coefficients.
    pub explicit: ExplicitFriction,
}

/// `shape` as written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
enum ShapeKind {
    Rectangle,
    Circle,
}

/// A `[[ground.surfaces]]` table as written: every key that a surface may have. Converted into a
/// [`Surface`] by [`TryFrom`], which rejects the combinations that are not a surface.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, expecting = "struct Surface")]
struct RawSurface {
    #[serde(default)]
    name: String,
    shape: ShapeKind,
    center_m: [f64; 2],
    #[serde(default, skip_serializing_if = "Option::is_none")]
    size_m: Option<[f64; 2]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    radius_m: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    preset: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    friction: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    axial_friction: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    lateral_friction: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    backward_friction: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    viscous_tangential_n_s_per_m: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    viscous_normal_n_s_per_m: Option<f64>,
}

/// Why a surface table is not a surface: the key inside the table, its value as TOML writes it,
/// and what is allowed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("`{key}` = {value}: {allowed}")]
pub struct SurfaceError {
    /// The key inside the surface table (`size_m`).
    pub key: &'static str,
    /// Its value (`[1.0, 2.0]`, or `(missing)`).
    pub value: String,
    /// What is allowed.
    pub allowed: String,
}

impl SurfaceError {
    fn new(key: &'static str, value: impl Into<String>, allowed: impl Into<String>) -> Self {
        Self { key, value: value.into(), allowed: allowed.into() }
    }
}

impl TryFrom<RawSurface> for Surface {
    type Error = SurfaceError;

    fn try_from(raw: RawSurface) -> Result<Self, SurfaceError> {
        let shape = match raw.shape {
            ShapeKind::Rectangle => {
                if let Some(r) = raw.radius_m {
                    return Err(SurfaceError::new(
                        "radius_m",
                        fmt_f(r),
                        "only a circle has a radius; a rectangle takes size_m = [x, y] (full side lengths)",
                    ));
                }
                let Some(size_m) = raw.size_m else {
                    return Err(SurfaceError::new(
                        "size_m",
                        "(missing)",
                        "a rectangle needs size_m = [x, y]: its full side lengths along x and y, m",
                    ));
                };
                SurfaceShape::Rectangle { size_m }
            }
            ShapeKind::Circle => {
                if let Some(size) = raw.size_m {
                    return Err(SurfaceError::new(
                        "size_m",
                        fmt_a(&size),
                        "only a rectangle has a size; a circle takes radius_m",
                    ));
                }
                let Some(radius_m) = raw.radius_m else {
                    return Err(SurfaceError::new("radius_m", "(missing)", "a circle needs radius_m (> 0), m"));
                };
                SurfaceShape::Circle { radius_m }
            }
        };
        let base = match (raw.preset, raw.friction) {
            (Some(name), friction) => {
                let Some(p) = preset(&name) else {
                    let names: Vec<&str> = PRESETS.iter().map(|p| p.name).collect();
                    let hint = super::text::suggest(&name, &names)
                        .map(|n| format!("did you mean \"{n}\"? "))
                        .unwrap_or_default();
                    return Err(SurfaceError::new(
                        "preset",
                        format!("{name:?}"),
                        format!("{hint}unknown preset; allowed: {}", preset_names()),
                    ));
                };
                if let Some(mu) = friction {
                    return Err(SurfaceError::new(
                        "friction",
                        fmt_f(mu),
                        format!("give either preset ({name:?}) or friction, not both"),
                    ));
                }
                Some(FrictionSource::Preset(p))
            }
            (None, Some(mu)) => Some(FrictionSource::Coefficient(mu)),
            (None, None) => None,
        };
        Ok(Self {
            name: raw.name,
            shape,
            center_m: raw.center_m,
            base,
            explicit: ExplicitFriction {
                axial_friction: raw.axial_friction,
                lateral_friction: raw.lateral_friction,
                backward_friction: raw.backward_friction,
                viscous_tangential_n_s_per_m: raw.viscous_tangential_n_s_per_m,
                viscous_normal_n_s_per_m: raw.viscous_normal_n_s_per_m,
            },
        })
    }
}

impl From<Surface> for RawSurface {
    fn from(s: Surface) -> Self {
        let (shape, size_m, radius_m) = match s.shape {
            SurfaceShape::Rectangle { size_m } => (ShapeKind::Rectangle, Some(size_m), None),
            SurfaceShape::Circle { radius_m } => (ShapeKind::Circle, None, Some(radius_m)),
        };
        let (preset, friction) = match s.base {
            Some(FrictionSource::Preset(p)) => (Some(p.name.to_string()), None),
            Some(FrictionSource::Coefficient(mu)) => (None, Some(mu)),
            None => (None, None),
        };
        let e = s.explicit;
        Self {
            name: s.name,
            shape,
            center_m: s.center_m,
            size_m,
            radius_m,
            preset,
            friction,
            axial_friction: e.axial_friction,
            lateral_friction: e.lateral_friction,
            backward_friction: e.backward_friction,
            viscous_tangential_n_s_per_m: e.viscous_tangential_n_s_per_m,
            viscous_normal_n_s_per_m: e.viscous_normal_n_s_per_m,
        }
    }
}

/// The error of the surface table `value` at `key` (`ground.surfaces[i]`) when serde rejected
/// it as a [`Surface`] although it has every key with the right type: the conversion's own
/// error, with the full key path of the offending key. `None` for any other problem (serde's
/// message is the precise one then).
pub(super) fn conversion_error(key: &str, value: &toml::Value) -> Option<super::ConfigError> {
    let raw = RawSurface::deserialize(value.clone()).ok()?;
    let e = Surface::try_from(raw).err()?;
    Some(super::ConfigError::invalid(&format!("{key}.{}", e.key), e.value, e.allowed))
}

/// The friction coefficients of every ground model on one surface (or on the plain floor).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceFriction {
    /// Isotropic sliding coefficient.
    pub sliding: f64,
    /// Axial coefficient (anisotropic); forward coefficient (directional).
    pub axial: f64,
    /// Lateral coefficient (anisotropic, directional).
    pub lateral: f64,
    /// Backward coefficient (directional).
    pub backward: f64,
    /// Viscous coefficient along the link, N·s/m.
    pub viscous_tangential: f64,
    /// Viscous coefficient across the link, N·s/m.
    pub viscous_normal: f64,
}

impl SurfaceFriction {
    /// The coefficients of the plain floor (outside every surface).
    pub fn floor(cfg: &super::Config) -> Self {
        let g = &cfg.ground;
        Self {
            sliding: cfg.snake.ground_friction[0],
            axial: g.axial_friction,
            lateral: g.lateral_friction,
            backward: g.backward_friction,
            viscous_tangential: g.viscous_tangential_n_s_per_m,
            viscous_normal: g.viscous_normal_n_s_per_m,
        }
    }
}

impl Surface {
    /// The surface's base coefficient μ: the preset's or the explicit `friction` (None when the
    /// surface gives only explicit per-model coefficients).
    pub fn base_friction(&self) -> Option<f64> {
        self.base.map(|b| b.coefficient())
    }

    /// Whether the floor point (x, y) lies in this surface (borders included).
    pub fn contains(&self, x: f64, y: f64) -> bool {
        let [cx, cy] = self.center_m;
        match self.shape {
            SurfaceShape::Rectangle { size_m: [sx, sy] } => (x - cx).abs() <= sx / 2.0 && (y - cy).abs() <= sy / 2.0,
            SurfaceShape::Circle { radius_m: r } => (x - cx) * (x - cx) + (y - cy) * (y - cy) <= r * r,
        }
    }

    /// Axis-aligned bounding box `[min_x, min_y, max_x, max_y]`, m.
    pub fn bounds(&self) -> [f64; 4] {
        let [cx, cy] = self.center_m;
        let [hx, hy] = self.shape.half_extent_m();
        [cx - hx, cy - hy, cx + hx, cy + hy]
    }

    /// The coefficients of every ground model on this surface (see the module documentation):
    /// the floor's scaled by μ / μ₀, replaced by the surface's explicit keys. A value that needs
    /// the base μ when there is none (or μ₀ = 0) is NaN; `Config::validate` rejects such configs.
    pub fn resolve(&self, floor: &SurfaceFriction) -> SurfaceFriction {
        let base = self.base_friction().unwrap_or(f64::NAN);
        let k = if floor.sliding > 0.0 { base / floor.sliding } else { f64::NAN };
        let e = &self.explicit;
        SurfaceFriction {
            sliding: base,
            axial: e.axial_friction.unwrap_or(k * floor.axial),
            lateral: e.lateral_friction.unwrap_or(k * floor.lateral),
            backward: e.backward_friction.unwrap_or(k * floor.backward),
            viscous_tangential: e.viscous_tangential_n_s_per_m.unwrap_or(k * floor.viscous_tangential),
            viscous_normal: e.viscous_normal_n_s_per_m.unwrap_or(k * floor.viscous_normal),
        }
    }

    /// The colour of the surface in pictures: the preset's, else a grey whose darkness grows with
    /// μ (light = slippery).
    pub fn rgba(&self) -> [f64; 4] {
        if let Some(FrictionSource::Preset(p)) = self.base {
            return p.rgba;
        }
        let mu = self.base_friction().unwrap_or(0.5);
        let shade = 0.9 - 0.6 * mu.clamp(0.0, 1.0);
        [shade, shade, shade, 1.0]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn preset_names_are_unique_and_values_sane() {
        for (i, p) in PRESETS.iter().enumerate() {
            assert!(PRESETS[..i].iter().all(|q| q.name != p.name), "duplicate preset {}", p.name);
            assert!(p.friction > 0.0 && p.friction < 1.5, "{}", p.name);
            assert!(!p.source.is_empty() && !p.pair.is_empty());
            assert!(p.rgba.iter().all(|c| (0.0..=1.0).contains(c)));
        }
        assert_eq!(preset("ice").map(|p| p.friction), Some(0.03));
        assert!(preset("Ice").is_none());
    }

    #[test]
    fn contains_borders_and_outside() {
        let mut s = Surface {
            name: String::new(),
            shape: SurfaceShape::Rectangle { size_m: [2.0, 1.0] },
            center_m: [1.0, 0.0],
            base: preset("ice").map(FrictionSource::Preset),
            explicit: ExplicitFriction::default(),
        };
        assert!(s.contains(0.0, 0.5) && s.contains(2.0, -0.5) && s.contains(1.0, 0.0));
        assert!(!s.contains(-0.001, 0.0) && !s.contains(1.0, 0.501));
        assert_eq!(s.bounds(), [0.0, -0.5, 2.0, 0.5]);
        s.shape = SurfaceShape::Circle { radius_m: 0.5 };
        assert!(s.contains(1.5, 0.0) && !s.contains(1.4, 0.4));
    }
}
