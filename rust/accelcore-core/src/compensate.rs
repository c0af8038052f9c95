//! Compensation: raw output to acceleration in g, sample by sample.
//!
//! The calibration model of each axis `a` is linear in its coefficients:
//!
//! ```text
//! v_a = sum_k O[a,k] B_k  +  sum_b ( sum_k G[3a+b,k] B_k ) g_b
//! ```
//!
//! where `B_k` are basis values of the sample (1, ΔT, ΔT², dT/dt, ... — built by
//! the caller, so new effects add basis columns, not code here), `O` holds the
//! offset coefficients and `G` those of the 3x3 gain matrix `M` (sensitivity on
//! the diagonal, misalignment and cross-axis sensitivity off it). Compensation
//! inverts it: `g = M⁻¹ (v − o)`, a 3x3 solve per sample by Gaussian elimination
//! with partial pivoting.

// Index loops over 3x3 systems read like the algebra they implement.
#![allow(clippy::needless_range_loop)]

use ndarray::{Array2, ArrayView2};

use crate::error::{Error, Result};

/// Turn raw readings into acceleration in g.
///
/// - `raw`: (n, 3) raw output in session units;
/// - `basis`: (n, K) basis values per sample;
/// - `offset_coefficients`: (3, K);
/// - `gain_coefficients`: (9, K), row `3a + b` is gain from gravity on `b` to output `a`.
///
/// A non-finite raw or basis value gives NaN for that sample. A gain matrix
/// that is singular at some sample is an error naming the sample.
pub fn compensate(
    raw: ArrayView2<'_, f64>,
    basis: ArrayView2<'_, f64>,
    offset_coefficients: ArrayView2<'_, f64>,
    gain_coefficients: ArrayView2<'_, f64>,
) -> Result<Array2<f64>> {
    let n = raw.nrows();
    let k = basis.ncols();
    if raw.ncols() != 3 {
        return Err(Error::Shape {
            what: "raw columns",
            expected: 3,
            got: raw.ncols(),
        });
    }
    if basis.nrows() != n {
        return Err(Error::Shape {
            what: "basis rows",
            expected: n,
            got: basis.nrows(),
        });
    }
    if offset_coefficients.dim() != (3, k) {
        return Err(Error::Shape {
            what: "offset_coefficients (3 x K) elements",
            expected: 3 * k,
            got: offset_coefficients.len(),
        });
    }
    if gain_coefficients.dim() != (9, k) {
        return Err(Error::Shape {
            what: "gain_coefficients (9 x K) elements",
            expected: 9 * k,
            got: gain_coefficients.len(),
        });
    }
    let mut out = Array2::<f64>::zeros((n, 3));
    for i in 0..n {
        let b = basis.row(i);
        let mut rhs = [0.0f64; 3];
        let mut m = [[0.0f64; 3]; 3];
        for a in 0..3 {
            let offset: f64 = offset_coefficients.row(a).dot(&b);
            rhs[a] = raw[[i, a]] - offset;
            for c in 0..3 {
                m[a][c] = gain_coefficients.row(3 * a + c).dot(&b);
            }
        }
        if !rhs.iter().all(|v| v.is_finite()) || !m.iter().flatten().all(|v| v.is_finite()) {
            out.row_mut(i).fill(f64::NAN);
            continue;
        }
        let g = solve3(m, rhs).ok_or(Error::NonFinite {
            what: "gain matrix (singular)",
            row: i as u64,
            column: 0,
        })?;
        for a in 0..3 {
            out[[i, a]] = g[a];
        }
    }
    Ok(out)
}

