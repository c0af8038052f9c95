//! Tests of `LeastSquares`: exact recovery, accuracy against a double-double
//! reference, weights, merge and chunking invariance, rank, errors.

use accelcore_core::{Error, LeastSquares, LstsqSolution};
use ndarray::{Array2, ArrayView2, Axis, Slice};
use proptest::prelude::*;

const EPS: f64 = f64::EPSILON;

// ---------------------------------------------------------------- helpers

/// Rows `r` of `x` (ndarray's `s!` expands to `allow(unsafe_code)`, which the
/// workspace `forbid` rejects).
fn rows(x: &Array2<f64>, r: impl Into<Slice>) -> ArrayView2<'_, f64> {
    x.slice_axis(Axis(0), r.into())
}

/// xorshift64*: deterministic pseudo-random numbers without a dependency.
struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    /// Uniform in [0, 1).
    fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1_u64 << 53) as f64
    }
    /// Approximately standard normal (sum of 12 uniforms).
    fn normal(&mut self) -> f64 {
        (0..12).map(|_| self.uniform()).sum::<f64>() - 6.0
    }
}

fn names(list: &[&str]) -> Option<Vec<String>> {
    let owned: Vec<String> = list.iter().map(|s| (*s).to_string()).collect();
    (!owned.is_empty()).then_some(owned)
}

fn fit(x: &Array2<f64>, y: &[f64], w: Option<&[f64]>) -> LstsqSolution {
    let mut ls = LeastSquares::new(x.ncols(), None).unwrap();
    ls.push(x.view(), y, w).unwrap();
    ls.finish().unwrap()
}

/// Temperatures on a 1/8 °C grid in [-40, 125]: every power up to 5 is exact in f64.
fn temperatures(n: usize, rng: &mut Rng) -> Vec<f64> {
    (0..n)
        .map(|_| (-320.0 + (rng.uniform() * 1321.0).floor()) / 8.0)
        .collect()
}

fn poly_design(t: &[f64], degree: usize) -> Array2<f64> {
    Array2::from_shape_fn((t.len(), degree + 1), |(i, k)| t[i].powi(k as i32))
}

fn column_norms(x: &Array2<f64>) -> Vec<f64> {
    x.columns()
        .into_iter()
        .map(|c| c.iter().map(|v| v * v).sum::<f64>().sqrt())
        .collect()
}

/// `||D (a - b)|| / ||D b||`, D = diag(column norms): the error measure that
/// backward-stable QR bounds by ~ kappa_scaled * eps.
fn scaled_rel_err(a: &[f64], b: &[f64], norms: &[f64]) -> f64 {
    let num: f64 = a
        .iter()
        .zip(b)
        .zip(norms)
        .map(|((a, b), d)| (d * (a - b)).powi(2))
        .sum();
    let den: f64 = b.iter().zip(norms).map(|(b, d)| (d * b).powi(2)).sum();
    (num / den).sqrt()
}

fn max_componentwise_rel_err(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(a, b)| ((a - b) / b).abs())
        .fold(0.0, f64::max)
}

/// Two fits agree within what rounding in a backward-stable solver allows.
fn assert_fits_close(a: &LstsqSolution, b: &LstsqSolution, norms: &[f64], factor: f64) {
    let k = b.condition_number_scaled;
    let scale: f64 = b
        .coefficients
        .iter()
        .zip(norms)
        .map(|(c, d)| (c * d).powi(2))
        .sum::<f64>()
        .sqrt()
        + k * b.residual_sum_squares.sqrt();
    for ((ca, cb), d) in a.coefficients.iter().zip(&b.coefficients).zip(norms) {
        let tol = factor * EPS * k * scale;
        assert!(
            (d * (ca - cb)).abs() <= tol,
            "coefficients {:?} vs {:?} (tol {tol:e})",
            a.coefficients,
            b.coefficients
        );
    }
    let rss_tol = factor * EPS * (b.residual_sum_squares + scale * scale);
    assert!((a.residual_sum_squares - b.residual_sum_squares).abs() <= rss_tol);
    assert_eq!(a.n_rows, b.n_rows);
    assert_eq!(a.dof, b.dof);
}

