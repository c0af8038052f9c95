//! Temperature binner: named semantics tests and chunking/merge properties.
use accelcore_core::{BinnedStats, BinnerConfig, Error, TemperatureBinner};
use ndarray::Array2;
use proptest::prelude::*;

fn cfg(lo_c: f64, hi_c: f64, width_c: f64, n_channels: usize) -> BinnerConfig {
    BinnerConfig {
        lo_c,
        hi_c,
        width_c,
        n_channels,
    }
}

/// Push (temperature, channel) pairs into a 1-channel binner; time = row number.
fn push_1ch(b: &mut TemperatureBinner, temps: &[f64], values: &[f64]) {
    let t: Vec<f64> = (0..temps.len()).map(|i| i as f64).collect();
    let ch = Array2::from_shape_vec((values.len(), 1), values.to_vec()).unwrap();
    b.push(&t, temps, ch.view()).unwrap();
}

#[test]
fn basic_stats() {
    let mut b = TemperatureBinner::new(cfg(0.0, 2.0, 1.0, 1)).unwrap();
    push_1ch(&mut b, &[0.2, 0.4, 0.9, 1.5], &[1.0, 2.0, 6.0, 7.0]);
    let s = b.finish().unwrap();
    assert_eq!(s.edges_c, vec![0.0, 1.0, 2.0]);
    assert_eq!(s.count, vec![3, 1]);
    assert_eq!(s.time_s, vec![1.0, 3.0]);
    assert!((s.temperature_c[0] - 0.5).abs() < 1e-15);
    assert_eq!(s.mean, vec![3.0, 7.0]);
    assert!((s.variance[0] - 7.0).abs() < 1e-14);
    assert!(s.variance[1].is_nan());
}

#[test]
fn bin_closure_lo_inclusive_hi_exclusive() {
    let mut b = TemperatureBinner::new(cfg(-10.0, 10.0, 0.5, 1)).unwrap();
    let temps = [
        -10.0,
        10.0,
        -10.000_000_000_000_002,
        9.999_999_999_999_998,
        0.5,
        -0.5,
        0.0,
    ];
    push_1ch(&mut b, &temps, &[1.0; 7]);
    let s = b.finish().unwrap();
    assert_eq!(s.n_below, 1);
    assert_eq!(s.n_above, 1);
    assert_eq!(s.count[0], 1, "T == lo goes to bin 0");
    assert_eq!(s.count[39], 1, "just below hi goes to the last bin");
    // interior edges go to the upper bin
    assert_eq!(s.count[21], 1, "T = 0.5 is the lower edge of bin 21");
    assert_eq!(s.count[19], 1, "T = -0.5 is the lower edge of bin 19");
    assert_eq!(s.count[20], 1, "T = 0.0 is the lower edge of bin 20");
    assert_eq!(s.count.iter().sum::<u64>(), 5);
    assert_eq!(s.edges_c[20], 0.0);
    assert_eq!(s.edges_c[21], 0.5);
}

#[test]
fn narrow_last_bin_and_clamp() {
    let mut b = TemperatureBinner::new(cfg(0.0, 1.25, 0.5, 1)).unwrap();
    assert_eq!(b.n_bins(), 3);
    push_1ch(&mut b, &[1.0, 1.2, 1.25], &[1.0, 1.0, 1.0]);
    let s = b.finish().unwrap();
    assert_eq!(s.edges_c, vec![0.0, 0.5, 1.0, 1.25]);
    assert_eq!(s.count, vec![0, 0, 2]);
    assert_eq!(s.n_above, 1);
    // tolerance: (hi - lo)/width just above an integer does not add a bin,
    // values there are clamped into the last bin
    let mut b = TemperatureBinner::new(cfg(0.0, 1.0 + 1e-12, 0.5, 1)).unwrap();
    assert_eq!(b.n_bins(), 2);
    push_1ch(&mut b, &[1.0 + 5e-13], &[1.0]);
    assert_eq!(b.finish().unwrap().count, vec![0, 1]);
    assert_eq!(b.edges_c(), vec![0.0, 0.5, 1.0 + 1e-12]);
}

