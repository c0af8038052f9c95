//! Tests of held-out least squares from per-block factors: `residual_sum_squares_at`,
//! `without_columns`, `select_columns`, `solve_identifiable`,
//! `BlockedLeastSquares::cross_validate` and the subset queries of
//! `FoldedLeastSquares::cross_validate`, each against a brute-force computation
//! over the rows.

use accelcore_core::{BlockedLeastSquares, Error, LeastSquares};
use ndarray::{Array2, Axis};
use proptest::prelude::*;

const EPS: f64 = f64::EPSILON;

/// A well-conditioned random problem: columns 1, t, t², noise; weights in [0.5, 2).
fn problem(n: usize, p: usize, seed: u64) -> (Array2<f64>, Vec<f64>, Vec<f64>) {
    let mut s = seed
        .wrapping_mul(6_364_136_223_846_793_005)
        .wrapping_add(1_442_695_040_888_963_407);
    let mut uniform = move || {
        s ^= s >> 12;
        s ^= s << 25;
        s ^= s >> 27;
        (s.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1_u64 << 53) as f64
    };
    let x = Array2::from_shape_fn((n, p), |(_, j)| if j == 0 { 1.0 } else { 0.0 });
    let mut x = x;
    for i in 0..n {
        let t = 2.0 * uniform() - 1.0;
        for j in 1..p {
            x[[i, j]] = if j % 2 == 1 {
                t.powi(j as i32)
            } else {
                2.0 * uniform() - 1.0
            };
        }
    }
    let y: Vec<f64> = (0..n)
        .map(|i| {
            (0..p).map(|j| (j as f64 + 1.0) * x[[i, j]]).sum::<f64>() + 0.1 * (uniform() - 0.5)
        })
        .collect();
    let w: Vec<f64> = (0..n).map(|_| 0.5 + 1.5 * uniform()).collect();
    (x, y, w)
}

fn direct_rss(x: &Array2<f64>, y: &[f64], w: &[f64], beta: &[f64], rows: &[usize]) -> f64 {
    rows.iter()
        .map(|&i| {
            let fit: f64 = x.row(i).iter().zip(beta).map(|(a, b)| a * b).sum();
            w[i] * (y[i] - fit) * (y[i] - fit)
        })
        .sum()
}

fn sub_rows(x: &Array2<f64>, rows: &[usize]) -> Array2<f64> {
    x.select(Axis(0), rows)
}

#[test]
fn residual_sum_squares_at_equals_the_rows() {
    let (x, y, w) = problem(200, 4, 7);
    let mut ls = LeastSquares::new(4, None).unwrap();
    ls.push(x.view(), &y, Some(&w)).unwrap();
    let all: Vec<usize> = (0..200).collect();
    for beta in [
        vec![0.0; 4],
        vec![1.0, 2.0, 3.0, 4.0],
        vec![-3.0, 0.5, 7.0, 1e-3],
    ] {
        let got = ls.residual_sum_squares_at(&beta, 0).unwrap();
        let want = direct_rss(&x, &y, &w, &beta, &all);
        // Both sum n squares of O(10) terms: relative error of a few hundred eps.
        assert!(
            (got - want).abs() <= 1e3 * EPS * want.max(1.0),
            "{got} vs {want}"
        );
    }
    let fit = ls.finish().unwrap();
    let at_min = ls.residual_sum_squares_at(&fit.coefficients, 0).unwrap();
    assert!((at_min - fit.residual_sum_squares).abs() <= 1e3 * EPS * at_min.max(1.0));
    assert!(matches!(
        ls.residual_sum_squares_at(&[1.0], 0),
        Err(Error::Shape { .. })
    ));
}

