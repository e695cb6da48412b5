//! SimSerpent's contact law for one contact point, in the normal direction: the normal force of
//! a step with its spring held explicitly and its damper implicit ([`held_normal_force_n`], the
//! per-link ground), or integrated implicitly
//! through the point's mass ([`normal_force_n`], [`normal_force_terms`] for points coupled
//! through a body's mobility: the obstacles), and the damping that gives a configured
//! coefficient of restitution ([`damping_ratio_for_restitution`], [`damping_ratio_for_step`]). Pure functions of the point's state and the step;
//! the engine side (which contacts, which masses, friction) is `simserpent::sim::ground`.
//!
//! Sources: the trapezoidal rule is Newmark's average-acceleration method (N. M. Newmark, "A
//! method of computation for structural dynamics", *J. Eng. Mech. Div. ASCE* 85, 1959); the
//! restitution of a spring–damper that only pushes is from T. Schwager and T. Pöschel,
//! "Coefficient of restitution and linear–dashpot model revisited", *Granular Matter* 9,
//! 465–469 (2007).
//!
//! Limits: one point of known mass. A real contact point's mass depends on where it is on its
//! body and on what the body is joined to; the engine side chooses which mass the solve
//! assumes, and the rebound follows the configured restitution exactly only where the real mass
//! is the assumed one (a link landing flat on both ends).

/// One contact point's normal spring–damper: stiffness k (N/m), damping c (N·s/m) and the
/// point's effective mass along the normal for its link alone (kg).
#[derive(Debug, Clone, Copy)]
pub struct NormalLaw {
    pub stiffness_n_per_m: f64,
    pub damping_n_s_per_m: f64,
    pub effective_mass_kg: f64,
}

/// The normal force (N, ≥ 0) a contact point gets for a step of `dt`, held over the step: the
/// point at penetration δ₀ = `depth_m` approaching the surface at u = `approach_m_per_s`, with
/// free acceleration a = `free_approach_m_per_s2` toward it (gravity along the normal).
///
/// - **In contact the whole step** (δ₀ > 0 and the free prediction δ₀ + u·dt + ½·a·dt² > 0):
///   the spring by the trapezoidal rule (Newmark's average acceleration) and the damper by
///   backward Euler, both through the point's own mass m, the end state moved by the force
///   itself: N = k·(δ₀ + δ₁)/2 + c·u₁, u₁ = u₀ + (a − N/m)·dt, δ₁ = δ₀ + u₀·dt + ½·(a − N/m)·dt²,
///   solved for N: N = [k·(δ₀ + ½·u₀·dt + ¼·a·dt²) + c·(u₀ + a·dt)] / [1 + (¼·k·dt² + c·dt)/m].
///   For one point of mass m it is unconditionally stable, the undamped spring neither gains nor
///   loses energy, and the damper needs no bound on c·dt/m; backward Euler also damps an
///   oscillation that flips sign every step (the trapezoidal damper would not: its mean
///   velocity over such a step is zero), such as a link's pitch rocking against its friction.
/// - **Touching down or lifting off within the step**: the spring's held force is its energy's
///   change over the free prediction's penetration change, k·(δ₁⁺² − δ₀⁺²)/(2·(δ₁ − δ₀)) (its exact
///   work), plus the damper over the part f of the step in contact, implicit in the same way:
///   (F_s + f·c·u₀)/(1 + f·c·dt/m).
/// - N is never negative (a contact only pushes): the force ends when the spring–damper would
///   pull, before the spring is relaxed, which is why the restitution of a damping ratio ζ is
///   [`restitution_of_damping_ratio`], not exp(−πζ/√(1 − ζ²)).
pub fn normal_force_n(
    law: NormalLaw,
    depth_m: f64,
    approach_m_per_s: f64,
    free_approach_m_per_s2: f64,
    dt: f64,
) -> f64 {
    let (numerator, implicit) = normal_force_terms(law, depth_m, approach_m_per_s, free_approach_m_per_s2, dt);
    (numerator / (1.0 + implicit / law.effective_mass_kg)).max(0.0)
}