#[test]
fn nan_policy_skips_rows() {
    let mut b = TemperatureBinner::new(cfg(0.0, 10.0, 1.0, 2)).unwrap();
    let t = [0.0, f64::NAN, 2.0, 3.0, 4.0, f64::INFINITY];
    let temp = [1.0, 1.0, f64::NAN, 1.0, 1.0, 1.0];
    let ch = Array2::from_shape_vec(
        (6, 2),
        vec![
            1.0,
            2.0,
            1.0,
            2.0,
            1.0,
            2.0,
            f64::NAN,
            2.0,
            3.0,
            f64::NEG_INFINITY,
            1.0,
            2.0,
        ],
    )
    .unwrap();
    b.push(&t, &temp, ch.view()).unwrap();
    let s = b.finish().unwrap();
    assert_eq!(s.n_nonfinite, 5);
    assert_eq!(s.count[1], 1);
    assert_eq!(&s.mean[2..4], &[1.0, 2.0]);
    // non-finite temperature is never counted as below/above
    assert_eq!((s.n_below, s.n_above), (0, 0));
    // a time order is not required
    b.push(
        &[10.0, -5.0],
        &[1.5, 1.5],
        Array2::from_elem((2, 2), 1.0).view(),
    )
    .unwrap();
    assert_eq!(b.finish().unwrap().count[1], 3);
}

#[test]
fn empty_input_finish_is_error() {
    let b = TemperatureBinner::new(BinnerConfig::default()).unwrap();
    assert!(matches!(b.finish(), Err(Error::Empty { .. })));
}

#[test]
fn only_out_of_window_or_nan_is_empty() {
    let mut b = TemperatureBinner::new(cfg(0.0, 10.0, 1.0, 1)).unwrap();
    push_1ch(&mut b, &[-1.0, 10.0, 20.0, f64::NAN], &[1.0; 4]);
    assert!(matches!(b.finish(), Err(Error::Empty { .. })));
}

#[test]
fn empty_chunk_changes_nothing() {
    let mut b = TemperatureBinner::new(cfg(0.0, 10.0, 1.0, 3)).unwrap();
    b.push(&[], &[], Array2::zeros((0, 3)).view()).unwrap();
    assert!(matches!(b.finish(), Err(Error::Empty { .. })));
    b.push(&[0.0], &[5.0], Array2::from_elem((1, 3), 1.0).view())
        .unwrap();
    let before = b.finish().unwrap();
    b.push(&[], &[], Array2::zeros((0, 3)).view()).unwrap();
    assert_stats_close(&b.finish().unwrap(), &before, 0.0, 0.0);
}

#[test]
fn empty_bins_are_nan() {
    let mut b = TemperatureBinner::new(cfg(0.0, 3.0, 1.0, 1)).unwrap();
    push_1ch(&mut b, &[1.5, 1.6], &[1.0, 2.0]);
    let s = b.finish().unwrap();
    assert_eq!(s.count, vec![0, 2, 0]);
    for i in [0, 2] {
        assert!(s.mean[i].is_nan() && s.variance[i].is_nan());
        assert!(s.time_s[i].is_nan() && s.temperature_c[i].is_nan());
    }
    assert_eq!(s.variance[1], 0.5);
}

#[test]
fn shape_errors() {
    let mut b = TemperatureBinner::new(cfg(0.0, 10.0, 1.0, 2)).unwrap();
    let ch = Array2::<f64>::zeros((2, 2));
    assert!(matches!(
        b.push(&[0.0, 1.0], &[0.0], ch.view()),
        Err(Error::Shape { .. })
    ));
    assert!(matches!(
        b.push(&[0.0], &[0.0], ch.view()),
        Err(Error::Shape { .. })
    ));
    let ch1 = Array2::<f64>::zeros((2, 1));
    assert!(matches!(
        b.push(&[0.0, 1.0], &[0.0, 1.0], ch1.view()),
        Err(Error::Shape {
            expected: 2,
            got: 1,
            ..
        })
    ));
}

#[test]
fn invalid_configs() {
    for c in [
        cfg(0.0, 0.0, 1.0, 1),
        cfg(1.0, 0.0, 1.0, 1),
        cfg(0.0, 1.0, 0.0, 1),
        cfg(0.0, 1.0, -1.0, 1),
        cfg(f64::NAN, 1.0, 1.0, 1),
        cfg(0.0, f64::INFINITY, 1.0, 1),
        cfg(0.0, 1.0, f64::NAN, 1),
        cfg(0.0, 1e8, 1.0, 1), // too many bins
    ] {
        assert!(matches!(
            TemperatureBinner::new(c),
            Err(Error::InvalidParameter { .. })
        ));
    }
    assert_eq!(
        TemperatureBinner::new(cfg(0.0, 1e7, 1.0, 0))
            .unwrap()
            .n_bins(),
        10_000_000
    );
}