#[test]
fn without_columns_equals_pushing_the_reduced_rows() {
    let (x, y, w) = problem(300, 5, 11);
    let mut ls = LeastSquares::new(5, None).unwrap();
    ls.push(x.view(), &y, Some(&w)).unwrap();
    let reduced = ls.without_columns(&[1, 3]).unwrap();
    let xr = x.select(Axis(1), &[0, 2, 4]);
    let mut direct = LeastSquares::new(3, None).unwrap();
    direct.push(xr.view(), &y, Some(&w)).unwrap();
    let (a, b) = (reduced.finish().unwrap(), direct.finish().unwrap());
    // Two backward-stable factorisations of the same well-conditioned design
    // (scaled condition number < 10): coefficients agree to ~kappa * n * eps.
    for (u, v) in a.coefficients.iter().zip(&b.coefficients) {
        assert!((u - v).abs() <= 1e-11 * v.abs().max(1.0), "{u} vs {v}");
    }
    let rel = (a.residual_sum_squares - b.residual_sum_squares).abs() / b.residual_sum_squares;
    assert!(
        rel <= 1e-10,
        "rss {} vs {}",
        a.residual_sum_squares,
        b.residual_sum_squares
    );
    assert_eq!(reduced.n_rows(), 300);
    assert!(ls.without_columns(&[0, 1, 2, 3, 4]).is_err());
    assert!(ls.without_columns(&[5]).is_err());
}

#[test]
fn select_columns_equals_pushing_the_selected_rows_in_that_order() {
    let (x, y, w) = problem(300, 5, 13);
    let mut ls = LeastSquares::new(5, None).unwrap();
    ls.push(x.view(), &y, Some(&w)).unwrap();
    for columns in [vec![3, 0, 4], vec![4], vec![2, 1], vec![0, 1, 2, 3, 4]] {
        let selected = ls.select_columns(&columns).unwrap();
        let xs = x.select(Axis(1), &columns);
        let mut direct = LeastSquares::new(columns.len(), None).unwrap();
        direct.push(xs.view(), &y, Some(&w)).unwrap();
        let (a, b) = (selected.finish().unwrap(), direct.finish().unwrap());
        for (u, v) in a.coefficients.iter().zip(&b.coefficients) {
            assert!(
                (u - v).abs() <= 1e-11 * v.abs().max(1.0),
                "{columns:?}: {u} vs {v}"
            );
        }
        let rel = (a.residual_sum_squares - b.residual_sum_squares).abs() / b.residual_sum_squares;
        assert!(
            rel <= 1e-10,
            "{columns:?}: rss {} vs {}",
            a.residual_sum_squares,
            b.residual_sum_squares
        );
        assert_eq!(selected.n_rows(), 300);
        let names: Vec<String> = columns.iter().map(|j| format!("x{j}")).collect();
        assert_eq!(selected.column_names(), names.as_slice());
    }
    // The order decides which of two equal columns is held at zero: the later one.
    let mut xd = Array2::zeros((300, 3));
    for i in 0..300 {
        xd[[i, 0]] = x[[i, 0]];
        xd[[i, 1]] = x[[i, 1]];
        xd[[i, 2]] = x[[i, 1]];
    }
    let mut dup = LeastSquares::new(3, None).unwrap();
    dup.push(xd.view(), &y, Some(&w)).unwrap();
    assert_eq!(dup.solve_identifiable(0).unwrap().1, vec![2]);
    let swapped = dup.select_columns(&[2, 0, 1]).unwrap();
    assert_eq!(swapped.solve_identifiable(0).unwrap().1, vec![2]);
    assert_eq!(
        dup.select_columns(&[1, 2]).unwrap().deficient_columns(),
        vec![1]
    );
    for bad in [vec![], vec![0, 0], vec![3]] {
        assert!(matches!(
            dup.select_columns(&bad),
            Err(Error::InvalidParameter {
                name: "columns",
                ..
            })
        ));
    }
}

