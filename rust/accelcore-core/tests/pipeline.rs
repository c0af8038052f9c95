//! FusedPipeline: equals the composed kernels; chunking and merge invariance.
use accelcore_core::{
    BinnedStats, BinnerConfig, Decimator, DecimatorConfig, Error, FusedPipeline, LeastSquares,
    LstsqSolution, PipelineConfig, PipelineResult, TemperatureBinner,
};
use ndarray::{Array2, ArrayView2, Axis, Slice};
use proptest::prelude::*;

/// A synthetic log: 20 Hz with jitter, optional gaps and NaNs, a temperature ramp,
/// channels linear in temperature plus deterministic noise.
struct Log {
    t: Vec<f64>,
    temp: Vec<f64>,
    ch: Array2<f64>,
}

fn make_log(n: usize, seed: u64, nan_every: usize, gap_every: usize) -> Log {
    let mut state = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
    let mut rnd = move || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((state >> 11) as f64) / ((1u64 << 53) as f64) - 0.5
    };
    let mut t = Vec::with_capacity(n);
    let mut now = 1000.0;
    for i in 0..n {
        now += 0.05 + 0.004 * rnd();
        if gap_every > 0 && i % gap_every == gap_every - 1 {
            now += 1.3;
        }
        t.push(now);
    }
    let temp: Vec<f64> = (0..n)
        .map(|i| -10.0 + 60.0 * i as f64 / n as f64 + 0.2 * rnd())
        .collect();
    let mut ch = Array2::from_shape_fn((n, 3), |(i, j)| {
        (j as f64 + 1.0) * 0.01 * (temp[i] - 25.0) + 0.3 * j as f64 + 0.02 * rnd()
    });
    if nan_every > 0 {
        for i in (nan_every / 2..n).step_by(nan_every) {
            ch[[i, i % 3]] = f64::NAN;
        }
    }
    Log { t, temp, ch }
}

fn config(t0_s: Option<f64>, min_count: usize) -> PipelineConfig {
    PipelineConfig {
        decimator: DecimatorConfig {
            factor: 10,
            rate_hz: 20.0,
            n_channels: 3,
            min_count,
            t0_s,
        },
        binner: BinnerConfig {
            lo_c: 0.0,
            hi_c: 40.0,
            width_c: 2.5,
            n_channels: 3,
        },
        t_ref_c: 25.0,
    }
}

fn push_range(p: &mut FusedPipeline, log: &Log, lo: usize, hi: usize) {
    let ch = log.ch.slice_axis(Axis(0), Slice::from(lo..hi));
    p.push(&log.t[lo..hi], &log.temp[lo..hi], ch).unwrap();
}

/// The composition the pipeline fuses, with the kernels used one after the other.
fn composed(cfg: &PipelineConfig, log: &Log) -> (BinnedStats, Vec<LstsqSolution>) {
    let mut d = Decimator::new(cfg.decimator.clone()).unwrap();
    d.push(&log.t, &log.temp, log.ch.view()).unwrap();
    let blocks = d.finish().unwrap();
    let n = blocks.len();
    let ch = ArrayView2::from_shape((n, 3), &blocks.channels[..]).unwrap();
    let mut b = TemperatureBinner::new(cfg.binner.clone()).unwrap();
    b.push(&blocks.time_s, &blocks.temperature_c, ch).unwrap();
    let design = Array2::from_shape_fn((n, 2), |(i, j)| {
        if j == 0 {
            1.0
        } else {
            blocks.temperature_c[i] - cfg.t_ref_c
        }
    });
    let w: Vec<f64> = blocks.count.iter().map(|&c| c as f64).collect();
    let fits = (0..3)
        .map(|j| {
            let mut ls = LeastSquares::new(2, None).unwrap();
            let y: Vec<f64> = ch.column(j).to_vec();
            ls.push(design.view(), &y, Some(&w)).unwrap();
            ls.finish().unwrap()
        })
        .collect();
    (b.finish().unwrap(), fits)
}

fn close(a: f64, b: f64, rel: f64, scale: f64) -> bool {
    (a.is_nan() && b.is_nan()) || (a - b).abs() <= rel * (a.abs().max(b.abs()) + scale)
}