#[test]
fn large_offset_variance_is_stable() {
    // 16000 + tiny variations of ~1e-6: exact variance known from the deviations.
    let n = 10_000;
    let dev: Vec<f64> = (0..n)
        .map(|i| ((i * 7919) % 1000) as f64 * 2e-9 - 1e-6)
        .collect();
    let values: Vec<f64> = dev.iter().map(|d| 16000.0 + d).collect();
    // reference from the stored values, two-pass in extended form around 16000
    let shifted: Vec<f64> = values.iter().map(|v| v - 16000.0).collect(); // exact (Sterbenz)
    let mean_s = shifted.iter().sum::<f64>() / n as f64;
    let var_ref = shifted.iter().map(|x| (x - mean_s).powi(2)).sum::<f64>() / (n - 1) as f64;
    assert!(var_ref > 1e-13 && var_ref < 1e-12);

    let mut one = TemperatureBinner::new(cfg(0.0, 60.0, 0.5, 1)).unwrap();
    push_1ch(&mut one, &vec![25.0; n], &values);
    let s = one.finish().unwrap();
    let rel = (s.variance[50] - var_ref).abs() / var_ref;
    assert!(rel < 1e-10, "relative error {rel}");
    // mean: relative error ~1e-15 (a few ulps of 16000, ulp = 3.6e-12)
    let err = (s.mean[50] - 16000.0 - mean_s).abs();
    assert!(err < 1e-14 * 16000.0, "mean error {err}");

    // the same through merges of many pieces
    let mut acc = TemperatureBinner::new(cfg(0.0, 60.0, 0.5, 1)).unwrap();
    for chunk in values.chunks(37) {
        let mut p = TemperatureBinner::new(cfg(0.0, 60.0, 0.5, 1)).unwrap();
        push_1ch(&mut p, &vec![25.0; chunk.len()], chunk);
        acc.merge(&p).unwrap();
    }
    let s = acc.finish().unwrap();
    let rel = (s.variance[50] - var_ref).abs() / var_ref;
    assert!(rel < 1e-10, "relative error after merge {rel}");
}

#[test]
fn merge_with_empty() {
    let c = cfg(0.0, 10.0, 1.0, 1);
    let mut full = TemperatureBinner::new(c.clone()).unwrap();
    push_1ch(
        &mut full,
        &[1.0, 1.5, 3.0, -2.0, 12.0],
        &[1.0, 2.0, 3.0, 4.0, 5.0],
    );
    let expected = full.finish().unwrap();
    let mut a = full.clone();
    a.merge(&TemperatureBinner::new(c.clone()).unwrap())
        .unwrap();
    assert_stats_close(&a.finish().unwrap(), &expected, 0.0, 0.0);
    let mut e = TemperatureBinner::new(c).unwrap();
    e.merge(&full).unwrap();
    assert_stats_close(&e.finish().unwrap(), &expected, 0.0, 0.0);
    assert_eq!(
        (e.finish().unwrap().n_below, e.finish().unwrap().n_above),
        (1, 1)
    );
}

#[test]
fn merge_config_mismatch_is_incompatible() {
    let base = cfg(0.0, 10.0, 1.0, 1);
    let mut a = TemperatureBinner::new(base.clone()).unwrap();
    for other in [
        cfg(0.5, 10.0, 1.0, 1),
        cfg(0.0, 10.5, 1.0, 1),
        cfg(0.0, 10.0, 0.5, 1),
        cfg(0.0, 10.0, 1.0, 2),
        cfg(-0.0, 10.0, 1.0, 1), // bitwise comparison
    ] {
        let b = TemperatureBinner::new(other).unwrap();
        assert!(matches!(a.merge(&b), Err(Error::Incompatible { .. })));
    }
}

fn close(a: f64, b: f64, rel: f64, abs: f64) -> bool {
    (a.is_nan() && b.is_nan()) || a == b || (a - b).abs() <= abs + rel * a.abs().max(b.abs())
}

/// Compare stats with relative tolerance `rel` plus absolute slack `abs`
/// (scaled to the data's magnitude by the caller: means near zero of data
/// of magnitude M carry absolute rounding ~ eps * M).
fn assert_stats_close(a: &BinnedStats, b: &BinnedStats, rel: f64, abs: f64) {
    assert_eq!(a.n_channels, b.n_channels);
    assert_eq!(a.edges_c, b.edges_c);
    assert_eq!(a.count, b.count);
    assert_eq!(
        (a.n_below, a.n_above, a.n_nonfinite),
        (b.n_below, b.n_above, b.n_nonfinite)
    );
    for (x, y, abs) in [
        (&a.time_s, &b.time_s, abs),
        (&a.temperature_c, &b.temperature_c, abs),
        (&a.mean, &b.mean, abs),
        (&a.variance, &b.variance, abs),
    ] {
        assert_eq!(x.len(), y.len());
        for (p, q) in x.iter().zip(y.iter()) {
            assert!(close(*p, *q, rel, abs), "{p} vs {q}");
        }
    }
}

// ---------------------------------------------------------------- properties

type Row = [f64; 4]; // time, temperature, ch0, ch1