#[test]
fn a_dependent_column_is_held_at_zero_and_the_fit_is_unchanged() {
    let (x, y, w) = problem(150, 3, 3);
    // Column 3 = column 1 + column 2: not identifiable after them.
    let mut xd = Array2::zeros((150, 4));
    for i in 0..150 {
        for j in 0..3 {
            xd[[i, j]] = x[[i, j]];
        }
        xd[[i, 3]] = x[[i, 1]] + x[[i, 2]];
    }
    let mut ls = LeastSquares::new(4, None).unwrap();
    ls.push(xd.view(), &y, Some(&w)).unwrap();
    assert!(matches!(ls.finish(), Err(Error::RankDeficient { .. })));
    assert_eq!(ls.deficient_columns(), vec![3]);
    let (beta, dropped) = ls.solve_identifiable(0).unwrap();
    assert_eq!(dropped, vec![3]);
    assert_eq!(beta[3], 0.0);
    let mut full = LeastSquares::new(3, None).unwrap();
    full.push(x.view(), &y, Some(&w)).unwrap();
    let want = full.finish().unwrap();
    for (u, v) in beta[..3].iter().zip(&want.coefficients) {
        assert!((u - v).abs() <= 1e-10 * v.abs().max(1.0), "{u} vs {v}");
    }
    // An all-zero column, and a problem where nothing is identifiable.
    let zeros = Array2::zeros((10, 2));
    let mut z = LeastSquares::new(2, None).unwrap();
    z.push(zeros.view(), &[1.0; 10], None).unwrap();
    let (beta, dropped) = z.solve_identifiable(0).unwrap();
    assert_eq!((beta, dropped), (vec![0.0, 0.0], vec![0, 1]));
    assert!(matches!(
        LeastSquares::new(2, None).unwrap().solve_identifiable(0),
        Err(Error::Empty { .. })
    ));
}