/// The two terms of [`normal_force_n`] for contact points that push the same bodies: N =
/// (`numerator` − `implicit`·Δu̇)/(1 + `implicit`/m) is the force of one point, and for points
/// coupled through a mobility W (the approach acceleration of point i under unit forces at the
/// others) N_i = (numerator_i − implicit_i·Σ_{j≠i} W_ij·N_j)/(1 + implicit_i·W_ii), solved
/// together, N ≥ 0. In contact the whole step: numerator = k·(δ₀ + ½·u₀·dt + ¼·a·dt²) +
/// c·(u₀ + a·dt), implicit = ¼·k·dt² + c·dt; touching down or lifting off within it: numerator =
/// the spring's held force + f·c·u₀, implicit = f·c·dt; out of contact: (0, 0). The mass of
/// `law` is not used.
pub fn normal_force_terms(
    law: NormalLaw,
    depth_m: f64,
    approach_m_per_s: f64,
    free_approach_m_per_s2: f64,
    dt: f64,
) -> (f64, f64) {
    let NormalLaw { stiffness_n_per_m: k, damping_n_s_per_m: c, .. } = law;
    let (d0, u, a) = (depth_m, approach_m_per_s, free_approach_m_per_s2);
    let d1 = d0 + dt * u + 0.5 * dt * dt * a;
    if d0 > 0.0 && d1 > 0.0 {
        return (k * (d0 + 0.5 * dt * u + 0.25 * dt * dt * a) + c * (u + dt * a), 0.25 * k * dt * dt + c * dt);
    }
    if d0 <= 0.0 && d1 <= 0.0 {
        return (0.0, 0.0);
    }
    let (p0, p1) = (d0.max(0.0), d1.max(0.0));
    let spring = k * (p1 * p1 - p0 * p0) / (2.0 * (d1 - d0));
    if spring <= 0.0 {
        return (0.0, 0.0);
    }
    let fraction = p0.max(p1) / (d1 - d0).abs();
    (spring + fraction * c * u, fraction * c * dt)
}

/// The normal force (N, ≥ 0) of a ground contact point held over a step of `dt`: the spring held
/// explicitly, the damper implicitly through the point's mass m (`law.effective_mass_kg`).
/// N = max(0, F_s + D):
/// - the spring's held force is its energy's change over the penetration's free predicted change,
///   F_s = k·(δ₁⁺² − δ₀⁺²)/(2·(δ₁ − δ₀)), δ₁ = δ₀ + u₀·dt + ½·a·dt² (k·(δ₀ + δ₁)/2 while the contact
///   lasts the whole step, the spring's exact work when it starts or ends within it), so the
///   undamped spring neither gains nor loses energy whatever the point's real mass;
/// - the damper by backward Euler on the point alone, over the part f of the step in contact:
///   D = f·c·u₁ with u₁ = u₀ − D·dt/m, so D = f·c·u₀/(1 + f·c·dt/m). It resists the motion at
///   the step's start, as an explicit damper does, and its effective damping c/(1 + c·dt/m)
///   stays below m/dt: for a point whose real mass is m or more it never flips the point's
///   motion in one step, so it needs no bound on c.
pub fn held_normal_force_n(
    law: NormalLaw,
    depth_m: f64,
    approach_m_per_s: f64,
    free_approach_m_per_s2: f64,
    dt: f64,
) -> f64 {
    let NormalLaw { stiffness_n_per_m: k, damping_n_s_per_m: c, effective_mass_kg: m } = law;
    let (u, a) = (approach_m_per_s, free_approach_m_per_s2);
    let (d0, d1) = (depth_m, depth_m + dt * u + 0.5 * dt * dt * a);
    let (p0, p1) = (d0.max(0.0), d1.max(0.0));
    let crossing = (d0 > 0.0) != (d1 > 0.0);
    let spring = if crossing { k * (p1 * p1 - p0 * p0) / (2.0 * (d1 - d0)) } else { 0.5 * k * (p0 + p1) };
    if spring <= 0.0 {
        return 0.0;
    }
    let fraction = if crossing { p0.max(p1) / (d1 - d0).abs() } else { 1.0 };
    let damper = fraction * c * u / (1.0 + fraction * c * dt / m);
    (spring + damper).max(0.0)
}