/// Solve a 3x3 system by Gaussian elimination with partial pivoting; None if singular.
fn solve3(mut m: [[f64; 3]; 3], mut r: [f64; 3]) -> Option<[f64; 3]> {
    let scale = m.iter().flatten().fold(0.0f64, |acc, v| acc.max(v.abs()));
    if scale == 0.0 {
        return None;
    }
    for col in 0..3 {
        let pivot = (col..3).max_by(|&p, &q| m[p][col].abs().total_cmp(&m[q][col].abs()))?;
        if m[pivot][col].abs() <= 1e-13 * scale {
            return None;
        }
        m.swap(col, pivot);
        r.swap(col, pivot);
        for row in col + 1..3 {
            let f = m[row][col] / m[col][col];
            for c in col..3 {
                m[row][c] -= f * m[col][c];
            }
            r[row] -= f * r[col];
        }
    }
    let mut x = [0.0f64; 3];
    for row in (0..3).rev() {
        let mut s = r[row];
        for c in row + 1..3 {
            s -= m[row][c] * x[c];
        }
        x[row] = s / m[row][row];
    }
    Some(x)
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::array;

    #[test]
    fn diagonal_model_inverts_offset_and_sensitivity() {
        // basis [1, dT]; offset 1.5 + 0.001 dT; sensitivity 0.3 (1 - 0.0001 dT) on each axis.
        let basis = array![[1.0, 0.0], [1.0, 10.0]];
        let offset = array![[1.5, 0.001], [1.5, 0.001], [1.5, 0.001]];
        let mut gain = Array2::<f64>::zeros((9, 2));
        for a in 0..3 {
            gain[[4 * a, 0]] = 0.3;
            gain[[4 * a, 1]] = -0.3e-4;
        }
        let g_true = [0.5, -1.0, 0.25];
        let mut raw = Array2::<f64>::zeros((2, 3));
        for i in 0..2 {
            let dt = basis[[i, 1]];
            for a in 0..3 {
                raw[[i, a]] = 1.5 + 0.001 * dt + 0.3 * (1.0 - 1e-4 * dt) * g_true[a];
            }
        }
        let g = compensate(raw.view(), basis.view(), offset.view(), gain.view()).unwrap();
        for i in 0..2 {
            for a in 0..3 {
                assert!((g[[i, a]] - g_true[a]).abs() < 1e-12, "{g:?}");
            }
        }
    }

    #[test]
    fn cross_axis_terms_are_inverted() {
        let basis = array![[1.0]];
        let offset = Array2::<f64>::zeros((3, 1));
        let gain = array![
            [1.0],
            [0.02],
            [0.0],
            [-0.01],
            [1.1],
            [0.0],
            [0.0],
            [0.03],
            [0.9]
        ];
        let g_true = [0.1, 0.2, 0.97];
        let mut raw = Array2::<f64>::zeros((1, 3));
        for a in 0..3 {
            raw[[0, a]] = (0..3).map(|b| gain[[3 * a + b, 0]] * g_true[b]).sum();
        }
        let g = compensate(raw.view(), basis.view(), offset.view(), gain.view()).unwrap();
        for a in 0..3 {
            assert!((g[[0, a]] - g_true[a]).abs() < 1e-14);
        }
    }

    #[test]
    fn singular_gain_is_an_error_naming_the_sample() {
        let basis = array![[1.0], [1.0]];
        let offset = Array2::<f64>::zeros((3, 1));
        let gain = Array2::<f64>::zeros((9, 1));
        let raw = Array2::<f64>::zeros((2, 3));
        let err = compensate(raw.view(), basis.view(), offset.view(), gain.view()).unwrap_err();
        assert!(matches!(err, Error::NonFinite { row: 0, .. }));
    }

    #[test]
    fn nan_input_gives_nan_row() {
        let basis = array![[1.0], [f64::NAN]];
        let offset = Array2::<f64>::zeros((3, 1));
        let mut gain = Array2::<f64>::zeros((9, 1));
        gain[[0, 0]] = 1.0;
        gain[[4, 0]] = 1.0;
        gain[[8, 0]] = 1.0;
        let raw = array![[0.1, 0.2, 0.3], [0.1, 0.2, 0.3]];
        let g = compensate(raw.view(), basis.view(), offset.view(), gain.view()).unwrap();
        assert!((g[[0, 2]] - 0.3).abs() < 1e-15);
        assert!(g.row(1).iter().all(|v| v.is_nan()));
    }

    #[test]
    fn shapes_are_checked() {
        let basis = Array2::<f64>::zeros((2, 1));
        let raw = Array2::<f64>::zeros((2, 2));
        let z = Array2::<f64>::zeros((3, 1));
        let g = Array2::<f64>::zeros((9, 1));
        assert!(matches!(
            compensate(raw.view(), basis.view(), z.view(), g.view()),
            Err(Error::Shape { .. })
        ));
    }
}