/// Brute force: for each fold, fit on the other folds' rows, evaluate each block.
fn brute_force(
    x: &Array2<f64>,
    y: &[f64],
    w: &[f64],
    block: &[u32],
    block_fold: &[u32],
) -> Vec<f64> {
    let n_folds = *block_fold.iter().max().unwrap() as usize + 1;
    let mut out = vec![0.0; block_fold.len()];
    for k in 0..n_folds as u32 {
        let train: Vec<usize> = (0..y.len())
            .filter(|&i| block_fold[block[i] as usize] != k)
            .collect();
        let xt = sub_rows(x, &train);
        let yt: Vec<f64> = train.iter().map(|&i| y[i]).collect();
        let wt: Vec<f64> = train.iter().map(|&i| w[i]).collect();
        let mut ls = LeastSquares::new(x.ncols(), None).unwrap();
        ls.push(xt.view(), &yt, Some(&wt)).unwrap();
        let beta = ls.finish().unwrap().coefficients;
        for (b, &f) in block_fold.iter().enumerate() {
            if f == k {
                let rows: Vec<usize> = (0..y.len()).filter(|&i| block[i] as usize == b).collect();
                out[b] = direct_rss(x, y, w, &beta, &rows);
            }
        }
    }
    out
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn cross_validation_equals_refitting_the_rows(
        seed in 0_u64..10_000,
        n_blocks in 3_usize..12,
        n_folds in 2_u32..5,
        p in 1_usize..5,
        shuffled in any::<bool>(),
    ) {
        let n = 40 * n_blocks;
        let (x, y, w) = problem(n, p, seed);
        // Rows in block order, or interleaved (a block's rows need not be contiguous).
        let block: Vec<u32> = (0..n)
            .map(|i| if shuffled { (i % n_blocks) as u32 } else { (i / 40) as u32 })
            .collect();
        let block_fold: Vec<u32> = (0..n_blocks).map(|b| b as u32 % n_folds).collect();
        let mut cv = BlockedLeastSquares::new(p, n_blocks).unwrap();
        // Pushed in two chunks cut mid-block: chunking must not matter.
        let cut = n / 2 + 7;
        cv.push(x.slice_axis(Axis(0), (..cut).into()), &y[..cut], Some(&w[..cut]), &block[..cut]).unwrap();
        cv.push(x.slice_axis(Axis(0), (cut..).into()), &y[cut..], Some(&w[cut..]), &block[cut..]).unwrap();
        let fit = cv.cross_validate(&block_fold).unwrap();
        let want = brute_force(&x, &y, &w, &block, &block_fold);
        for (got, want) in fit.heldout_rss_per_block.iter().zip(&want) {
            // Well-conditioned designs (scaled kappa < 10), n <= 480 rows: the two
            // routes differ by rounding of order n * kappa * eps relative.
            prop_assert!((got - want).abs() <= 1e-9 * want.max(1e-12), "{} vs {}", got, want);
        }
        let mut whole = LeastSquares::new(p, None).unwrap();
        whole.push(x.view(), &y, Some(&w)).unwrap();
        let sol = whole.finish().unwrap();
        for (u, v) in fit.coefficients.iter().zip(&sol.coefficients) {
            prop_assert!((u - v).abs() <= 1e-10 * v.abs().max(1.0));
        }
        prop_assert!((fit.in_sample_rss - sol.residual_sum_squares).abs() <= 1e-9 * sol.residual_sum_squares);
        prop_assert!(fit.heldout_rss() >= fit.in_sample_rss * (1.0 - 1e-9));
    }

    #[test]
    fn a_subset_of_a_wide_design_equals_refitting_its_rows(
        seed in 0_u64..10_000,
        n_blocks in 3_usize..10,
        n_folds in 2_u32..5,
        mask in 1_u32..64,
        reversed in any::<bool>(),
        response in 0_usize..3,
    ) {
        // Six columns, three responses (the first a fit of the design, the others
        // the same plus a smooth function of the row): any subset, either order.
        let (p, n) = (6, 40 * n_blocks);
        let (x, y0, w) = problem(n, p, seed);
        let ys: Vec<Vec<f64>> = (0..3)
            .map(|r| {
                y0.iter()
                    .enumerate()
                    .map(|(i, &v)| v + f64::from(r) * (i as f64 / n as f64).sin())
                    .collect()
            })
            .collect();
        let responses = Array2::from_shape_fn((n, 3), |(i, r)| ys[r][i]);
        let block: Vec<u32> = (0..n).map(|i| ((i / 3) % n_blocks) as u32).collect();
        let block_fold: Vec<u32> = (0..n_blocks).map(|b| b as u32 % n_folds).collect();
        let mut cv = BlockedLeastSquares::with_responses(p, 3, n_blocks).unwrap();
        cv.push_multi(x.view(), responses.view(), Some(&w), &block).unwrap();
        let mut columns: Vec<usize> = (0..p).filter(|j| mask & (1 << j) != 0).collect();
        if reversed {
            columns.reverse();
        }
        let folds = cv.folds(&block_fold).unwrap();
        let fit = folds.cross_validate(&columns, response).unwrap();
        let xs = x.select(Axis(1), &columns);
        let want = brute_force(&xs, &ys[response], &w, &block, &block_fold);
        for (got, want) in fit.heldout_rss_per_block.iter().zip(&want) {
            prop_assert!((got - want).abs() <= 1e-9 * want.max(1e-12), "{} vs {}", got, want);
        }
        let mut whole = LeastSquares::new(columns.len(), None).unwrap();
        whole.push(xs.view(), &ys[response], Some(&w)).unwrap();
        let sol = whole.finish().unwrap();
        prop_assert_eq!(fit.coefficients.len(), columns.len());
        for (u, v) in fit.coefficients.iter().zip(&sol.coefficients) {
            prop_assert!((u - v).abs() <= 1e-10 * v.abs().max(1.0));
        }
        prop_assert!((fit.in_sample_rss - sol.residual_sum_squares).abs() <= 1e-9 * sol.residual_sum_squares);
        // Every column, response 0: the same numbers as cross_validate.
        if response == 0 {
            let every: Vec<usize> = (0..p).collect();
            let mut single = BlockedLeastSquares::new(p, n_blocks).unwrap();
            single.push(x.view(), &ys[0], Some(&w), &block).unwrap();
            let a = folds.cross_validate(&every, 0).unwrap();
            let b = single.cross_validate(&block_fold).unwrap();
            for (u, v) in a.heldout_rss_per_block.iter().zip(&b.heldout_rss_per_block) {
                prop_assert!((u - v).abs() <= 1e-9 * v.max(1e-12));
            }
        }
    }

    #[test]
    fn merged_halves_equal_one_accumulator(seed in 0_u64..10_000, n_blocks in 2_usize..8) {
        let n = 30 * n_blocks;
        let (x, y, w) = problem(n, 3, seed);
        let block: Vec<u32> = (0..n).map(|i| (i % n_blocks) as u32).collect();
        let folds: Vec<u32> = (0..n_blocks).map(|b| (b % 2) as u32).collect();
        let mut one = BlockedLeastSquares::new(3, n_blocks).unwrap();
        one.push(x.view(), &y, Some(&w), &block).unwrap();
        let mut a = BlockedLeastSquares::new(3, n_blocks).unwrap();
        let mut b = BlockedLeastSquares::new(3, n_blocks).unwrap();
        let h = n / 3;
        a.push(x.slice_axis(Axis(0), (..h).into()), &y[..h], Some(&w[..h]), &block[..h]).unwrap();
        b.push(x.slice_axis(Axis(0), (h..).into()), &y[h..], Some(&w[h..]), &block[h..]).unwrap();
        a.merge(&b).unwrap();
        let (u, v) = (one.cross_validate(&folds).unwrap(), a.cross_validate(&folds).unwrap());
        for (p, q) in u.heldout_rss_per_block.iter().zip(&v.heldout_rss_per_block) {
            prop_assert!((p - q).abs() <= 1e-9 * q.max(1e-12));
        }
    }
}