/// The coefficient of restitution of a mass on a linear spring–damper that only pushes, with
/// damping ratio ζ: the contact ends when the force k·δ + c·δ̇ reaches zero, before the spring
/// has relaxed (Schwager and Pöschel, "Coefficient of restitution and linear–dashpot model
/// revisited", *Granular Matter* 9, 465–469, 2007):
/// - ζ < 1/√2: e = exp(−ζ/√(1−ζ²)·(π − arctan(2ζ√(1−ζ²)/(1 − 2ζ²))));
/// - 1/√2 ≤ ζ < 1: e = exp(−ζ/√(1−ζ²)·arctan(2ζ√(1−ζ²)/(2ζ² − 1)))  (ζ = 1/√2: e^(−π/2));
/// - ζ = 1: e = e⁻²; ζ > 1: the overdamped solution δ ∝ e^{r₁t} − e^{r₂t}, r₁,₂ = −ζ ± √(ζ²−1)
///   (per ω), whose force is zero at e^{(r₁−r₂)t} = (1 + 2ζr₂)/(1 + 2ζr₁): e = −δ̇(t)/δ̇(0).
///
/// Without gravity during the contact; gravity lowers a measured rebound by about g·t_c/v
/// (t_c the contact's duration, ≈ 3 ms with the defaults).
pub fn restitution_of_damping_ratio(zeta: f64) -> f64 {
    let z = zeta.max(0.0);
    if z == 0.0 {
        return 1.0;
    }
    if z < 1.0 {
        // π − arctan(2ζ√(1−ζ²)/(1 − 2ζ²)) below 1/√2 and arctan(2ζ√(1−ζ²)/(2ζ² − 1)) above: both
        // π − atan2(2ζ√(1−ζ²), 1 − 2ζ²), continuous through 1/√2.
        let s = (1.0 - z * z).sqrt();
        let phase = std::f64::consts::PI - (2.0 * z * s).atan2(1.0 - 2.0 * z * z);
        return (-z / s * phase).exp();
    }
    if z == 1.0 {
        return (-2.0_f64).exp();
    }
    // Overdamped, with ω = 1: δ(t) = v₀·(e^{r₁t} − e^{r₂t})/(r₁ − r₂).
    let s = (z * z - 1.0).sqrt();
    let (r1, r2) = (-z + s, -z - s);
    let t = ((1.0 + 2.0 * z * r2) / (1.0 + 2.0 * z * r1)).ln() / (r1 - r2);
    -(r1 * (r1 * t).exp() - r2 * (r2 * t).exp()) / (r1 - r2)
}

