//! Dense symmetric positive-definite linear algebra for the mode distributions: the Cholesky
//! factor draws correlated Gaussians (`engine::object`) and validates covariances (`preset`);
//! the solve serves the least-squares fits (`fit`). Matrices are small (≤ 3·MAX_MODES rows) and
//! factored off the audio thread, so plain row-major `Vec`s are enough.

/// Solves `L·Lᵀ·x = b` for `x` given the Cholesky factor `l` of [`cholesky`].
pub fn cholesky_solve(l: &[Vec<f64>], b: &[f64]) -> Vec<f64> {
    let p = b.len();
    let mut z = vec![0.0; p];
    for i in 0..p {
        let mut s = b[i];
        for k in 0..i {
            s -= l[i][k] * z[k];
        }
        z[i] = s / l[i][i];
    }
    let mut x = vec![0.0; p];
    for i in (0..p).rev() {
        let mut s = z[i];
        for k in i + 1..p {
            s -= l[k][i] * x[k];
        }
        x[i] = s / l[i][i];
    }
    x
}

/// Lower-triangular Cholesky factor of a symmetric positive-definite matrix, or `None` if the
/// matrix is not positive definite. Row-major `n × n`.
pub fn cholesky(a: &[Vec<f64>]) -> Option<Vec<Vec<f64>>> {
    let n = a.len();
    let mut l = vec![vec![0.0; n]; n];
    for i in 0..n {
        for j in 0..=i {
            let mut sum = a[i][j];
            for k in 0..j {
                sum -= l[i][k] * l[j][k];
            }
            if i == j {
                if !(sum > 0.0) || !sum.is_finite() {
                    return None;
                }
                l[i][j] = sum.sqrt();
            } else {
                l[i][j] = sum / l[j][j];
            }
        }
    }
    Some(l)
}