#[test]
fn a_fold_whose_training_data_lacks_a_column_holds_it_at_zero() {
    // Column 1 is non-zero only in block 0; without block 0 it cannot be fitted.
    let n = 60;
    let mut x = Array2::zeros((n, 2));
    let mut y = vec![0.0; n];
    let block: Vec<u32> = (0..n).map(|i| (i / 20) as u32).collect();
    for i in 0..n {
        x[[i, 0]] = 1.0;
        x[[i, 1]] = if block[i] == 0 { 1.0 } else { 0.0 };
        y[i] = 2.0 + 3.0 * x[[i, 1]];
    }
    let mut cv = BlockedLeastSquares::new(2, 3).unwrap();
    cv.push(x.view(), &y, None, &block).unwrap();
    let fit = cv.cross_validate(&[0, 1, 2]).unwrap();
    assert_eq!(fit.fold_coefficients[0][1], 0.0);
    // Block 0 predicted without its step of 3: 20 rows of error 3.
    assert!((fit.heldout_rss_per_block[0] - 20.0 * 9.0).abs() < 1e-9);
    assert!(fit.heldout_rss_per_block[1] < 1e-20 && fit.heldout_rss_per_block[2] < 1e-20);
    assert!(fit.not_identified.is_empty());
}

#[test]
fn bad_input_is_refused_whole() {
    let x = Array2::from_elem((4, 2), 1.0);
    let mut cv = BlockedLeastSquares::new(2, 2).unwrap();
    assert!(matches!(
        cv.push(x.view(), &[1.0; 4], None, &[0, 0, 2, 1]),
        Err(Error::InvalidParameter { name: "block", .. })
    ));
    assert!(matches!(
        cv.push(x.view(), &[1.0; 3], None, &[0, 0, 1, 1]),
        Err(Error::Shape { .. })
    ));
    assert!(matches!(
        cv.push(x.view(), &[1.0, 1.0, f64::NAN, 1.0], None, &[0, 0, 1, 1]),
        Err(Error::NonFinite {
            what: "response",
            row: 2,
            ..
        })
    ));
    assert!(matches!(
        cv.push(
            x.view(),
            &[1.0; 4],
            Some(&[1.0, -1.0, 1.0, 1.0]),
            &[0, 0, 1, 1]
        ),
        Err(Error::InvalidParameter {
            name: "weights",
            ..
        })
    ));
    assert_eq!(
        cv.block(0).unwrap().n_rows(),
        0,
        "a refused chunk pushes nothing"
    );
    assert!(matches!(cv.cross_validate(&[0]), Err(Error::Shape { .. })));
    assert!(matches!(
        cv.cross_validate(&[0, 1]),
        Err(Error::Empty { .. })
    ));
}

