//! The Gauss–Newton fit's building blocks: the time model's powers, the channel
//! model's basis and its derivative, and the small products the normal equations are
//! summed from.

use super::{BASIS, TERMS};
use nalgebra::{Const, Matrix, SVector, StorageMut};

/// 1, τ, τ², … up to [`TIME_MODEL_DEGREE`].
pub(super) fn powers(tau: f64) -> [f64; TERMS] {
    let mut p = [1.0; TERMS];
    let mut v = 1.0;
    for x in p.iter_mut() {
        *x = v;
        v *= tau;
    }
    p
}

/// The model's basis at φ: 1, sin φ, cos φ, sin 3φ, cos 3φ, sin 5φ, cos 5φ.
pub(super) fn basis(phi: f64) -> [f64; BASIS] {
    let (s1, c1) = (libm::sin(phi), libm::cos(phi));
    let (s3, c3) = (libm::sin(3.0 * phi), libm::cos(3.0 * phi));
    let (s5, c5) = (libm::sin(5.0 * phi), libm::cos(5.0 * phi));
    [1.0, s1, c1, s3, c3, s5, c5]
}

/// d basis / dφ.
pub(super) fn derivative(phi: f64) -> [f64; BASIS] {
    let (s1, c1) = (libm::sin(phi), libm::cos(phi));
    let (s3, c3) = (libm::sin(3.0 * phi), libm::cos(3.0 * phi));
    let (s5, c5) = (libm::sin(5.0 * phi), libm::cos(5.0 * phi));
    [0.0, c1, -s1, 3.0 * c3, -3.0 * s3, 5.0 * c5, -5.0 * s5]
}

/// `acc += x·yᵀ`, column by column (each element `acc_ij + y_j·x_i`, as the product
/// of the two and the sum would give it), the count opaque to the optimiser: the
/// fit runs once per calibration, in the link task, and its unrolled products cost
/// the board image some 1.6 KB of flash.
pub(super) fn add_outer<const R: usize, const C: usize, S>(
    acc: &mut Matrix<f64, Const<R>, Const<C>, S>,
    x: &SVector<f64, R>,
    y: &SVector<f64, C>,
) where
    S: StorageMut<f64, Const<R>, Const<C>>,
{
    let columns = core::hint::black_box(C).min(C);
    for (mut column, &y_j) in acc.column_iter_mut().zip(y.iter()).take(columns) {
        column.axpy(y_j, x, 1.0);
    }
}

/// Σ a_i b_i.
pub(super) fn dot<const M: usize>(a: &[f64; M], b: &[f64; M]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}
