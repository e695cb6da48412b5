//! SimSerpent's contact law for one contact point in the normal direction: the normal force a
//! point gets for a step ([`explicit_normal_force_n`]) and the damping that gives a configured
//! coefficient of restitution ([`damping_ratio_for_restitution`]). Pure functions of the point's
//! state and the step; the engine side (which contacts, which masses, friction) is
//! `simserpent::sim::ground`.
//!
//! Source of the restitution: T. Schwager and T. Pöschel, "Coefficient of restitution and
//! linear–dashpot model revisited", *Granular Matter* 9, 465–469 (2007).
//!
//! Limits: one point of known mass. A real contact point's mass depends on where it is on its
//! body and on what the body is joined to, so the restitution is the configured one only where
//! the engine's masses are the point's (a link landing flat on both ends); the explicit force is
//! stable only for b·dt ≤ 1 (the engine bounds b·dt ≤ ½), which caps the damping, and so the
//! lowest restitution, at large steps.

/// The normal force (N, ≥ 0) of a contact point held explicitly over a step of `dt` (the
/// ground's law): N = max(0, F_s + c·δ̇·f) with the spring's held force the spring energy's change
/// over the penetration's free predicted change, F_s = k·(δ₁⁺² − δ₀⁺²)/(2·(δ₁ − δ₀)), δ₁ = δ₀ +
/// δ̇·dt + ½·a·dt² (k·(δ₀ + δ₁)/2 while the contact lasts the whole step, the spring's exact work
/// when it starts or ends within it), f the part of the step in contact. For one point of mass
/// m with k = m·ω² and c = m·b its eigenvalues have modulus √(1 − b·dt) while ω·dt ≤ 1.2: stable
/// for b·dt ≤ 1, and the ground bounds it to b·dt ≤ ½ (room for the damping the stick springs add
/// through a link's rotation).
pub fn explicit_normal_force_n(
    stiffness_n_per_m: f64,
    damping_n_s_per_m: f64,
    depth_m: f64,
    approach_m_per_s: f64,
    free_approach_m_per_s2: f64,
    dt: f64,
) -> f64 {
    let (k, c) = (stiffness_n_per_m, damping_n_s_per_m);
    let (d0, d1) = (depth_m, depth_m + dt * approach_m_per_s + 0.5 * dt * dt * free_approach_m_per_s2);
    let (p0, p1) = (d0.max(0.0), d1.max(0.0));
    let crossing = (d0 > 0.0) != (d1 > 0.0);
    let spring = if crossing { k * (p1 * p1 - p0 * p0) / (2.0 * (d1 - d0)) } else { 0.5 * k * (p0 + p1) };
    let fraction = if crossing {
        p0.max(p1) / (d1 - d0).abs()
    } else if d0 > 0.0 {
        1.0
    } else {
        0.0
    };
    if spring > 0.0 { (spring + fraction * c * approach_m_per_s).max(0.0) } else { 0.0 }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A point mass under the explicit force with a small step rebounds at the closed form, and
    /// the inverse gives back the restitution it was asked for.
    #[test]
    fn the_rebound_of_a_point_is_the_closed_form_restitution() {
        for zeta in [0.1, 0.3, 0.5] {
            // ω = 1, mass 1, entry at speed 1, dt = 0.001 (b·dt ≤ ½).
            let (dt, mut depth, mut approach, mut touched) = (1e-3, -1e-9, 1.0, false);
            let rebound = loop {
                let n = explicit_normal_force_n(1.0, 2.0 * zeta, depth, approach, 0.0, dt);
                depth += approach * dt - 0.5 * n * dt * dt;
                approach -= n * dt;
                touched |= depth > 0.0;
                if touched && depth < 0.0 && approach < 0.0 {
                    break -approach;
                }
            };
            let closed = restitution_of_damping_ratio(zeta);
            assert!((rebound - closed).abs() < 0.005, "ζ {zeta}: {rebound} against {closed}");
        }
        assert!((restitution_of_damping_ratio(0.5) - 0.2983).abs() < 1e-3);
        assert!((restitution_of_damping_ratio(1.0) - (-2.0_f64).exp()).abs() < 1e-12);
        for e in [0.1, 0.3, 0.7, 0.95] {
            let z = damping_ratio_for_restitution(e);
            assert!((restitution_of_damping_ratio(z) - e).abs() < 1e-9, "e {e}");
        }
    }
}