fn rows() -> impl Strategy<Value = Vec<Row>> {
    prop::collection::vec(
        (
            -1.0e3f64..1.0e3,
            -5.0f64..15.0,
            prop::array::uniform2(-100.0f64..100.0),
            0u8..40,
        )
            .prop_map(|(t, temp, ch, bad)| {
                let mut r = [t, temp, ch[0], ch[1]];
                if (bad as usize) < r.len() {
                    r[bad as usize] = f64::NAN;
                }
                r
            }),
        0..150,
    )
}

fn push_rows(b: &mut TemperatureBinner, rows: &[Row]) {
    let t: Vec<f64> = rows.iter().map(|r| r[0]).collect();
    let temp: Vec<f64> = rows.iter().map(|r| r[1]).collect();
    let ch: Vec<f64> = rows.iter().flat_map(|r| [r[2], r[3]]).collect();
    let ch = Array2::from_shape_vec((rows.len(), 2), ch).unwrap();
    b.push(&t, &temp, ch.view()).unwrap();
}

fn build(rows: &[Row]) -> TemperatureBinner {
    let mut b = TemperatureBinner::new(cfg(0.0, 10.0, 0.75, 2)).unwrap();
    push_rows(&mut b, rows);
    b
}

fn cuts(n: usize, raw: &[usize]) -> Vec<usize> {
    let mut c: Vec<usize> = raw.iter().map(|r| r % (n + 1)).collect();
    c.push(0);
    c.push(n);
    c.sort_unstable();
    c
}

fn same(a: &TemperatureBinner, b: &TemperatureBinner, rel: f64) {
    match (a.finish(), b.finish()) {
        // data up to 1e3 (time) and 100 (channels): absolute rounding of means
        // ~ eps * 1e3, of variances ~ eps * n * 100^2
        (Ok(x), Ok(y)) => assert_stats_close(&x, &y, rel, if rel == 0.0 { 0.0 } else { 1e-9 }),
        (Err(x), Err(y)) => assert_eq!(x, y),
        (x, y) => panic!("{x:?} vs {y:?}"),
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn chunked_push_is_bitwise_one_push(rows in rows(), raw in prop::collection::vec(0usize..200, 0..8)) {
        let one = build(&rows);
        let mut chunked = TemperatureBinner::new(one.config().clone()).unwrap();
        for w in cuts(rows.len(), &raw).windows(2) {
            push_rows(&mut chunked, &rows[w[0]..w[1]]);
        }
        same(&one, &chunked, 0.0);
    }

    #[test]
    fn merged_pieces_equal_one_pass(rows in rows(), raw in prop::collection::vec(0usize..200, 0..6)) {
        let one = build(&rows);
        let mut acc = TemperatureBinner::new(one.config().clone()).unwrap();
        for w in cuts(rows.len(), &raw).windows(2) {
            acc.merge(&build(&rows[w[0]..w[1]])).unwrap();
        }
        same(&one, &acc, 1e-12);
    }

    #[test]
    fn merge_is_associative(rows in rows(), i in 0usize..200, j in 0usize..200) {
        let c = cuts(rows.len(), &[i, j]);
        let (a, b, cc) = (build(&rows[c[0]..c[1]]), build(&rows[c[1]..c[2]]), build(&rows[c[2]..c[3]]));
        let mut left = a.clone();
        left.merge(&b).unwrap();
        left.merge(&cc).unwrap();
        let mut bc = b.clone();
        bc.merge(&cc).unwrap();
        let mut right = a;
        right.merge(&bc).unwrap();
        same(&left, &right, 1e-12);
    }

    #[test]
    fn matches_two_pass_reference(rows in rows()) {
        let b = build(&rows);
        let Ok(s) = b.finish() else { return Ok(()); };
        let nb = b.n_bins();
        for bin in 0..nb {
            let members: Vec<&Row> = rows
                .iter()
                .filter(|r| r.iter().all(|v| v.is_finite()))
                .filter(|r| r[1] >= 0.0 && r[1] < 10.0)
                .filter(|r| (((r[1] / 0.75).floor() as usize).min(nb - 1)) == bin)
                .collect();
            prop_assert_eq!(s.count[bin], members.len() as u64);
            if members.len() >= 2 {
                for ch in 0..2 {
                    let n = members.len() as f64;
                    let m = members.iter().map(|r| r[2 + ch]).sum::<f64>() / n;
                    let v = members.iter().map(|r| (r[2 + ch] - m).powi(2)).sum::<f64>() / (n - 1.0);
                    prop_assert!(close(s.mean[bin * 2 + ch], m, 1e-12, 1e-12));
                    prop_assert!(close(s.variance[bin * 2 + ch], v, 1e-10, 1e-10));
                }
            }
        }
    }
}