/// The property tests' configuration: 128 cases; integration tests have no lib.rs
/// next to them to persist failures beside.
fn config() -> ProptestConfig {
    ProptestConfig {
        cases: 128,
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

// ------------------------------------------------- double-double reference

/// Unevaluated sum hi + lo, ~106-bit precision.
#[derive(Clone, Copy, Debug)]
struct Dd(f64, f64);

fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    (s, (a - (s - bb)) + (b - bb))
}

fn quick_two_sum(a: f64, b: f64) -> Dd {
    let s = a + b;
    Dd(s, b - (s - a))
}

impl Dd {
    fn from(v: f64) -> Self {
        Dd(v, 0.0)
    }
    fn add(self, o: Dd) -> Dd {
        let (s, e) = two_sum(self.0, o.0);
        let (t, f) = two_sum(self.1, o.1);
        let r = quick_two_sum(s, e + t);
        quick_two_sum(r.0, r.1 + f)
    }
    fn neg(self) -> Dd {
        Dd(-self.0, -self.1)
    }
    fn sub(self, o: Dd) -> Dd {
        self.add(o.neg())
    }
    fn mul(self, o: Dd) -> Dd {
        let p = self.0 * o.0;
        let e = self.0.mul_add(o.0, -p) + (self.0 * o.1 + self.1 * o.0);
        quick_two_sum(p, e)
    }
    fn div(self, o: Dd) -> Dd {
        let q1 = self.0 / o.0;
        let r = self.sub(o.mul(Dd::from(q1)));
        let q2 = r.0 / o.0;
        let r = r.sub(o.mul(Dd::from(q2)));
        let q3 = r.0 / o.0;
        quick_two_sum(q1, q2).add(Dd::from(q3))
    }
}

/// Weighted least squares in double-double: normal equations of the
/// power-of-two column-equilibrated design, Gaussian elimination with partial
/// pivoting. Error ~ kappa_scaled^2 * 1e-32, far below f64 rounding here.
fn reference_lstsq(x: &Array2<f64>, y: &[f64]) -> Vec<f64> {
    let p = x.ncols();
    let scale: Vec<f64> = column_norms(x)
        .iter()
        .map(|d| 2f64.powi(-(d.log2().round() as i32)))
        .collect();
    let mut a = vec![vec![Dd::from(0.0); p + 1]; p];
    for (row, &yi) in x.rows().into_iter().zip(y) {
        let xs: Vec<Dd> = row
            .iter()
            .zip(&scale)
            .map(|(v, s)| Dd::from(v * s))
            .collect();
        for i in 0..p {
            for j in 0..p {
                a[i][j] = a[i][j].add(xs[i].mul(xs[j]));
            }
            a[i][p] = a[i][p].add(xs[i].mul(Dd::from(yi)));
        }
    }
    for col in 0..p {
        let piv = (col..p)
            .max_by(|&i, &j| a[i][col].0.abs().total_cmp(&a[j][col].0.abs()))
            .unwrap();
        a.swap(col, piv);
        let pivot = a[col].clone();
        for row in &mut a[col + 1..] {
            let f = row[col].div(pivot[col]);
            for (v, pv) in row[col..].iter_mut().zip(&pivot[col..]) {
                *v = v.sub(f.mul(*pv));
            }
        }
    }
    let mut u = vec![Dd::from(0.0); p];
    for i in (0..p).rev() {
        let mut acc = a[i][p];
        for j in i + 1..p {
            acc = acc.sub(a[i][j].mul(u[j]));
        }
        u[i] = acc.div(a[i][i]);
    }
    u.iter().zip(&scale).map(|(u, s)| (u.0 + u.1) * s).collect()
}

// ------------------------------------------------------------ exactness

#[test]
fn exact_line() {
    let t: Vec<f64> = (0..11).map(f64::from).collect();
    let x = poly_design(&t, 1);
    let y: Vec<f64> = t.iter().map(|t| 1.0 + 2.0 * t).collect();
    let sol = fit(&x, &y, None);
    approx::assert_relative_eq!(sol.coefficients[0], 1.0, max_relative = 1e-14);
    approx::assert_relative_eq!(sol.coefficients[1], 2.0, max_relative = 1e-14);
    assert!(sol.residual_sum_squares < 1e-24);
    assert_eq!(sol.n_rows, 11);
    assert_eq!(sol.dof, 9);
    assert_eq!(sol.column_names, vec!["x0", "x1"]);
}

/// Realistic thermal polynomial of an accelerometer axis (g per °C^k).
const BETA5: [f64; 6] = [0.02, 1.0e-4, -3.0e-6, 2.0e-8, -5.0e-11, 1.0e-13];

#[test]
fn exact_degree5_raw_celsius() {
    let mut rng = Rng(0x1234_5678_9abc_def1);
    let t = temperatures(5000, &mut rng);
    let x = poly_design(&t, 5);
    // Response evaluated in double-double, rounded once.
    let y: Vec<f64> = t
        .iter()
        .map(|&t| {
            let mut acc = Dd::from(0.0);
            for (k, b) in BETA5.iter().enumerate() {
                acc = acc.add(Dd::from(*b).mul(Dd::from(t.powi(k as i32))));
            }
            acc.0 + acc.1
        })
        .collect();
    let sol = fit(&x, &y, None);
    let norms = column_norms(&x);
    let k_s = sol.condition_number_scaled;
    let scaled = scaled_rel_err(&sol.coefficients, &BETA5, &norms);
    let comp = max_componentwise_rel_err(&sol.coefficients, &BETA5);
    eprintln!(
        "degree 5 exact: kappa = {:.3e}, kappa_scaled = {:.3e}, scaled rel err = {scaled:.3e}, \
         max componentwise rel err = {comp:.3e}, (kappa_scaled*eps = {:.3e})",
        sol.condition_number,
        k_s,
        k_s * EPS
    );
    assert!(
        k_s > 1e2 && sol.condition_number > 1e9,
        "test should be ill-conditioned"
    );
    assert!(scaled <= 10.0 * k_s * EPS, "scaled error {scaled:e}");
    assert!(comp <= 100.0 * k_s * EPS, "componentwise error {comp:e}");
}

#[test]
fn degree5_noisy_matches_double_double_reference() {
    let mut rng = Rng(0x0dd_ba11_cafe_f00d);
    let t = temperatures(20_000, &mut rng);
    let x = poly_design(&t, 5);
    let y: Vec<f64> = t
        .iter()
        .map(|&t| {
            BETA5
                .iter()
                .enumerate()
                .map(|(k, b)| b * t.powi(k as i32))
                .sum::<f64>()
                + 1e-3 * rng.normal()
        })
        .collect();
    let reference = reference_lstsq(&x, &y);
    let norms = column_norms(&x);

    let one = fit(&x, &y, None);
    // Reverse order, and four merged pieces.
    let xr = x.slice_axis(Axis(0), Slice::new(0, None, -1)).to_owned();
    let yr: Vec<f64> = y.iter().rev().copied().collect();
    let rev = fit(&xr, &yr, None);
    let mut merged = LeastSquares::new(6, None).unwrap();
    for part in 0..4 {
        let r = part * 5000..(part + 1) * 5000;
        let mut ls = LeastSquares::new(6, None).unwrap();
        ls.push(rows(&x, r.clone()), &y[r], None).unwrap();
        merged.merge(&ls).unwrap();
    }
    let merged = merged.finish().unwrap();

    let k_s = one.condition_number_scaled;
    for (label, sol) in [("one pass", &one), ("reversed", &rev), ("merged", &merged)] {
        let scaled = scaled_rel_err(&sol.coefficients, &reference, &norms);
        let comp = max_componentwise_rel_err(&sol.coefficients, &reference);
        eprintln!(
            "degree 5 noisy, {label}: kappa = {:.3e}, kappa_scaled = {k_s:.3e}, \
             scaled rel err = {scaled:.3e} ({:.2} kappa_scaled*eps), componentwise = {comp:.3e}",
            sol.condition_number,
            scaled / (k_s * EPS)
        );
        assert!(
            scaled <= 10.0 * k_s * EPS,
            "{label}: scaled error {scaled:e}"
        );
        assert!(
            comp <= 100.0 * k_s * EPS,
            "{label}: componentwise error {comp:e}"
        );
    }
}

// -------------------------------------------------------------- weights

#[test]
fn weight_two_equals_repeated_row() {
    let mut rng = Rng(7);
    let n = 40;
    let x = Array2::from_shape_fn((n, 3), |(i, j)| {
        if j == 0 {
            1.0
        } else {
            rng.normal() + i as f64 * 0.0
        }
    });
    let y: Vec<f64> = (0..n)
        .map(|i| x[[i, 1]] - 2.0 * x[[i, 2]] + 0.1 * rng.normal())
        .collect();
    let mut w = vec![1.0; n];
    let mut xs = Vec::new();
    let mut ys = Vec::new();
    for i in 0..n {
        let reps = if i % 3 == 0 { 2 } else { 1 };
        w[i] = f64::from(reps);
        for _ in 0..reps {
            xs.extend(x.row(i).iter().copied());
            ys.push(y[i]);
        }
    }
    let xrep = Array2::from_shape_vec((ys.len(), 3), xs).unwrap();
    let weighted = fit(&x, &y, Some(&w));
    let repeated = fit(&xrep, &ys, None);
    for (a, b) in weighted.coefficients.iter().zip(&repeated.coefficients) {
        approx::assert_relative_eq!(a, b, max_relative = 1e-12);
    }
    approx::assert_relative_eq!(
        weighted.residual_sum_squares,
        repeated.residual_sum_squares,
        max_relative = 1e-12
    );
    // Counters count rows, not weights.
    assert_eq!(weighted.n_rows, n as u64);
    assert_eq!(repeated.n_rows, ys.len() as u64);
}

#[test]
fn zero_weight_row_is_ignored() {
    let mut rng = Rng(11);
    let x = Array2::from_shape_fn((20, 2), |(_, j)| if j == 0 { 1.0 } else { rng.normal() });
    let y: Vec<f64> = (0..20).map(|i| 3.0 + x[[i, 1]] + rng.normal()).collect();
    let mut xw = x.clone();
    xw[[7, 1]] = 1e30;
    let mut yw = y.clone();
    yw[7] = -1e30;
    let mut w = vec![1.0; 20];
    w[7] = 0.0;

    let mut with_zero = LeastSquares::new(2, None).unwrap();
    with_zero.push(xw.view(), &yw, Some(&w)).unwrap();
    assert_eq!(with_zero.n_rows(), 19);

    let keep: Vec<usize> = (0..20).filter(|&i| i != 7).collect();
    let x19 = x.select(ndarray::Axis(0), &keep);
    let y19: Vec<f64> = keep.iter().map(|&i| y[i]).collect();
    let without = fit(&x19, &y19, None);
    // Identical sequence of rotations: bitwise equal.
    assert_eq!(
        format!("{:?}", with_zero.finish()),
        format!("{:?}", Ok::<_, Error>(without))
    );
}

#[test]
fn only_zero_weights_is_empty() {
    let mut ls = LeastSquares::new(2, None).unwrap();
    let x = Array2::from_elem((3, 2), 1.0);
    ls.push(x.view(), &[1.0, 2.0, 3.0], Some(&[0.0, 0.0, 0.0]))
        .unwrap();
    assert_eq!(ls.n_rows(), 0);
    assert!(matches!(ls.finish(), Err(Error::Empty { .. })));
}

// --------------------------------------------------- merge and chunking

fn random_problem(n: usize, p: usize, seed: u64) -> (Array2<f64>, Vec<f64>, Vec<f64>) {
    let mut rng = Rng(seed | 1);
    let x = Array2::from_shape_fn(
        (n, p),
        |(_, j)| if j == 0 { 1.0 } else { 10.0 * rng.normal() },
    );
    let y: Vec<f64> = (0..n)
        .map(|i| (0..p).map(|j| x[[i, j]] * (j as f64 - 1.5)).sum::<f64>() + rng.normal())
        .collect();
    let w: Vec<f64> = (0..n).map(|_| rng.uniform() * 3.0).collect();
    (x, y, w)
}

#[test]
fn merge_equals_single_pass() {
    let (x, y, w) = random_problem(300, 5, 42);
    let one = fit(&x, &y, Some(&w));
    let mut a = LeastSquares::new(5, None).unwrap();
    let mut b = LeastSquares::new(5, None).unwrap();
    a.push(rows(&x, ..123), &y[..123], Some(&w[..123])).unwrap();
    b.push(rows(&x, 123..), &y[123..], Some(&w[123..])).unwrap();
    a.merge(&b).unwrap();
    assert_eq!(a.n_rows(), 300);
    let norms = column_norms(&x);
    assert_fits_close(&a.finish().unwrap(), &one, &norms, 64.0);
}

#[test]
fn merge_with_empty_and_into_empty() {
    let (x, y, _) = random_problem(50, 3, 5);
    let one = fit(&x, &y, None);
    let mut empty = LeastSquares::new(3, None).unwrap();
    let mut full = LeastSquares::new(3, None).unwrap();
    full.push(x.view(), &y, None).unwrap();
    empty.merge(&full).unwrap();
    full.merge(&LeastSquares::new(3, None).unwrap()).unwrap();
    let norms = column_norms(&x);
    assert_fits_close(&empty.finish().unwrap(), &one, &norms, 16.0);
    assert_eq!(format!("{:?}", full.finish().unwrap()), format!("{one:?}"));
}

#[test]
fn merge_is_associative() {
    let (x, y, w) = random_problem(240, 4, 99);
    let part = |r: std::ops::Range<usize>| {
        let mut ls = LeastSquares::new(4, None).unwrap();
        ls.push(rows(&x, r.clone()), &y[r.clone()], Some(&w[r]))
            .unwrap();
        ls
    };
    let (a, b, c) = (part(0..70), part(70..200), part(200..240));
    let mut left = a.clone();
    left.merge(&b).unwrap();
    left.merge(&c).unwrap();
    let mut bc = b.clone();
    bc.merge(&c).unwrap();
    let mut right = a.clone();
    right.merge(&bc).unwrap();
    let norms = column_norms(&x);
    assert_fits_close(
        &left.finish().unwrap(),
        &right.finish().unwrap(),
        &norms,
        64.0,
    );
}

#[test]
fn merge_incompatible() {
    let mut a = LeastSquares::new(2, None).unwrap();
    let b = LeastSquares::new(3, None).unwrap();
    assert!(matches!(a.merge(&b), Err(Error::Incompatible { .. })));
    let c = LeastSquares::new(2, names(&["a", "b"])).unwrap();
    assert!(matches!(a.merge(&c), Err(Error::Incompatible { .. })));
}

#[test]
fn strided_design_equals_contiguous() {
    let (x, y, w) = random_problem(64, 4, 3);
    let one = fit(&x, &y, Some(&w));
    // Transposed storage (column-major view).
    let xt = x.t().to_owned();
    let mut ls = LeastSquares::new(4, None).unwrap();
    ls.push(xt.t(), &y, Some(&w)).unwrap();
    assert_eq!(format!("{:?}", ls.finish().unwrap()), format!("{one:?}"));
    // Every other row of a bigger array.
    let mut big = Array2::zeros((128, 4));
    big.slice_axis_mut(Axis(0), Slice::new(0, None, 2))
        .assign(&x);
    let mut ls = LeastSquares::new(4, None).unwrap();
    ls.push(
        big.slice_axis(Axis(0), Slice::new(0, None, 2)),
        &y,
        Some(&w),
    )
    .unwrap();
    assert_eq!(format!("{:?}", ls.finish().unwrap()), format!("{one:?}"));
}

proptest! {
    #![proptest_config(config())]

    /// Any chunking (empty chunks included) gives bitwise the same result.
    #[test]
    fn chunking_invariance(
        p in 1_usize..6,
        n in 0_usize..150,
        seed in any::<u64>(),
        cuts in prop::collection::vec(0.0_f64..=1.0, 0..8),
        use_weights in any::<bool>(),
    ) {
        let (x, y, mut w) = random_problem(n, p, seed);
        for (i, wi) in w.iter_mut().enumerate() {
            if i % 5 == 0 { *wi = 0.0; }
        }
        let w = use_weights.then_some(w);
        let mut one = LeastSquares::new(p, None).unwrap();
        one.push(x.view(), &y, w.as_deref()).unwrap();

        let mut points: Vec<usize> = cuts.iter().map(|c| (c * n as f64) as usize).collect();
        points.push(0);
        points.push(n);
        points.sort_unstable();
        let mut chunked = LeastSquares::new(p, None).unwrap();
        for win in points.windows(2) {
            let r = win[0]..win[1];
            chunked
                .push(rows(&x, r.clone()), &y[r.clone()], w.as_deref().map(|w| &w[r]))
                .unwrap();
        }
        prop_assert_eq!(one.n_rows(), chunked.n_rows());
        prop_assert_eq!(format!("{:?}", one.finish()), format!("{:?}", chunked.finish()));
    }

    /// Splitting into accumulators and merging them equals one pass.
    #[test]
    fn merge_invariance(
        p in 1_usize..6,
        extra in 5_usize..60,
        seed in any::<u64>(),
        cuts in prop::collection::vec(0.0_f64..=1.0, 0..5),
    ) {
        let n = 3 * p + extra;
        let (x, y, w) = random_problem(n, p, seed);
        let one = fit(&x, &y, Some(&w));
        prop_assume!(one.condition_number_scaled < 1e6);
        let mut points: Vec<usize> = cuts.iter().map(|c| (c * n as f64) as usize).collect();
        points.push(0);
        points.push(n);
        points.sort_unstable();
        let mut merged = LeastSquares::new(p, None).unwrap();
        for win in points.windows(2) {
            let r = win[0]..win[1];
            let mut part = LeastSquares::new(p, None).unwrap();
            part.push(rows(&x, r.clone()), &y[r.clone()], Some(&w[r])).unwrap();
            merged.merge(&part).unwrap();
        }
        assert_fits_close(&merged.finish().unwrap(), &one, &column_norms(&x), 64.0);
    }
}

// ----------------------------------------------------------------- rank

fn rank_error(x: &Array2<f64>, col_names: &[&str]) -> Vec<String> {
    let mut rng = Rng(5);
    let y: Vec<f64> = (0..x.nrows()).map(|_| rng.normal()).collect();
    let mut ls = LeastSquares::new(x.ncols(), names(col_names)).unwrap();
    ls.push(x.view(), &y, None).unwrap();
    match ls.finish() {
        Err(Error::RankDeficient { columns }) => columns,
        other => panic!("expected RankDeficient, got {other:?}"),
    }
}

#[test]
fn rank_deficient_duplicate_column() {
    let mut rng = Rng(21);
    let t: Vec<f64> = (0..50).map(|_| 100.0 * rng.uniform()).collect();
    let x = Array2::from_shape_fn((50, 3), |(i, j)| if j == 0 { 1.0 } else { t[i] });
    assert_eq!(rank_error(&x, &["one", "t", "t_again"]), vec!["t_again"]);
}

#[test]
fn rank_deficient_sum_of_two_columns() {
    let mut rng = Rng(22);
    let x = Array2::from_shape_fn((60, 4), |_| rng.normal());
    let mut x = x;
    for i in 0..60 {
        x[[i, 2]] = x[[i, 0]] + x[[i, 1]];
    }
    assert_eq!(
        rank_error(&x, &["a", "b", "a_plus_b", "c"]),
        vec!["a_plus_b"]
    );
}

#[test]
fn rank_deficient_zero_column() {
    let mut rng = Rng(23);
    let x = Array2::from_shape_fn((30, 3), |(_, j)| if j == 1 { 0.0 } else { rng.normal() });
    assert_eq!(rank_error(&x, &["a", "zero", "b"]), vec!["zero"]);
    // A zero column first.
    let x0 = Array2::from_shape_fn((30, 2), |(i, j)| if j == 0 { 0.0 } else { x[[i, 0]] });
    assert_eq!(rank_error(&x0, &["zero", "a"]), vec!["zero"]);
}

#[test]
fn rank_deficient_names_every_column() {
    let mut rng = Rng(24);
    let a: Vec<f64> = (0..80).map(|_| rng.normal()).collect();
    let b: Vec<f64> = (0..80).map(|_| rng.normal()).collect();
    let x = Array2::from_shape_fn((80, 6), |(i, j)| match j {
        0 | 1 => a[i],
        2 => 0.0,
        3 => b[i],
        4 => 2.0 * a[i] - 3.0 * b[i],
        _ => rng.normal(),
    });
    assert_eq!(
        rank_error(&x, &["a", "a2", "zero", "b", "comb", "c"]),
        vec!["a2", "zero", "comb"]
    );
}

#[test]
fn rank_deficient_only_nonzero_weight_rows_count() {
    // Distinct temperatures only on zero-weight rows: slope not identifiable.
    let x = Array2::from_shape_fn((4, 2), |(i, j)| if j == 0 { 1.0 } else { i as f64 });
    let mut ls = LeastSquares::new(2, names(&["offset", "slope"])).unwrap();
    ls.push(x.view(), &[1.0, 2.0, 3.0, 4.0], Some(&[1.0, 0.0, 0.0, 0.0]))
        .unwrap();
    let x2 = Array2::from_shape_fn((1, 2), |(_, j)| if j == 0 { 1.0 } else { 0.0 });
    ls.push(x2.view(), &[1.5], None).unwrap();
    assert_eq!(ls.n_rows(), 2);
    assert_eq!(
        ls.finish(),
        Err(Error::RankDeficient {
            columns: vec!["slope".to_string()]
        })
    );
}

#[test]
fn row_by_row_equals_one_chunk_bitwise() {
    let (x, y, w) = random_problem(101, 5, 31);
    let one = fit(&x, &y, Some(&w));
    let mut ls = LeastSquares::new(5, None).unwrap();
    for i in 0..101 {
        ls.push(rows(&x, i..=i), &y[i..=i], Some(&w[i..=i]))
            .unwrap();
    }
    assert_eq!(format!("{:?}", ls.finish().unwrap()), format!("{one:?}"));
}

#[test]
fn extreme_scales_use_the_hypot_fallback() {
    // Column norms whose squares overflow (1e200) or underflow (1e-200).
    let (x, y, _) = random_problem(50, 3, 13);
    let base = fit(&x, &y, None);
    for scale in [1e200, 1e-200] {
        let mut xs = x.clone();
        xs.column_mut(1).mapv_inplace(|v| v * scale);
        let sol = fit(&xs, &y, None);
        approx::assert_relative_eq!(
            sol.coefficients[0],
            base.coefficients[0],
            max_relative = 1e-12
        );
        approx::assert_relative_eq!(
            sol.coefficients[1] * scale,
            base.coefficients[1],
            max_relative = 1e-12
        );
        approx::assert_relative_eq!(
            sol.residual_sum_squares,
            base.residual_sum_squares,
            max_relative = 1e-12
        );
        approx::assert_relative_eq!(
            sol.condition_number_scaled,
            base.condition_number_scaled,
            max_relative = 1e-10
        );
    }
}

#[test]
fn overflowing_column_norm_is_reported() {
    let x = Array2::from_shape_vec((3, 1), vec![1.5e308, 1.5e308, 1.0]).unwrap();
    let mut ls = LeastSquares::new(1, None).unwrap();
    ls.push(x.view(), &[1.0, 1.0, 1.0], None).unwrap();
    assert!(matches!(
        ls.finish(),
        Err(Error::NonFinite {
            what: "accumulated state",
            ..
        })
    ));
}

// --------------------------------------------------------------- errors

#[test]
fn finish_on_empty() {
    let ls = LeastSquares::new(3, None).unwrap();
    assert_eq!(ls.n_rows(), 0);
    assert!(matches!(ls.finish(), Err(Error::Empty { .. })));
    let mut ls = LeastSquares::new(3, None).unwrap();
    ls.push(Array2::zeros((0, 3)).view(), &[], None).unwrap();
    assert!(matches!(ls.finish(), Err(Error::Empty { .. })));
}

#[test]
fn fewer_rows_than_columns() {
    let x = Array2::from_shape_fn((2, 3), |(i, j)| (i + j) as f64);
    let mut ls = LeastSquares::new(3, None).unwrap();
    ls.push(x.view(), &[1.0, 2.0], None).unwrap();
    assert_eq!(
        ls.finish(),
        Err(Error::InsufficientData {
            what: "least squares".to_string(),
            needed: 3,
            have: 2
        })
    );
}

#[test]
fn nan_reports_global_row_and_leaves_state_unchanged() {
    let (x, y, _) = random_problem(20, 3, 8);
    let mut ls = LeastSquares::new(3, None).unwrap();
    let mut w = vec![1.0; 10];
    w[4] = 0.0; // zero-weight rows still count in the global row index
    ls.push(rows(&x, ..10), &y[..10], Some(&w)).unwrap();
    let before = format!("{:?}", ls.finish());

    let mut bad = rows(&x, 10..).to_owned();
    bad[[3, 1]] = f64::NAN;
    bad[[5, 0]] = f64::INFINITY; // later error must not be the one reported
    assert_eq!(
        ls.push(bad.view(), &y[10..], None),
        Err(Error::NonFinite {
            what: "design",
            row: 13,
            column: 1
        })
    );
    assert_eq!(ls.n_rows(), 9);
    assert_eq!(format!("{:?}", ls.finish()), before);

    let mut ybad = y[10..].to_vec();
    ybad[2] = f64::NEG_INFINITY;
    assert_eq!(
        ls.push(rows(&x, 10..), &ybad, None),
        Err(Error::NonFinite {
            what: "response",
            row: 12,
            column: 0
        })
    );
    let mut wbad = vec![1.0; 10];
    wbad[9] = f64::NAN;
    assert_eq!(
        ls.push(rows(&x, 10..), &y[10..], Some(&wbad)),
        Err(Error::NonFinite {
            what: "weights",
            row: 19,
            column: 0
        })
    );
    assert_eq!(format!("{:?}", ls.finish()), before);
}

#[test]
fn nan_in_zero_weight_row_is_rejected() {
    let mut ls = LeastSquares::new(1, None).unwrap();
    let x = Array2::from_shape_vec((2, 1), vec![1.0, f64::NAN]).unwrap();
    assert_eq!(
        ls.push(x.view(), &[1.0, 1.0], Some(&[1.0, 0.0])),
        Err(Error::NonFinite {
            what: "design",
            row: 1,
            column: 0
        })
    );
}

#[test]
fn negative_weight() {
    let mut ls = LeastSquares::new(2, None).unwrap();
    let x = Array2::from_elem((9, 2), 1.0);
    let mut w = vec![1.0; 9];
    w[7] = -0.5;
    match ls.push(x.view(), &[0.0; 9], Some(&w)) {
        Err(Error::InvalidParameter {
            name: "weights",
            reason,
        }) => {
            assert!(reason.contains("row 7"), "{reason}");
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(ls.n_rows(), 0);
}

#[test]
fn shape_errors() {
    let mut ls = LeastSquares::new(2, None).unwrap();
    let x = Array2::zeros((4, 3));
    assert_eq!(
        ls.push(x.view(), &[0.0; 4], None),
        Err(Error::Shape {
            what: "design columns",
            expected: 2,
            got: 3
        })
    );
    let x = Array2::zeros((4, 2));
    assert_eq!(
        ls.push(x.view(), &[0.0; 3], None),
        Err(Error::Shape {
            what: "response",
            expected: 4,
            got: 3
        })
    );
    assert_eq!(
        ls.push(x.view(), &[0.0; 4], Some(&[1.0; 5])),
        Err(Error::Shape {
            what: "weights",
            expected: 4,
            got: 5
        })
    );
}

#[test]
fn constructor_validation() {
    assert!(matches!(
        LeastSquares::new(0, None),
        Err(Error::InvalidParameter {
            name: "n_columns",
            ..
        })
    ));
    assert!(matches!(
        LeastSquares::new(65, None),
        Err(Error::InvalidParameter {
            name: "n_columns",
            ..
        })
    ));
    assert!(LeastSquares::new(64, None).is_ok());
    assert!(matches!(
        LeastSquares::new(2, names(&["a"])),
        Err(Error::InvalidParameter {
            name: "column_names",
            ..
        })
    ));
    assert!(matches!(
        LeastSquares::new(3, names(&["a", "b", "a"])),
        Err(Error::InvalidParameter {
            name: "column_names",
            ..
        })
    ));
    let ls = LeastSquares::new(3, names(&["offset", "t", "t2"])).unwrap();
    assert_eq!(ls.n_columns(), 3);
    assert_eq!(ls.column_names(), ["offset", "t", "t2"]);
    assert_eq!(
        LeastSquares::new(2, None).unwrap().column_names(),
        ["x0", "x1"]
    );
}

// ------------------------------------------------ covariance, condition

/// Gauss-Jordan inverse with partial pivoting.
fn invert(mut a: Vec<Vec<f64>>) -> Vec<Vec<f64>> {
    let p = a.len();
    let mut inv: Vec<Vec<f64>> = (0..p)
        .map(|i| (0..p).map(|j| f64::from(u8::from(i == j))).collect())
        .collect();
    for c in 0..p {
        let piv = (c..p)
            .max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs()))
            .unwrap();
        a.swap(c, piv);
        inv.swap(c, piv);
        let d = a[c][c];
        for j in 0..p {
            a[c][j] /= d;
            inv[c][j] /= d;
        }
        for i in 0..p {
            if i != c {
                let f = a[i][c];
                for j in 0..p {
                    a[i][j] -= f * a[c][j];
                    inv[i][j] -= f * inv[c][j];
                }
            }
        }
    }
    inv
}

#[test]
fn covariance_matches_normal_equations() {
    let (x, y, w) = random_problem(200, 4, 1234);
    let sol = fit(&x, &y, Some(&w));
    assert!(sol.condition_number_scaled < 10.0);
    let p = 4;
    let mut xtx = vec![vec![0.0; p]; p];
    let mut xty = vec![0.0; p];
    for ((row, yi), wi) in x.rows().into_iter().zip(&y).zip(&w) {
        for i in 0..p {
            xty[i] += wi * row[i] * yi;
            for j in 0..p {
                xtx[i][j] += wi * row[i] * row[j];
            }
        }
    }
    let inv = invert(xtx);
    let beta: Vec<f64> = (0..p)
        .map(|i| (0..p).map(|j| inv[i][j] * xty[j]).sum())
        .collect();
    let rss: f64 = x
        .rows()
        .into_iter()
        .zip(&y)
        .zip(&w)
        .map(|((row, yi), wi)| {
            wi * (yi - row.iter().zip(&beta).map(|(a, b)| a * b).sum::<f64>()).powi(2)
        })
        .sum();
    approx::assert_relative_eq!(sol.residual_sum_squares, rss, max_relative = 1e-10);
    assert_eq!(sol.dof, 196);
    let sigma2 = rss / 196.0;
    for i in 0..p {
        approx::assert_relative_eq!(sol.coefficients[i], beta[i], max_relative = 1e-10);
        for j in 0..p {
            let expect = sigma2 * inv[i][j];
            let got = sol.covariance[i * p + j];
            assert!(
                (got - expect).abs() <= 1e-10 * (sigma2 * (inv[i][i] * inv[j][j]).sqrt()),
                "cov[{i}][{j}] = {got} vs {expect}"
            );
        }
        // Exactly symmetric.
        for j in 0..p {
            assert_eq!(sol.covariance[i * p + j], sol.covariance[j * p + i]);
        }
    }
}

#[test]
fn condition_number_of_diagonal_design() {
    let d = [1.0, 10.0, 1000.0, 0.5];
    let x = Array2::from_shape_fn((4, 4), |(i, j)| if i == j { d[i] } else { 0.0 });
    let y = [2.0, 3.0, 4.0, 5.0];
    let sol = fit(&x, &y, None);
    approx::assert_relative_eq!(sol.condition_number, 2000.0, max_relative = 1e-14);
    approx::assert_relative_eq!(sol.condition_number_scaled, 1.0, max_relative = 1e-14);
    for i in 0..4 {
        approx::assert_relative_eq!(sol.coefficients[i], y[i] / d[i], max_relative = 1e-15);
    }
    // dof == 0: covariance undefined.
    assert_eq!(sol.dof, 0);
    assert!(sol.covariance.iter().all(|v| v.is_nan()));
    assert_eq!(sol.residual_sum_squares, 0.0);
}

#[test]
fn condition_number_matches_known_singular_values() {
    // Rows of a 2x2 with singular values 3 and 1: [[2, 1], [1, 2]].
    let x = Array2::from_shape_vec((2, 2), vec![2.0, 1.0, 1.0, 2.0]).unwrap();
    let sol = fit(&x, &[1.0, 1.0], None);
    approx::assert_relative_eq!(sol.condition_number, 3.0, max_relative = 1e-14);
    // Weights scale rows: sqrt(W) X = diag(2, 1) * I -> kappa 2.
    let x = Array2::from_shape_vec((2, 2), vec![1.0, 0.0, 0.0, 1.0]).unwrap();
    let sol = fit(&x, &[1.0, 1.0], Some(&[4.0, 1.0]));
    approx::assert_relative_eq!(sol.condition_number, 2.0, max_relative = 1e-14);
}

#[test]
fn finish_does_not_consume_and_push_continues() {
    let (x, y, _) = random_problem(100, 3, 77);
    let mut ls = LeastSquares::new(3, None).unwrap();
    ls.push(rows(&x, ..50), &y[..50], None).unwrap();
    let _ = ls.finish().unwrap();
    ls.push(rows(&x, 50..), &y[50..], None).unwrap();
    assert_eq!(
        format!("{:?}", ls.finish().unwrap()),
        format!("{:?}", fit(&x, &y, None))
    );
}

// ---------------------------------------------------------- performance

/// `cargo test --release -p accelcore-core --test regression -- --ignored --nocapture`
#[test]
#[ignore = "timing; run in release"]
fn push_throughput() {
    for p in [4_usize, 6, 10] {
        let n = 2_000_000;
        let mut rng = Rng(3);
        let t: Vec<f64> = (0..n).map(|_| -40.0 + 165.0 * rng.uniform()).collect();
        let x = Array2::from_shape_fn((n, p), |(i, k)| t[i].powi(k as i32));
        let y: Vec<f64> = t.iter().map(|t| 0.01 * t + rng.normal() * 1e-3).collect();
        let mut ls = LeastSquares::new(p, None).unwrap();
        let start = std::time::Instant::now();
        for c in 0..=(n / 4096) {
            let r = (c * 4096).min(n)..((c + 1) * 4096).min(n);
            ls.push(rows(&x, r.clone()), &y[r], None).unwrap();
        }
        let secs = start.elapsed().as_secs_f64();
        let sol = ls.finish().unwrap();
        eprintln!(
            "p = {p}: {:.1} M rows/s, {:.1} M row-column updates/s (kappa_scaled {:.2e})",
            n as f64 / secs / 1e6,
            (n * p) as f64 / secs / 1e6,
            sol.condition_number_scaled
        );
    }
}

#[test]
fn several_responses_share_one_factor_and_equal_separate_fits() {
    // Three channels against [1, dT]: the shared-R fit must give, bit for bit, what
    // three single-response fits give (the same rotations act on every column).
    let n = 500;
    let temp: Vec<f64> = (0..n).map(|i| -2.0 + 0.134 * f64::from(i)).collect();
    let mut design = Vec::with_capacity(2 * n as usize);
    let mut ys = Vec::with_capacity(3 * n as usize);
    let mut w = Vec::with_capacity(n as usize);
    for (i, &t) in temp.iter().enumerate() {
        design.extend([1.0, t - 25.0]);
        let wobble = ((i * 7919) % 13) as f64 * 1e-4;
        ys.extend([
            1.5 + 1e-3 * t + wobble,
            1.48 - 2e-4 * t - wobble,
            1.84 + 5e-3 * t + wobble,
        ]);
        w.push(if i % 17 == 0 {
            0.0
        } else {
            10.0 - (i % 3) as f64
        });
    }
    let design = ndarray::ArrayView2::from_shape((n as usize, 2), &design).unwrap();
    let responses = ndarray::ArrayView2::from_shape((n as usize, 3), &ys).unwrap();
    let mut multi = LeastSquares::with_responses(2, 3, None).unwrap();
    // Two chunks and a merge: still identical to one pass of each single fit.
    let (d1, d2) = design.view().split_at(ndarray::Axis(0), 200);
    let (r1, r2) = responses.view().split_at(ndarray::Axis(0), 200);
    multi.push_multi(d1, r1, Some(&w[..200])).unwrap();
    let mut rest = LeastSquares::with_responses(2, 3, None).unwrap();
    rest.push_multi(d2, r2, Some(&w[200..])).unwrap();
    multi.merge(&rest).unwrap();
    for j in 0..3 {
        let column: Vec<f64> = responses.column(j).to_vec();
        let mut single = LeastSquares::new(2, None).unwrap();
        single
            .push(
                design.slice_axis(ndarray::Axis(0), (..200).into()),
                &column[..200],
                Some(&w[..200]),
            )
            .unwrap();
        let mut tail = LeastSquares::new(2, None).unwrap();
        tail.push(
            design.slice_axis(ndarray::Axis(0), (200..).into()),
            &column[200..],
            Some(&w[200..]),
        )
        .unwrap();
        single.merge(&tail).unwrap();
        let (a, b) = (multi.finish_response(j).unwrap(), single.finish().unwrap());
        assert_eq!(a.coefficients, b.coefficients, "response {j}");
        assert_eq!(
            a.residual_sum_squares, b.residual_sum_squares,
            "response {j}"
        );
        assert_eq!(a.covariance, b.covariance, "response {j}");
    }
    assert!(multi.finish_response(3).is_err());
    assert_eq!(multi.n_responses(), 3);
}

#[test]
fn several_responses_check_shapes_and_values() {
    let mut multi = LeastSquares::with_responses(2, 3, None).unwrap();
    let design = ndarray::Array2::<f64>::ones((4, 2));
    let bad = ndarray::Array2::<f64>::ones((4, 2));
    assert!(matches!(
        multi.push_multi(design.view(), bad.view(), None),
        Err(Error::Shape {
            what: "response columns",
            expected: 3,
            got: 2
        })
    ));
    assert!(matches!(
        multi.push(design.view(), &[1.0; 4], None),
        Err(Error::Shape { .. })
    ));
    let mut ys = ndarray::Array2::<f64>::ones((4, 3));
    ys[[2, 1]] = f64::NAN;
    assert!(matches!(
        multi.push_multi(design.view(), ys.view(), None),
        Err(Error::NonFinite {
            what: "response",
            row: 2,
            column: 1
        })
    ));
    assert_eq!(multi.n_rows(), 0);
    assert!(LeastSquares::with_responses(2, 0, None).is_err());
    let single = LeastSquares::new(2, None).unwrap();
    assert!(matches!(
        multi.merge(&single),
        Err(Error::Incompatible { .. })
    ));
}

// ------------------------------------------------------------- push_mapped

/// One stretch of a mapped problem: its basis `b` (n, q), three responses (n, 3),
/// weights (every fifth 0), a map (q, p) and a shift (q).
struct Stretch {
    b: Array2<f64>,
    y: Array2<f64>,
    w: Vec<f64>,
    map: Array2<f64>,
    shift: Vec<f64>,
}

fn stretch(n: usize, q: usize, p: usize, rng: &mut Rng) -> Stretch {
    let b = Array2::from_shape_fn((n, q), |_| rng.normal());
    let y = Array2::from_shape_fn((n, 3), |_| rng.normal());
    let w = (0..n)
        .map(|i| if i % 5 == 0 { 0.0 } else { 0.5 + rng.uniform() })
        .collect();
    let map = Array2::from_shape_fn((q, p), |_| rng.normal());
    let shift = (0..q).map(|_| rng.normal()).collect();
    Stretch {
        b,
        y,
        w,
        map,
        shift,
    }
}

/// The same problem two ways: the stretches' rows `b · map` with the response
/// `y_r - b · shift` pushed directly, and each stretch's `[b | y]` factored then
/// pushed through its map.
fn mapped_and_direct(parts: &[Stretch], r: usize, shifted: bool) -> (LeastSquares, LeastSquares) {
    let p = parts[0].map.ncols();
    let mut direct = LeastSquares::new(p, None).unwrap();
    let mut mapped = LeastSquares::new(p, None).unwrap();
    for s in parts {
        let q = s.b.ncols();
        let x = s.b.dot(&s.map);
        let shift = ndarray::Array1::from(s.shift.clone());
        let mut y = s.y.column(r).to_owned();
        if shifted {
            y = y - s.b.dot(&shift);
        }
        direct
            .push(x.view(), y.as_slice().unwrap(), Some(&s.w))
            .unwrap();
        let mut basis = LeastSquares::with_responses(q, 3, None).unwrap();
        basis
            .push_multi(s.b.view(), s.y.view(), Some(&s.w))
            .unwrap();
        let shift2 = shift.into_shape_with_order((q, 1)).unwrap();
        mapped
            .push_mapped(&basis, s.map.view(), &[r], shifted.then(|| shift2.view()))
            .unwrap();
    }
    (mapped, direct)
}

proptest! {
    #![proptest_config(config())]

    /// Pushing each stretch's factor through its map equals pushing the mapped
    /// rows: the same triangle up to rounding, the same counts.
    #[test]
    fn push_mapped_equals_direct(
        q in 1_usize..6,
        p in 1_usize..9,
        stretches in 1_usize..5,
        extra in 0_usize..40,
        r in 0_usize..3,
        shifted in any::<bool>(),
        seed in any::<u64>(),
    ) {
        let mut rng = Rng(seed | 1);
        let parts: Vec<Stretch> = (0..stretches)
            // Every fifth weight is 0: more weighted rows than columns in every draw,
            // so a failure to solve is the rank's, not the count's.
            .map(|_| stretch(2 * (q + p) + 3 + extra, q, p, &mut rng))
            .collect();
        let (mapped, direct) = mapped_and_direct(&parts, r, shifted);
        prop_assert_eq!(mapped.n_rows(), direct.n_rows());
        if p > q * stretches {
            // The columns b · map of a stretch span at most q directions.
            let rank_deficient = |r: Result<LstsqSolution, Error>| {
                matches!(r, Err(Error::RankDeficient { .. }))
            };
            prop_assert!(rank_deficient(direct.finish()));
            prop_assert!(rank_deficient(mapped.finish()));
            return Ok(());
        }
        let b = direct.finish().unwrap();
        // Random Gaussian stretches are of full rank; a badly conditioned draw is
        // left out (the bound below grows with the condition number).
        prop_assume!(b.condition_number_scaled < 1e6);
        let a = mapped.finish().unwrap();
        let w: Vec<f64> = parts.iter().flat_map(|s| s.w.iter().copied()).collect();
        let x: Vec<Array2<f64>> = parts.iter().map(|s| s.b.dot(&s.map)).collect();
        let views: Vec<ArrayView2<'_, f64>> = x.iter().map(|a| a.view()).collect();
        let mut weighted = ndarray::concatenate(Axis(0), &views).unwrap();
        for (mut row, wi) in weighted.rows_mut().into_iter().zip(&w) {
            row *= wi.sqrt();
        }
        // Two QRs in a row (the stretch's, then the mapped rows'): each backward
        // stable, so the bound of one, with room for both.
        assert_fits_close(&a, &b, &column_norms(&weighted), 256.0);
    }
}

#[test]
fn push_mapped_names_the_columns_it_cannot_identify() {
    // Two gain terms of one basis, the second never seeing gravity: a zero column.
    let mut rng = Rng(11);
    let mut s = stretch(40, 2, 3, &mut rng);
    s.map.column_mut(2).fill(0.0);
    let mut basis = LeastSquares::with_responses(2, 3, None).unwrap();
    basis
        .push_multi(s.b.view(), s.y.view(), Some(&s.w))
        .unwrap();
    let mut mapped = LeastSquares::new(3, names(&["offset", "gain", "never"])).unwrap();
    mapped
        .push_mapped(&basis, s.map.view(), &[1], None)
        .unwrap();
    match mapped.finish() {
        Err(Error::RankDeficient { columns }) => assert_eq!(columns, vec!["never".to_string()]),
        other => panic!("expected a rank error, got {other:?}"),
    }
}

#[test]
fn push_mapped_of_an_empty_source_adds_nothing() {
    let basis = LeastSquares::with_responses(3, 2, None).unwrap();
    let mut mapped = LeastSquares::new(2, None).unwrap();
    let map = Array2::from_elem((3, 2), 1.0);
    mapped.push_mapped(&basis, map.view(), &[0], None).unwrap();
    assert_eq!(mapped.n_rows(), 0);
    assert!(matches!(mapped.finish(), Err(Error::Empty { .. })));
}

#[test]
fn push_mapped_rejects_bad_shapes_and_values() {
    let mut rng = Rng(3);
    let s = stretch(20, 2, 3, &mut rng);
    let mut basis = LeastSquares::with_responses(2, 3, None).unwrap();
    basis.push_multi(s.b.view(), s.y.view(), None).unwrap();
    let mut mapped = LeastSquares::new(3, None).unwrap();
    let wrong = Array2::zeros((3, 3));
    assert!(matches!(
        mapped.push_mapped(&basis, wrong.view(), &[0], None),
        Err(Error::Shape { .. })
    ));
    assert!(matches!(
        mapped.push_mapped(&basis, s.map.view(), &[0, 1], None),
        Err(Error::Shape { .. })
    ));
    assert!(matches!(
        mapped.push_mapped(&basis, s.map.view(), &[3], None),
        Err(Error::InvalidParameter {
            name: "responses",
            ..
        })
    ));
    let mut bad = s.map.clone();
    bad[[1, 2]] = f64::NAN;
    assert!(matches!(
        mapped.push_mapped(&basis, bad.view(), &[0], None),
        Err(Error::InvalidParameter { name: "map", .. })
    ));
    let short_shift = Array2::zeros((1, 1));
    assert!(matches!(
        mapped.push_mapped(&basis, s.map.view(), &[0], Some(short_shift.view())),
        Err(Error::Shape { .. })
    ));
    // Nothing was pushed by the failed calls.
    assert_eq!(mapped.n_rows(), 0);
}