/// The damping ratio ζ whose linear spring–damper rebounds at restitution `e`
/// ([`restitution_of_damping_ratio`] inverted by bisection; `e` in (0, 1], 1 → 0).
pub fn damping_ratio_for_restitution(e: f64) -> f64 {
    if e >= 1.0 {
        return 0.0;
    }
    let e = e.max(1e-6);
    let (mut lo, mut hi) = (0.0_f64, 1.0_f64);
    while restitution_of_damping_ratio(hi) > e {
        hi *= 2.0;
    }
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if restitution_of_damping_ratio(mid) > e {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The rebound of one contact point under [`normal_force_n`] with steps of `omega_dt` (ω·dt), a
/// carried mass of 1 whose solve assumes `1 / mass_ratio`, damping ratio ζ, without gravity:
/// the exit speed over the entry speed.
pub fn discrete_restitution(zeta: f64, omega_dt: f64, mass_ratio: f64) -> f64 {
    // Entry from just above the surface.
    rebound_speed(zeta, omega_dt, mass_ratio, -1e-9)
}

/// One impact stepped with [`normal_force_n`] in units where ω = 1 (so dt = ω·dt): entry at
/// speed 1 from `start_depth` (≤ 0), the exit speed once the point has left the surface (0 if it
/// does not within 100,000 steps).
fn rebound_speed(zeta: f64, omega_dt: f64, mass_ratio: f64, start_depth: f64) -> f64 {
    rebound_speed_of(normal_force_n, zeta, omega_dt, mass_ratio, start_depth)
}

/// [`rebound_speed`] with the force law `force` ([`normal_force_n`] or [`held_normal_force_n`]).
fn rebound_speed_of(
    force: fn(NormalLaw, f64, f64, f64, f64) -> f64,
    zeta: f64,
    omega_dt: f64,
    mass_ratio: f64,
    start_depth: f64,
) -> f64 {
    let dt = omega_dt;
    let law = NormalLaw { stiffness_n_per_m: 1.0, damping_n_s_per_m: 2.0 * zeta, effective_mass_kg: 1.0 / mass_ratio };
    let (mut depth, mut approach, mut touched) = (start_depth, 1.0, false);
    for _ in 0..100_000 {
        let n = force(law, depth, approach, 0.0, dt);
        depth += approach * dt - 0.5 * n * dt * dt;
        approach -= n * dt;
        touched |= depth > 0.0;
        if touched && depth < 0.0 && approach < 0.0 {
            return -approach;
        }
    }
    0.0
}

/// [`discrete_restitution`] averaged over where in a step the contact starts: the entry point
/// [`ENTRY_PHASES`] evenly spread over one step's travel above the surface (at ω·dt near 1 the
/// rebound of one impact moves by ±0.03 with it; an impact meets the step grid anywhere).
pub fn phase_averaged_restitution(zeta: f64, omega_dt: f64, mass_ratio: f64) -> f64 {
    phase_averaged_restitution_of(normal_force_n, zeta, omega_dt, mass_ratio)
}

/// [`phase_averaged_restitution`] with the force law `force`.
fn phase_averaged_restitution_of(
    force: fn(NormalLaw, f64, f64, f64, f64) -> f64,
    zeta: f64,
    omega_dt: f64,
    mass_ratio: f64,
) -> f64 {
    // Entry (k + ½)/ENTRY_PHASES of a step above the surface.
    let sum: f64 = (0..ENTRY_PHASES)
        .map(|k| {
            rebound_speed_of(force, zeta, omega_dt, mass_ratio, -(k as f64 + 0.5) / ENTRY_PHASES as f64 * omega_dt)
        })
        .sum();
    sum / ENTRY_PHASES as f64
}

/// Entry phases [`phase_averaged_restitution`] averages over.
const ENTRY_PHASES: usize = 16;

/// The damping ratio whose contact point rebounds at `e` on average over where in a step the
/// contact starts ([`phase_averaged_restitution`] inverted by bisection below the damping of its
/// lowest rebound), with steps of `omega_dt` and the solve's mass ratio `mass_ratio`.
pub fn damping_ratio_for_step_averaged(e: f64, omega_dt: f64, mass_ratio: f64) -> f64 {
    damping_ratio_giving(e, |zeta| phase_averaged_restitution(zeta, omega_dt, mass_ratio))
}

/// The damping ratio at which `restitution(ζ)` is `e`: 0 for e ≥ 1; else the lowest
/// restitution over [`SCAN_ZETA`] and its ζ, that ζ when e is at or below it, and otherwise
/// bisection between 0 and it (where the restitution falls as ζ grows).
fn damping_ratio_giving(e: f64, restitution: impl Fn(f64) -> f64) -> f64 {
    if e >= 1.0 {
        return 0.0;
    }
    let (lowest, at) = lowest_of(&restitution);
    if e <= lowest {
        return at;
    }
    let (mut lo, mut hi) = (0.0_f64, at);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if restitution(mid) > e {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The lowest `restitution(ζ)` over [`SCAN_ZETA`] and the ζ that gives it (the first, on a tie).
fn lowest_of(restitution: impl Fn(f64) -> f64) -> (f64, f64) {
    let mut best = (f64::INFINITY, 0.0);
    for z in SCAN_ZETA {
        let e = restitution(z);
        if e < best.0 {
            best = (e, z);
        }
    }
    best
}

/// Damping ratios scanned for the lowest restitution a step can give (0.05 apart, up to 4).
const SCAN_ZETA: [f64; 80] = {
    let mut z = [0.0; 80];
    let mut i = 0;
    while i < 80 {
        z[i] = 0.05 * (i + 1) as f64;
        i += 1;
    }
    z
};

/// The lowest restitution [`normal_force_n`] reaches with steps of `omega_dt` and the solve's
/// mass ratio `mass_ratio`, and the damping ratio that gives it: with ω·dt near 1 the step
/// cannot resolve a heavily damped impact (above that damping the rebound grows again; 0.19 at
/// ω·dt = 1 and mass ratio 1, 0.06 at ω·dt = 0.5, 0.015 at 0.2).
pub fn lowest_restitution(omega_dt: f64, mass_ratio: f64) -> (f64, f64) {
    lowest_of(|zeta| discrete_restitution(zeta, omega_dt, mass_ratio))
}

/// The damping ratio whose contact point rebounds at `e` with steps of `omega_dt` (ω·dt) and
/// the solve's mass ratio `mass_ratio` ([`discrete_restitution`] inverted by bisection below the
/// damping of [`lowest_restitution`]): the restitution is then the configured one at the step in
/// use, not only as dt → 0 (where it is [`damping_ratio_for_restitution`]). Below the lowest
/// reachable restitution, the damping of the lowest.
pub fn damping_ratio_for_step(e: f64, omega_dt: f64, mass_ratio: f64) -> f64 {
    damping_ratio_giving(e, |zeta| discrete_restitution(zeta, omega_dt, mass_ratio))
}

/// The damping per kilogram of a ground contact point's assumed mass (1/s) that makes an impact
/// under [`held_normal_force_n`] rebound at a restitution `e` on average over where in a step it
/// starts, for a point whose solve assumes a mass m_a while the impact carries q·m_a (the mass
/// ratio q): a link landing flat on a plane pushes each of its two end caps with half its mass,
/// while each cap's law assumes the cap's effective mass for the link alone,
/// 1/m_eff = 1/m + (r × n)ᵀ I⁻¹ (r × n), so q = m/(2·m_eff) (1.11 for the default link).
/// With k = m_a·ω² and c = m_a·b the impact's own frequency is ω/√q and its damping ratio
/// b/(2·ω)·√q: b = 2·ω·√q·ζ with ζ the damping ratio whose phase-averaged rebound (as
/// [`phase_averaged_restitution`], with this law and mass ratio q) is e at ω·dt/√q; where a step
/// cannot reach e (too coarse for the damping it needs), the damping of the lowest rebound.
/// Tabulated over q at set-up ([`DampingByMassRatio::new`]) and read by linear interpolation
/// ([`DampingByMassRatio::damping_per_s`]), clamped to the table's range.
#[derive(Debug, Clone)]
pub struct DampingByMassRatio {
    damping_per_s: Vec<f64>,
}

/// The mass ratios [`DampingByMassRatio`] tabulates: 0.5 (a point at its body's centre of mass)
/// to 5, 1/8 apart.
const MASS_RATIO_MIN: f64 = 0.5;
const MASS_RATIO_STEP: f64 = 0.125;
const MASS_RATIOS: usize = 37;

impl DampingByMassRatio {
    /// The table for restitution `e`, stiffness ω² = `omega_per_s`² per kilogram and step `dt`.
    pub fn new(e: f64, omega_per_s: f64, dt: f64) -> Self {
        let damping_per_s = (0..MASS_RATIOS)
            .map(|i| {
                let q = MASS_RATIO_MIN + MASS_RATIO_STEP * i as f64;
                let omega_dt = omega_per_s * dt / q.sqrt();
                let zeta =
                    damping_ratio_giving(e, |z| phase_averaged_restitution_of(held_normal_force_n, z, omega_dt, q));
                2.0 * omega_per_s * q.sqrt() * zeta
            })
            .collect();
        Self { damping_per_s }
    }

    /// The damping per kilogram of assumed mass (1/s) at mass ratio `mass_ratio`.
    pub fn damping_per_s(&self, mass_ratio: f64) -> f64 {
        let x = ((mass_ratio - MASS_RATIO_MIN) / MASS_RATIO_STEP).clamp(0.0, (MASS_RATIOS - 1) as f64);
        let i = (x as usize).min(MASS_RATIOS - 2);
        let f = x - i as f64;
        self.damping_per_s[i] * (1.0 - f) + self.damping_per_s[i + 1] * f
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The step's rebound tends to the closed form of the continuous law as dt → 0, and the
    /// inverse gives back the restitution it was asked for.
    #[test]
    fn the_rebound_of_a_point_is_the_configured_restitution() {
        for zeta in [0.1, 0.5, 0.9, 1.0, 1.5] {
            let closed = restitution_of_damping_ratio(zeta);
            let stepped = discrete_restitution(zeta, 0.002, 1.0);
            assert!((stepped - closed).abs() < 0.005, "ζ {zeta}: {stepped} against {closed}");
        }
        assert!((restitution_of_damping_ratio(0.5) - 0.2983).abs() < 1e-3);
        assert!((restitution_of_damping_ratio(1.0) - (-2.0_f64).exp()).abs() < 1e-12);
        for e in [0.3, 0.5, 0.7] {
            for wdt in [1.0, 0.25, 0.1] {
                let z = damping_ratio_for_step_averaged(e, wdt, 1.0);
                assert!((phase_averaged_restitution(z, wdt, 1.0) - e).abs() < 1e-6, "e {e} at ω·dt {wdt}");
            }
        }
        // As dt → 0 the phase does not matter.
        let z = damping_ratio_for_step_averaged(0.3, 0.01, 1.0);
        assert!((z - damping_ratio_for_restitution(0.3)).abs() < 0.01, "{z}");
        for e in [0.2, 0.3, 0.7] {
            for (wdt, q) in [(1.0, 1.0), (1.0, 1.4), (0.1, 1.4)] {
                let z = damping_ratio_for_step(e, wdt, q);
                assert!((discrete_restitution(z, wdt, q) - e).abs() < 1e-6, "e {e} at ω·dt {wdt}");
            }
            let z = damping_ratio_for_restitution(e);
            assert!((restitution_of_damping_ratio(z) - e).abs() < 1e-9);
        }
    }

    /// A point resting at the static penetration m·a/k carries m·a (the trapezoidal spring and
    /// the implicit damper add nothing at rest); an undamped bounce keeps its speed as the step
    /// resolves the contact (ω·dt = 0.1: 1 − 1.2e-5), and loses a little where the contact lasts
    /// a few steps, at touch-down and lift-off, whose held force is the spring's work over the
    /// free motion's penetration (ω·dt = 0.5: 0.993; 1: 0.902): what [`damping_ratio_for_step`]
    /// takes into account.
    #[test]
    fn a_resting_point_carries_its_weight_and_an_elastic_one_rebounds_fully() {
        let law = NormalLaw { stiffness_n_per_m: 1e6, damping_n_s_per_m: 1e3, effective_mass_kg: 0.7 };
        let rest = 0.7 * 9.81 / 1e6;
        assert!((normal_force_n(law, rest, 0.0, 9.81, 1e-3) - 0.7 * 9.81).abs() < 1e-9);
        assert!((discrete_restitution(0.0, 0.1, 1.0) - 1.0).abs() < 2e-5);
        assert!((discrete_restitution(0.0, 0.5, 1.0) - 0.9928).abs() < 1e-4);
    }
}
