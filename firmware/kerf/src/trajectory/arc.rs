//! Stepping a curve by arc length (T 3.2.2, A 4.2; docs/equations.md §12): the Newton
//! step on the arc-length integral and the parameter's time derivatives, shared by
//! the contour follower ([`super::tangential`]) and the constant-feed path
//! ([`super::feed`]).

use super::quadrature::gauss3;
use super::{lit, Float};

/// Δθ such that the arc from θ to θ + Δθ is `ds`: the second-order Taylor inverse
/// Δθ = Δs/σ − σθΔs²/(2σ³) as first guess, then `newton_steps` Newton corrections on g(Δθ) = ∫θ^θ+Δθ σ − Δs (g′ = σ), the integral by 3-point
/// Gauss–Legendre. `speed(u)` is σ at θ + u; `sigma` and `sigma_theta` are σ and dσ/dθ
/// at θ. Zero for ds ≤ 0 or σ ≤ 0 (no direction to move in). Shared by every
/// follower of a curve ([`super::tangential::CurveFollower`], [`super::feed`]).
pub(crate) fn arc_step<T: Float>(
    sigma: T,
    sigma_theta: T,
    ds: T,
    newton_steps: u8,
    speed: impl Fn(T) -> T,
) -> T {
    if ds <= T::ZERO || sigma <= T::ZERO {
        return T::ZERO;
    }
    let mut dth = ds / sigma - sigma_theta * ds * ds / (lit::<T>(2.0) * sigma * sigma * sigma);
    for _ in 0..newton_steps {
        let arc = gauss3(dth, &speed);
        let end_speed = speed(dth);
        if end_speed <= T::ZERO {
            break;
        }
        dth -= (arc - ds) / end_speed;
    }
    dth
}

/// θ̇, θ̈, θ⃛ from the arc-length speed v, acceleration a and jerk j (T 3.2.2 by the
/// chain rule, [`super::tangential`]:
/// θ′ = 1/σ, θ″ = −σθ/σ³, θ‴ = −σθθ/σ⁴ + 3σθ²/σ⁵), given σ > 0, σθ and σθθ.
pub(crate) fn parameter_rates<T: Float>(
    sigma: T,
    sigma_theta: T,
    sigma_theta_theta: T,
    v: T,
    a: T,
    j: T,
) -> (T, T, T) {
    let inv = T::one() / sigma;
    let (i2, i3) = (inv * inv, inv * inv * inv);
    let t1 = inv;
    let t2 = -sigma_theta * i3;
    let t3 = -sigma_theta_theta * i2 * i2 + lit::<T>(3.0) * sigma_theta * sigma_theta * i3 * i2;
    (
        t1 * v,
        t2 * v * v + t1 * a,
        t3 * v * v * v + lit::<T>(3.0) * t2 * v * a + t1 * j,
    )
}
