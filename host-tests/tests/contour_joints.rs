//! The contour pipeline end to end on the Keops slave: an EFD cam contour stepped at
//! constant tangential speed, mapped through the delta IK into a C² joint spline, then
//! checked against the IK of every period's task reference (position) and against the
//! inverse Jacobian applied to the task velocity (q̇ = Jx⁻¹ ṗ, computed independently).

use host_tests::contours::{cam_at_10_mm_s, CUT_Z_M};
use kerf::kinematics::delta::{DeltaConfig, DeltaGeometry};
use kerf::kinematics::Vector3;
use kerf::trajectory::spline::{JointSpline, KnotTiming};

#[test]
fn cam_contour_joint_spline_matches_ik_and_inverse_jacobian() {
    const TS_S: f64 = 1e-3;
    const KNOT_EVERY: usize = 10;
    let delta = DeltaGeometry::<f64>::new(&DeltaConfig::SLAVE_KEOPS).unwrap();
    // From rest, 3 s along the contour, then a stop back to rest (the spline is clamped
    // to zero joint velocity at both ends).
    let references = cam_at_10_mm_s(TS_S, 3.0, KNOT_EVERY);
    let task = |k: usize| Vector3::new(references[k].position.x, references[k].position.y, CUT_Z_M);
    let knots: Vec<Vector3<f64>> = (0..references.len())
        .step_by(KNOT_EVERY)
        .map(task)
        .collect();
    let spline = JointSpline::<f64, 512>::fit(
        &knots,
        KnotTiming {
            period_s: TS_S,
            periods_per_knot: KNOT_EVERY as u32,
            first_period: 0,
        },
        Vector3::zeros(),
        Vector3::zeros(),
        |p| delta.inverse(&p),
    )
    .unwrap();
    // max |q⁗| from fourth differences of the IK samples at the 1 ms period.
    let joint = |k: usize| delta.inverse(&task(k)).unwrap();
    let q4_max = (0..references.len() - 4)
        .map(|k| {
            ((joint(k + 4) - 4.0 * joint(k + 3) + 6.0 * joint(k + 2) - 4.0 * joint(k + 1)
                + joint(k))
                / TS_S.powi(4))
            .amax()
        })
        .fold(0.0f64, f64::max);
    let (mut worst_q, mut worst_qd, mut peak_qd) = (0.0f64, 0.0f64, 0.0f64);
    let last_knot = (knots.len() - 1) * KNOT_EVERY;
    for (k, r) in references.iter().enumerate().take(last_knot + 1) {
        let reference = spline.evaluate(k as u64);
        let p = task(k);
        let q = delta.inverse(&p).unwrap();
        let p_dot = Vector3::new(r.velocity.x, r.velocity.y, 0.0);
        let qd = delta.jacobian_inverse(&q, &p).unwrap() * p_dot;
        worst_q = worst_q.max((reference.q - q).amax());
        worst_qd = worst_qd.max((reference.qd - qd).amax());
        peak_qd = peak_qd.max(qd.amax());
    }
    // Error bounds of the clamped C² cubic (Hall & Meyer, 1976): |s − q| ≤ 5/384 h⁴ max|q⁗|
    // and |s′ − q′| ≤ 1/24 h³ max|q⁗|, with h the knot spacing.
    let h = TS_S * KNOT_EVERY as f64;
    let (bound_q, bound_qd) = (5.0 / 384.0 * h.powi(4) * q4_max, h.powi(3) / 24.0 * q4_max);
    println!(
        "cam on the Keops slave at 10 mm/s, knots every {KNOT_EVERY} ms: |q − IK(p)| ≤ {:.3} µm (bound {:.3}), |q̇ − Jx⁻¹ṗ| ≤ {:.2e} m/s (bound {:.2e}; peak q̇ {:.2e} m/s)",
        worst_q * 1e6,
        bound_q * 1e6,
        worst_qd,
        bound_qd,
        peak_qd
    );
    assert!(worst_q <= bound_q, "{worst_q} > {bound_q}");
    assert!(worst_qd <= bound_qd, "{worst_qd} > {bound_qd}");
}