fn assert_all_close(what: &str, a: &[f64], b: &[f64], rel: f64, scale: f64) {
    assert_eq!(a.len(), b.len(), "{what}: lengths");
    for (i, (&x, &y)) in a.iter().zip(b).enumerate() {
        assert!(close(x, y, rel, scale), "{what}[{i}]: {x} vs {y}");
    }
}

/// Tolerances: every quantity is a short sum or Welford/Givens update of O(1)
/// values; different orders of the same operations differ by a few ulps per
/// step times the condition (~10 for these well-spread temperatures).
fn assert_matches(result: &PipelineResult, binned: &BinnedStats, fits: &[LstsqSolution]) {
    let r = &result.binned;
    assert_eq!(r.count, binned.count);
    assert_eq!(
        (r.n_below, r.n_above, r.n_nonfinite),
        (binned.n_below, binned.n_above, binned.n_nonfinite)
    );
    assert_all_close("time_s", &r.time_s, &binned.time_s, 1e-13, 0.0);
    assert_all_close(
        "temperature_c",
        &r.temperature_c,
        &binned.temperature_c,
        1e-12,
        1.0,
    );
    assert_all_close("mean", &r.mean, &binned.mean, 1e-12, 1.0);
    assert_all_close("variance", &r.variance, &binned.variance, 1e-7, 1e-12);
    for (f, g) in result.fits.iter().zip(fits) {
        assert_eq!(f.n_rows, g.n_rows);
        assert_all_close(
            "coefficients",
            &f.coefficients,
            &g.coefficients,
            1e-10,
            1e-3,
        );
        assert!(close(
            f.residual_sum_squares,
            g.residual_sum_squares,
            1e-6,
            1e-12
        ));
    }
}

#[test]
fn equals_composed_kernels() {
    for (nan_every, gap_every, min_count) in [(0, 0, 1), (37, 501, 1), (13, 97, 8)] {
        let log = make_log(20_000, 7, nan_every, gap_every);
        let cfg = config(None, min_count);
        let mut p = FusedPipeline::new(cfg.clone()).unwrap();
        p.push(&log.t, &log.temp, log.ch.view()).unwrap();
        let result = p.finish().unwrap();
        let (binned, fits) = composed(&cfg, &log);
        assert_matches(&result, &binned, &fits);
        assert_eq!(result.n_samples, 20_000);
        assert_eq!(result.fits[0].column_names, vec!["offset", "slope_per_c"]);
        if min_count > 1 {
            assert!(result.n_blocks_dropped > 0, "gaps leave short blocks");
        }
    }
}

#[test]
fn recovers_the_line() {
    let log = make_log(50_000, 3, 0, 0);
    let mut p = FusedPipeline::new(config(None, 1)).unwrap();
    p.push(&log.t, &log.temp, log.ch.view()).unwrap();
    let r = p.finish().unwrap();
    for (j, fit) in r.fits.iter().enumerate() {
        assert!((fit.coefficients[0] - 0.3 * j as f64).abs() < 1e-3);
        assert!((fit.coefficients[1] - 0.01 * (j as f64 + 1.0)).abs() < 1e-4);
    }
}

#[test]
fn empty_input_is_an_error() {
    let p = FusedPipeline::new(config(None, 1)).unwrap();
    assert!(matches!(p.finish(), Err(Error::Empty { .. })));
    let mut p = FusedPipeline::new(config(None, 1)).unwrap();
    p.push(&[], &[], Array2::zeros((0, 3)).view()).unwrap();
    assert!(matches!(p.finish(), Err(Error::Empty { .. })));
}

#[test]
fn config_is_validated() {
    let mut c = config(None, 1);
    c.binner.n_channels = 2;
    assert!(matches!(
        FusedPipeline::new(c),
        Err(Error::InvalidParameter {
            name: "n_channels",
            ..
        })
    ));
    let mut c = config(None, 1);
    c.t_ref_c = f64::NAN;
    assert!(matches!(
        FusedPipeline::new(c),
        Err(Error::InvalidParameter {
            name: "t_ref_c",
            ..
        })
    ));
    assert!(FusedPipeline::new(config(None, 0)).is_err());
}