#[test]
fn subset_queries_refuse_bad_columns_and_responses() {
    let (x, y, w) = problem(40, 3, 2);
    let ys = Array2::from_shape_fn((40, 2), |(i, r)| y[i] + r as f64);
    let block: Vec<u32> = (0..40).map(|i| (i / 20) as u32).collect();
    let mut cv = BlockedLeastSquares::with_responses(3, 2, 2).unwrap();
    assert_eq!(cv.n_responses(), 2);
    assert!(matches!(
        cv.push(x.view(), &y, Some(&w), &block),
        Err(Error::Shape { .. })
    ));
    assert!(matches!(
        cv.push_multi(
            x.view(),
            ys.slice_axis(Axis(1), (..1).into()),
            Some(&w),
            &block
        ),
        Err(Error::Shape {
            what: "response columns",
            ..
        })
    ));
    cv.push_multi(x.view(), ys.view(), Some(&w), &block)
        .unwrap();
    let folds = cv.folds(&[0, 1]).unwrap();
    assert_eq!(folds.n_folds(), 2);
    assert!(matches!(
        folds.cross_validate(&[0, 1], 2),
        Err(Error::InvalidParameter {
            name: "response",
            ..
        })
    ));
    for bad in [vec![], vec![1, 1], vec![3]] {
        assert!(matches!(
            folds.cross_validate(&bad, 0),
            Err(Error::InvalidParameter {
                name: "columns",
                ..
            })
        ));
    }
    assert!(matches!(cv.folds(&[0]), Err(Error::Shape { .. })));
    // A response that is column 0 plus 1: the two responses differ by exactly that.
    let a = folds.cross_validate(&[2, 0], 0).unwrap();
    let b = folds.cross_validate(&[2, 0], 1).unwrap();
    assert!((b.coefficients[1] - a.coefficients[1] - 1.0).abs() < 1e-10);
}