#[test]
fn time_order_and_shape_errors() {
    let mut p = FusedPipeline::new(config(None, 1)).unwrap();
    let ch = Array2::zeros((3, 3));
    assert!(matches!(
        p.push(&[0.0, 1.0, 0.5], &[20.0; 3], ch.view()),
        Err(Error::TimeNotIncreasing { index: 2, .. })
    ));
    assert!(matches!(
        p.push(&[0.0, 1.0], &[20.0; 3], ch.view()),
        Err(Error::Shape { .. })
    ));
}

/// A block whose mean cannot enter the fit is reported, naming the row of the
/// fit (the first block is held back, so block 5 is the fit's row 4).
#[test]
fn non_finite_block_means_and_design_are_errors() {
    let push_error = |log: &Log, t_ref_c: f64| {
        let mut cfg = config(None, 1);
        cfg.t_ref_c = t_ref_c;
        let mut p = FusedPipeline::new(cfg).unwrap();
        match p.push(&log.t, &log.temp, log.ch.view()) {
            Err(Error::NonFinite { what, row, column }) => (what, row, column),
            other => panic!("expected a NonFinite error, got {other:?}"),
        }
    };
    // Two finite channel values whose sum overflows: block 5's mean is +inf.
    let mut log = make_log(200, 3, 0, 0);
    for i in 54..56 {
        log.ch[[i, 1]] = 1e308;
    }
    assert_eq!(push_error(&log, 25.0), ("response", 4, 1));
    // Finite temperatures whose difference from t_ref overflows.
    let mut log = make_log(200, 3, 0, 0);
    for i in 50..60 {
        log.temp[i] = 1e308;
    }
    let design = "design (temperature_c - t_ref_c)";
    assert_eq!(push_error(&log, -1.5e308), (design, 4, 1));
}

#[test]
fn merge_needs_a_shared_grid() {
    let log = make_log(4000, 1, 0, 0);
    let mut a = FusedPipeline::new(config(None, 1)).unwrap();
    let mut b = FusedPipeline::new(config(None, 1)).unwrap();
    push_range(&mut a, &log, 0, 2005);
    push_range(&mut b, &log, 2005, 4000);
    assert!(matches!(a.merge(&b), Err(Error::Incompatible { .. })));
}

#[test]
fn merge_rejects_overlap_and_other_configs() {
    let log = make_log(4000, 1, 0, 0);
    let t0 = Some(log.t[0]);
    let mut a = FusedPipeline::new(config(t0, 1)).unwrap();
    let mut b = FusedPipeline::new(config(t0, 1)).unwrap();
    push_range(&mut a, &log, 0, 3000);
    push_range(&mut b, &log, 2000, 4000);
    // NaN (empty bins) != NaN: compare the Debug text.
    let before = format!("{:?}", a.finish().unwrap());
    assert!(matches!(a.merge(&b), Err(Error::Incompatible { .. })));
    let after = format!("{:?}", a.finish().unwrap());
    assert_eq!(after, before, "a failed merge changes nothing");
    let mut c = config(t0, 1);
    c.t_ref_c = 20.0;
    let c = FusedPipeline::new(c).unwrap();
    assert!(matches!(a.merge(&c), Err(Error::Incompatible { .. })));
}

#[test]
fn memory_does_not_grow_with_the_log() {
    // Only held-back blocks, bins and R factors are kept: ten times more data
    // leaves the state (seen through its Debug text) the same size, give or
    // take the digits of the numbers.
    let mut p = FusedPipeline::new(config(Some(0.0), 1)).unwrap();
    let log = make_log(20_000, 5, 0, 0);
    let span = log.t[log.t.len() - 1] + 1.0;
    let mut sizes = Vec::new();
    for copy in 0..10 {
        let t: Vec<f64> = log.t.iter().map(|t| t + span * f64::from(copy)).collect();
        p.push(&t, &log.temp, log.ch.view()).unwrap();
        sizes.push(format!("{p:?}").len());
    }
    assert!(sizes[9] < sizes[0] + 1_000, "{sizes:?}");
}

fn split_points(n: usize) -> impl Strategy<Value = Vec<usize>> {
    proptest::collection::vec(0..=n, 0..6).prop_map(|mut v| {
        v.sort_unstable();
        v
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Any cut of the stream into `push` calls gives a bitwise identical result.
    #[test]
    fn chunking_is_invisible(
        seed in 0u64..1000,
        n in 50usize..30_000,
        nan_every in prop_oneof![Just(0usize), 3usize..200],
        gap_every in prop_oneof![Just(0usize), 5usize..2000],
        cuts in split_points(30_000),
    ) {
        let log = make_log(n, seed, nan_every, gap_every);
        let cfg = config(None, 2);
        let mut one = FusedPipeline::new(cfg.clone()).unwrap();
        one.push(&log.t, &log.temp, log.ch.view()).unwrap();
        let mut many = FusedPipeline::new(cfg).unwrap();
        let mut lo = 0;
        for &c in cuts.iter().map(|c| c.min(&n)).chain([&n]) {
            push_range(&mut many, &log, lo, c);
            lo = c;
        }
        let (a, b) = (one.finish(), many.finish());
        match (a, b) {
            // Debug text: bitwise equal, NaN included.
            (Ok(a), Ok(b)) => prop_assert_eq!(format!("{a:?}"), format!("{b:?}")),
            (Err(_), Err(_)) => {}
            (a, b) => prop_assert!(false, "{:?} vs {:?}", a.is_ok(), b.is_ok()),
        }
    }

    /// Pieces cut anywhere (inside blocks too), processed separately and merged
    /// in any order, equal one pass up to rounding.
    #[test]
    fn merge_equals_one_pass(
        seed in 0u64..1000,
        n in 200usize..20_000,
        nan_every in prop_oneof![Just(0usize), 3usize..200],
        gap_every in prop_oneof![Just(0usize), 5usize..2000],
        cuts in split_points(20_000),
        order in proptest::collection::vec(any::<proptest::sample::Index>(), 6),
    ) {
        let log = make_log(n, seed, nan_every, gap_every);
        let cfg = config(Some(log.t[0] - 0.02), 1);
        let mut one = FusedPipeline::new(cfg.clone()).unwrap();
        one.push(&log.t, &log.temp, log.ch.view()).unwrap();
        let Ok(expected) = one.finish() else { return Ok(()); };

        let mut bounds: Vec<usize> = cuts.iter().map(|&c| c.min(n)).collect();
        bounds.insert(0, 0);
        bounds.push(n);
        let mut pieces: Vec<FusedPipeline> = bounds
            .windows(2)
            .map(|w| {
                let mut p = FusedPipeline::new(cfg.clone()).unwrap();
                push_range(&mut p, &log, w[0], w[1]);
                p
            })
            .collect();
        // Merge pieces pairwise in a random order: a piece absorbs a neighbour.
        let mut k = 0;
        while pieces.len() > 1 {
            let i = order[k % order.len()].index(pieces.len() - 1);
            k += 1;
            let right = pieces.remove(i + 1);
            if k % 2 == 0 {
                pieces[i].merge(&right).unwrap();
            } else {
                let mut r = right;
                r.merge(&pieces[i]).unwrap();
                pieces[i] = r;
            }
        }
        let merged = pieces.pop().unwrap();
        let got = merged.finish().unwrap();
        prop_assert_eq!(got.n_samples, expected.n_samples);
        prop_assert_eq!(got.n_skipped_nonfinite, expected.n_skipped_nonfinite);
        prop_assert_eq!(got.n_blocks, expected.n_blocks);
        assert_matches(&got, &expected.binned, &expected.fits);

        // The merged pipeline keeps streaming: push more after the end.
        let mut cont = merged;
        let last = log.t[n - 1];
        let t = [last + 0.05, last + 0.1];
        cont.push(&t, &[20.0, 20.0], Array2::zeros((2, 3)).view()).unwrap();
        prop_assert_eq!(cont.n_samples(), n as u64 + 2);
    }
}