/// Uniform in [0, 1) from a counter (xorshift-multiply), for designs built inline.
fn uniform_at(seed: u64, i: usize, j: usize) -> f64 {
    let mut s = seed ^ ((i as u64) << 20) ^ (j as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    s = s
        .wrapping_mul(6_364_136_223_846_793_005)
        .wrapping_add(1_442_695_040_888_963_407);
    s ^= s >> 29;
    s = s.wrapping_mul(0xbf58_476d_1ce4_e5b9);
    s ^= s >> 32;
    (s >> 11) as f64 / (1_u64 << 53) as f64
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    /// Blocks of fewer rows than columns (kept as rows, gathered into their
    /// folds' factors) mixed with a block of a full update's rows and more (kept
    /// as a factor) and empty blocks and folds: the held-out error of every
    /// block, the coefficients of every fold and which columns are held at zero
    /// equal refitting each fold's training rows in one accumulator, for designs
    /// with a column dependent on earlier ones and a column only one fold sees.
    #[test]
    fn blocks_of_few_rows_equal_refitting_each_fold(
        seed in any::<u64>(),
        p in 5_usize..=20,
        sizes in prop::collection::vec(0_usize..30, 4..16),
        big in any::<bool>(),
        n_folds in 2_u32..7,
        dependent in any::<bool>(),
        local in any::<bool>(),
        response in 0_usize..2,
        cut in 0.0_f64..1.0,
    ) {
        let mut sizes = sizes;
        if big {
            sizes[0] = 70; // a factored block (more rows than a block update)
        }
        let n_blocks = sizes.len();
        let block: Vec<u32> = sizes
            .iter()
            .enumerate()
            .flat_map(|(b, &s)| std::iter::repeat_n(b as u32, s))
            .collect();
        let n = block.len();
        // Fold n_folds - 1 is left empty when there are enough folds.
        let block_fold: Vec<u32> = (0..n_blocks)
            .map(|b| (b as u32) % n_folds.max(2).saturating_sub(u32::from(n_folds > 2)))
            .collect();
        let local_fold = block_fold[n_blocks - 1];
        let mut x = Array2::from_shape_fn((n, p), |(i, j)| {
            if j == 0 { 1.0 } else { 2.0 * uniform_at(seed, i, j) - 1.0 }
        });
        if dependent {
            // Column 3 = column 1 + 2 column 2: the later one (3) is held at zero.
            for i in 0..n {
                x[[i, 3]] = x[[i, 1]] + 2.0 * x[[i, 2]];
            }
        }
        if local {
            // Column p - 1 only in the last block's fold: its training data lack it.
            for i in 0..n {
                if block_fold[block[i] as usize] != local_fold {
                    x[[i, p - 1]] = 0.0;
                }
            }
        }
        let ys = Array2::from_shape_fn((n, 2), |(i, r)| {
            (0..p).map(|j| x[[i, j]] * (j + r + 1) as f64).sum::<f64>()
                + 0.1 * (uniform_at(seed, i, p + r) - 0.5)
        });
        let w: Vec<f64> = (0..n)
            .map(|i| if i % 7 == 3 { 0.0 } else { 0.5 + 1.5 * uniform_at(seed, i, 2 * p) })
            .collect();
        let y: Vec<f64> = ys.column(response).to_vec();
        prop_assume!(w.iter().any(|&v| v > 0.0));

        let mut cv = BlockedLeastSquares::with_responses(p, 2, n_blocks).unwrap();
        let c = (cut * n as f64) as usize;
        for r in [0..c, c..n] {
            let rows = ndarray::Slice::from(r.clone());
            cv.push_multi(
                x.slice_axis(Axis(0), rows),
                ys.slice_axis(Axis(0), rows),
                Some(&w[r.clone()]),
                &block[r],
            ).unwrap();
        }
        let every: Vec<usize> = (0..p).collect();
        let fit = cv.folds(&block_fold).unwrap().cross_validate(&every, response).unwrap();

        let folds_used = *block_fold.iter().max().unwrap() + 1;
        prop_assert_eq!(fit.fold_coefficients.len(), folds_used as usize);
        for k in 0..folds_used {
            let held: Vec<usize> = (0..n).filter(|&i| block_fold[block[i] as usize] == k).collect();
            if held.iter().all(|&i| w[i] == 0.0) {
                prop_assert!(fit.fold_coefficients[k as usize].is_empty());
                continue;
            }
            let train: Vec<usize> = (0..n).filter(|&i| block_fold[block[i] as usize] != k).collect();
            let mut ls = LeastSquares::new(p, None).unwrap();
            let wt: Vec<f64> = train.iter().map(|&i| w[i]).collect();
            let yt: Vec<f64> = train.iter().map(|&i| y[i]).collect();
            ls.push(sub_rows(&x, &train).view(), &yt, Some(&wt)).unwrap();
            let got = &fit.fold_coefficients[k as usize];
            if ls.n_rows() == 0 {
                prop_assert!(got.iter().all(|&b| b == 0.0));
                continue;
            }
            let (beta, dropped) = ls.solve_identifiable(0).unwrap();
            // The same columns held at zero: the rank test sees |R_jj| of a
            // dependent (or absent) column at rounding level (~1e-15 of its norm)
            // and of the others at O(1) of it, far on either side of 1e-10.
            for (j, (&a, &b)) in got.iter().zip(&beta).enumerate() {
                prop_assert_eq!(a == 0.0, dropped.contains(&j) || b == 0.0, "fold {} column {}", k, j);
            }
            let kept: Vec<usize> = (0..p).filter(|j| !dropped.contains(j)).collect();
            if kept.is_empty() {
                continue;
            }
            let sol = ls.select_columns(&kept).unwrap().finish().unwrap();
            let kappa = sol.condition_number_scaled;
            prop_assume!(kappa < 1e6);
            // Scaled coefficients (each times its column's weighted norm in the
            // training rows): both routes are backward-stable QR solutions of
            // the same rows, each within e (kappa |x_s| + kappa^2 |r|) of the exact
            // one, e = 8 q sqrt(n) eps (as in the regression tests; Higham Thm 20.1).
            let norm = |v: &mut dyn Iterator<Item = f64>| v.fold(0.0_f64, f64::hypot);
            let col_norm: Vec<f64> = (0..p)
                .map(|j| norm(&mut train.iter().map(|&i| w[i].sqrt() * x[[i, j]])))
                .collect();
            let xs = norm(&mut kept.iter().map(|&j| beta[j] * col_norm[j]));
            let r = sol.residual_sum_squares.sqrt();
            let e = 8.0 * kept.len() as f64 * (train.len() as f64).sqrt() * EPS;
            let d_beta = 2.0 * e * (kappa * xs + kappa * kappa * r);
            let diff = norm(&mut kept.iter().map(|&j| (got[j] - beta[j]) * col_norm[j]));
            prop_assert!(diff <= d_beta, "fold {}: |d beta_s| {:e} > {:e} (kappa {:e})", k, diff, d_beta, kappa);
            for b in (0..n_blocks).filter(|&b| block_fold[b] == k) {
                let rows: Vec<usize> = (0..n).filter(|&i| block[i] as usize == b).collect();
                let want = direct_rss(&x, &y, &w, &beta, &rows);
                // ||A_b (beta + d) - y_b||^2 moves by 2 |r_b| |A_b,s| |d_s| + (|A_b,s| |d_s|)^2,
                // |A_b,s| <= its Frobenius norm (columns scaled as above); summing the
                // squares of n_b rows rounds by n_b eps (|y| + sum |x beta|)^2 on each side.
                let (xr, wr, cn) = (&x, &w, &col_norm);
                let frobenius = norm(&mut rows.iter().flat_map(|&i| {
                    kept.iter().map(move |&j| wr[i].sqrt() * xr[[i, j]] / cn[j].max(f64::MIN_POSITIVE))
                }));
                let moved = frobenius * d_beta;
                let scale: f64 = rows.iter().map(|&i| {
                    let s: f64 = (0..p).map(|j| (x[[i, j]] * beta[j]).abs()).sum();
                    w[i] * (y[i].abs() + s).powi(2)
                }).sum();
                let bound = 2.0 * want.sqrt() * moved + moved * moved
                    + 2.0 * (rows.len() + p) as f64 * EPS * scale;
                let got_b = fit.heldout_rss_per_block[b];
                prop_assert!((got_b - want).abs() <= bound, "block {}: {:e} vs {:e}, bound {:e}", b, got_b, want, bound);
            }
        }
        let weighted: Vec<u64> = (0..n_blocks)
            .map(|b| (0..n).filter(|&i| block[i] as usize == b && w[i] > 0.0).count() as u64)
            .collect();
        prop_assert_eq!(&fit.rows_per_block, &weighted);
        // In-sample: all rows in one accumulator, the same columns held at zero.
        let mut whole = LeastSquares::new(p, None).unwrap();
        whole.push(x.view(), &y, Some(&w)).unwrap();
        let (_, dropped) = whole.solve_identifiable(0).unwrap();
        prop_assert_eq!(&fit.not_identified, &dropped);
    }
}
