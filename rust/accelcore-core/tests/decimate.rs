//! Decimator: named semantics tests and chunking/merge invariance properties.
use accelcore_core::{DecimatedBlocks, Decimator, DecimatorConfig, Error};
use ndarray::{Array2, ArrayView2};
use proptest::prelude::*;

fn cfg(factor: usize, rate_hz: f64, n_channels: usize) -> DecimatorConfig {
    DecimatorConfig {
        factor,
        rate_hz,
        n_channels,
        min_count: 1,
        t0_s: None,
    }
}

/// Rows of (time, temperature, channels...) pushed as one chunk.
fn push_rows(d: &mut Decimator, rows: &[Vec<f64>]) -> accelcore_core::Result<()> {
    let nc = d.config().n_channels;
    let t: Vec<f64> = rows.iter().map(|r| r[0]).collect();
    let temp: Vec<f64> = rows.iter().map(|r| r[1]).collect();
    let ch: Vec<f64> = rows.iter().flat_map(|r| r[2..2 + nc].to_vec()).collect();
    let ch = Array2::from_shape_vec((rows.len(), nc), ch).unwrap();
    d.push(&t, &temp, ch.view())
}

fn empty_channels(nc: usize) -> Array2<f64> {
    Array2::zeros((0, nc))
}

/// 20 Hz rows starting at `t_start`, one channel = 2 * time.
fn ramp(t_start: f64, n: usize) -> Vec<Vec<f64>> {
    (0..n)
        .map(|i| {
            let t = t_start + i as f64 / 20.0;
            vec![t, 25.0, 2.0 * t]
        })
        .collect()
}

#[test]
fn block_means_basic() {
    let mut d = Decimator::new(cfg(2, 1.0, 1)).unwrap();
    push_rows(
        &mut d,
        &[
            vec![0.0, 10.0, 1.0],
            vec![1.0, 12.0, 3.0],
            vec![2.0, 14.0, 5.0],
            vec![3.0, 16.0, 7.0],
            vec![4.0, 18.0, 9.0],
        ],
    )
    .unwrap();
    let out = d.finish().unwrap();
    assert_eq!(out.n_channels, 1);
    assert_eq!(out.block_index, vec![0, 1, 2]);
    assert_eq!(out.count, vec![2, 2, 1]);
    assert_eq!(out.time_s, vec![0.5, 2.5, 4.0]);
    assert_eq!(out.temperature_c, vec![11.0, 15.0, 18.0]);
    assert_eq!(out.channels, vec![2.0, 6.0, 9.0]);
    assert_eq!(d.config().t0_s, Some(0.0));
    assert_eq!(d.n_samples(), 5);
    assert_eq!(d.n_skipped_nonfinite(), 0);
}

#[test]
fn nan_policy_skips_invalid_rows() {
    let mut d = Decimator::new(cfg(2, 1.0, 2)).unwrap();
    push_rows(
        &mut d,
        &[
            vec![f64::NAN, 1.0, 1.0, 1.0],          // no time: skipped, t0 not set
            vec![0.0, f64::NAN, 100.0, 1.0],        // skipped, but sets t0 and time order
            vec![0.5, 1.0, 2.0, 4.0],               // block 0
            vec![1.0, 1.0, f64::INFINITY, 1.0],     // skipped
            vec![1.5, 3.0, 4.0, 8.0],               // block 0
            vec![2.0, 1.0, 1.0, f64::NEG_INFINITY], // skipped
            vec![f64::INFINITY, 1.0, 1.0, 1.0],     // skipped, no order check
            vec![2.5, 5.0, 6.0, 0.0],               // block 1
        ],
    )
    .unwrap();
    assert_eq!(d.config().t0_s, Some(0.0));
    assert_eq!(d.n_samples(), 8);
    assert_eq!(d.n_skipped_nonfinite(), 5);
    let out = d.finish().unwrap();
    assert_eq!(out.block_index, vec![0, 1]);
    assert_eq!(out.count, vec![2, 1]);
    assert_eq!(out.time_s, vec![1.0, 2.5]);
    assert_eq!(out.temperature_c, vec![2.0, 5.0]);
    assert_eq!(out.channels, vec![3.0, 6.0, 6.0, 0.0]);
}

#[test]
fn invalid_row_with_finite_time_takes_part_in_order_check() {
    let mut d = Decimator::new(cfg(2, 1.0, 1)).unwrap();
    push_rows(&mut d, &[vec![0.0, 1.0, 1.0], vec![5.0, f64::NAN, 1.0]]).unwrap();
    let err = push_rows(&mut d, &[vec![4.0, 1.0, 1.0]]).unwrap_err();
    assert_eq!(
        err,
        Error::TimeNotIncreasing {
            index: 2,
            previous_s: 5.0,
            time_s: 4.0
        }
    );
}

#[test]
fn empty_input_finish_is_error() {
    let d = Decimator::new(DecimatorConfig::default()).unwrap();
    assert!(matches!(d.finish(), Err(Error::Empty { .. })));
    assert_eq!(d.config().t0_s, None);
}

#[test]
fn all_invalid_finish_is_error() {
    let mut d = Decimator::new(cfg(2, 1.0, 1)).unwrap();
    push_rows(
        &mut d,
        &[vec![f64::NAN, 1.0, 1.0], vec![1.0, 1.0, f64::NAN]],
    )
    .unwrap();
    assert!(matches!(d.finish(), Err(Error::Empty { .. })));
    assert_eq!(d.n_samples(), 2);
    assert_eq!(d.n_skipped_nonfinite(), 2);
}

#[test]
fn empty_chunk_changes_nothing() {
    let mut d = Decimator::new(cfg(10, 20.0, 3)).unwrap();
    d.push(&[], &[], empty_channels(3).view()).unwrap();
    assert_eq!(d.n_samples(), 0);
    assert_eq!(d.config().t0_s, None);
    let rows: Vec<Vec<f64>> = (0..25)
        .map(|i| vec![f64::from(i) / 20.0, 1.0, 1.0, 2.0, 3.0])
        .collect();
    push_rows(&mut d, &rows).unwrap();
    let before = d.finish().unwrap();
    d.push(&[], &[], empty_channels(3).view()).unwrap();
    assert_eq!(d.finish().unwrap(), before);
    assert_eq!(d.n_samples(), 25);
}

#[test]
fn zero_channels() {
    let mut d = Decimator::new(cfg(2, 1.0, 0)).unwrap();
    d.push(
        &[0.0, 1.0, 2.0],
        &[1.0, 3.0, 5.0],
        empty_channels(0)
            .into_shape_with_order((3, 0))
            .unwrap()
            .view(),
    )
    .unwrap();
    let out = d.finish().unwrap();
    assert_eq!(out.temperature_c, vec![2.0, 5.0]);
    assert!(out.channels.is_empty());
}

#[test]
fn shape_errors() {
    let mut d = Decimator::new(cfg(2, 1.0, 2)).unwrap();
    let ch = Array2::<f64>::zeros((3, 2));
    assert!(matches!(
        d.push(&[0.0, 1.0, 2.0], &[0.0, 1.0], ch.view()),
        Err(Error::Shape { .. })
    ));
    assert!(matches!(
        d.push(&[0.0, 1.0], &[0.0, 1.0], ch.view()),
        Err(Error::Shape { .. })
    ));
    let ch3 = Array2::<f64>::zeros((3, 3));
    assert!(matches!(
        d.push(&[0.0, 1.0, 2.0], &[0.0, 1.0, 2.0], ch3.view()),
        Err(Error::Shape {
            what: _,
            expected: 2,
            got: 3
        })
    ));
    assert_eq!(d.n_samples(), 0);
}

#[test]
fn gap_keeps_later_blocks_aligned() {
    // 20 Hz, factor 10: blocks of 0.5 s anchored at t0 = 100.
    let mut d = Decimator::new(cfg(10, 20.0, 1)).unwrap();
    let mut rows = ramp(100.0, 20); // 100.00 .. 100.95
                                    // gap of 3.3 s after the last sample: next sample at 100.95 + 3.3 = 104.25
    rows.extend(ramp(104.25, 20)); // 104.25 .. 105.20
    push_rows(&mut d, &rows).unwrap();
    let out = d.finish().unwrap();
    // 104.25 - 100 = 4.25 s -> block 8 ([104.0, 104.5)), 5 samples 104.25..104.45
    assert_eq!(out.block_index, vec![0, 1, 8, 9, 10]);
    assert_eq!(out.count, vec![10, 10, 5, 10, 5]);
    for (k, t) in out.block_index.iter().zip(&out.time_s) {
        let lo = 100.0 + *k as f64 * 0.5;
        assert!(*t >= lo && *t < lo + 0.5, "block {k} mean time {t}");
    }
}

#[test]
fn explicit_t0_defines_grid() {
    let mut d = Decimator::new(DecimatorConfig {
        t0_s: Some(0.0),
        ..cfg(10, 20.0, 1)
    })
    .unwrap();
    push_rows(&mut d, &ramp(0.25, 10)).unwrap(); // 0.25 .. 0.70
    let out = d.finish().unwrap();
    assert_eq!(out.block_index, vec![0, 1]);
    assert_eq!(out.count, vec![5, 5]);
    // samples before t0 get negative block indices
    let mut d = Decimator::new(DecimatorConfig {
        t0_s: Some(1.0),
        ..cfg(10, 20.0, 1)
    })
    .unwrap();
    push_rows(&mut d, &ramp(0.0, 30)).unwrap();
    assert_eq!(d.finish().unwrap().block_index, vec![-2, -1, 0]);
}

#[test]
fn min_count_drops_sparse_blocks() {
    let mut d = Decimator::new(DecimatorConfig {
        min_count: 3,
        ..cfg(4, 1.0, 1)
    })
    .unwrap();
    // block 0: 4 samples; block 1: 2 samples (4, 6); block 2: 3 samples (8, 9, 10)
    let times = [0.0, 1.0, 2.0, 3.0, 4.0, 6.0, 8.0, 9.0, 10.0];
    let rows: Vec<Vec<f64>> = times.iter().map(|&t| vec![t, 0.0, t]).collect();
    push_rows(&mut d, &rows).unwrap();
    let out = d.finish().unwrap();
    assert_eq!(out.block_index, vec![0, 2]);
    assert_eq!(out.count, vec![4, 3]);
    // only sparse blocks -> Empty
    let mut d = Decimator::new(DecimatorConfig {
        min_count: 3,
        ..cfg(4, 1.0, 1)
    })
    .unwrap();
    push_rows(&mut d, &[vec![0.0, 0.0, 0.0], vec![5.0, 0.0, 0.0]]).unwrap();
    assert!(matches!(d.finish(), Err(Error::Empty { .. })));
}

#[test]
fn time_going_backwards_reports_global_index_and_leaves_state() {
    let mut d = Decimator::new(cfg(2, 1.0, 1)).unwrap();
    push_rows(
        &mut d,
        &[
            vec![0.0, 0.0, 0.0],
            vec![1.0, 0.0, 0.0],
            vec![2.0, 0.0, 0.0],
        ],
    )
    .unwrap();
    let before = d.finish().unwrap();
    let err = push_rows(
        &mut d,
        &[
            vec![3.0, 0.0, 0.0],
            vec![f64::NAN, 0.0, 0.0],
            vec![4.0, 0.0, 0.0],
            vec![3.5, 0.0, 0.0],
        ],
    )
    .unwrap_err();
    assert_eq!(
        err,
        Error::TimeNotIncreasing {
            index: 6,
            previous_s: 4.0,
            time_s: 3.5
        }
    );
    assert_eq!(d.finish().unwrap(), before);
    assert_eq!(d.n_samples(), 3);
    // equal time is also rejected, across pushes
    let err = push_rows(&mut d, &[vec![2.0, 0.0, 0.0]]).unwrap_err();
    assert_eq!(
        err,
        Error::TimeNotIncreasing {
            index: 3,
            previous_s: 2.0,
            time_s: 2.0
        }
    );
    // the decimator still works afterwards
    push_rows(&mut d, &[vec![2.5, 0.0, 0.0]]).unwrap();
    assert_eq!(d.n_samples(), 4);
}

#[test]
fn failed_first_push_does_not_set_t0() {
    let mut d = Decimator::new(cfg(2, 1.0, 1)).unwrap();
    assert!(push_rows(&mut d, &[vec![1.0, 0.0, 0.0], vec![0.5, 0.0, 0.0]]).is_err());
    assert_eq!(d.config().t0_s, None);
    assert_eq!(d.n_samples(), 0);
}

#[test]
fn finish_is_repeatable_and_push_continues() {
    let mut d = Decimator::new(cfg(10, 20.0, 1)).unwrap();
    push_rows(&mut d, &ramp(0.0, 15)).unwrap();
    let a = d.finish().unwrap();
    assert_eq!(d.finish().unwrap(), a);
    push_rows(&mut d, &ramp(0.75, 5)).unwrap();
    let mut one = Decimator::new(cfg(10, 20.0, 1)).unwrap();
    push_rows(&mut one, &ramp(0.0, 20)).unwrap();
    assert_eq!(d.finish().unwrap(), one.finish().unwrap());
}

#[test]
fn t0_mismatch_merge_is_incompatible() {
    let mut a = Decimator::new(cfg(10, 20.0, 1)).unwrap();
    let mut b = Decimator::new(cfg(10, 20.0, 1)).unwrap();
    push_rows(&mut a, &ramp(0.0, 10)).unwrap();
    push_rows(&mut b, &ramp(0.55, 10)).unwrap();
    let err = a.merge(&b).unwrap_err();
    match err {
        Error::Incompatible { reason } => assert!(reason.contains("t0_s"), "{reason}"),
        other => panic!("unexpected {other:?}"),
    }
    // unchanged
    assert_eq!(a.n_samples(), 10);
}

#[test]
fn merge_config_mismatch_is_incompatible() {
    let base = cfg(10, 20.0, 1);
    let mut a = Decimator::new(base.clone()).unwrap();
    for other in [
        DecimatorConfig {
            factor: 5,
            ..base.clone()
        },
        DecimatorConfig {
            rate_hz: 10.0,
            ..base.clone()
        },
        DecimatorConfig {
            n_channels: 2,
            ..base.clone()
        },
        DecimatorConfig {
            min_count: 2,
            ..base.clone()
        },
    ] {
        let b = Decimator::new(other).unwrap();
        assert!(matches!(a.merge(&b), Err(Error::Incompatible { .. })));
    }
}

#[test]
fn merge_overlapping_ranges_is_incompatible() {
    let c = DecimatorConfig {
        t0_s: Some(0.0),
        ..cfg(10, 20.0, 1)
    };
    let mut a = Decimator::new(c.clone()).unwrap();
    let mut b = Decimator::new(c).unwrap();
    push_rows(&mut a, &ramp(0.0, 10)).unwrap();
    push_rows(&mut b, &ramp(0.3, 10)).unwrap();
    assert!(matches!(a.merge(&b), Err(Error::Incompatible { .. })));
}

#[test]
fn merge_overlap_includes_invalid_rows_with_finite_time() {
    // As in one pass, a row with finite time but a NaN value still orders the stream.
    let c = DecimatorConfig {
        t0_s: Some(0.0),
        ..cfg(10, 20.0, 1)
    };
    let mut a = Decimator::new(c.clone()).unwrap();
    let mut b = Decimator::new(c.clone()).unwrap();
    push_rows(&mut a, &[vec![0.0, 1.0, 1.0], vec![2.0, f64::NAN, 1.0]]).unwrap();
    push_rows(&mut b, &[vec![1.0, 1.0, 1.0]]).unwrap();
    assert!(matches!(a.merge(&b), Err(Error::Incompatible { .. })));
    // a piece with only invalid rows (finite time) still takes part
    let mut e = Decimator::new(c).unwrap();
    push_rows(&mut e, &[vec![1.5, 1.0, f64::NAN]]).unwrap();
    assert!(matches!(a.merge(&e), Err(Error::Incompatible { .. })));
    b.merge(&e).unwrap();
    assert_eq!((b.n_samples(), b.n_skipped_nonfinite()), (2, 1));
}

#[test]
fn merge_with_empty() {
    let c = DecimatorConfig {
        t0_s: Some(0.0),
        ..cfg(10, 20.0, 1)
    };
    let mut full = Decimator::new(c.clone()).unwrap();
    push_rows(&mut full, &ramp(0.0, 30)).unwrap();
    let expected = full.finish().unwrap();

    let mut a = full.clone();
    a.merge(&Decimator::new(c.clone()).unwrap()).unwrap();
    assert_eq!(a.finish().unwrap(), expected);

    let mut e = Decimator::new(c).unwrap();
    e.merge(&full).unwrap();
    assert_eq!(e.finish().unwrap(), expected);
    assert_eq!(e.n_samples(), 30);

    // an empty piece without t0 adopts the other's t0
    let mut e = Decimator::new(cfg(10, 20.0, 1)).unwrap();
    let mut b = Decimator::new(cfg(10, 20.0, 1)).unwrap();
    push_rows(&mut b, &ramp(3.0, 30)).unwrap();
    e.merge(&b).unwrap();
    assert_eq!(e.config().t0_s, Some(3.0));
    assert_eq!(e.finish().unwrap(), b.finish().unwrap());
    // and can keep going in the same grid
    push_rows(&mut e, &ramp(4.5, 10)).unwrap();
    push_rows(&mut b, &ramp(4.5, 10)).unwrap();
    assert_eq!(e.finish().unwrap(), b.finish().unwrap());
}

#[test]
fn merge_either_order_and_shared_block() {
    let c = DecimatorConfig {
        t0_s: Some(0.0),
        ..cfg(10, 20.0, 1)
    };
    let rows = ramp(0.0, 37);
    let mut one = Decimator::new(c.clone()).unwrap();
    push_rows(&mut one, &rows).unwrap();
    let mut a = Decimator::new(c.clone()).unwrap();
    let mut b = Decimator::new(c).unwrap();
    push_rows(&mut a, &rows[..13]).unwrap(); // cut in the middle of block 1
    push_rows(&mut b, &rows[13..]).unwrap();
    let mut ab = a.clone();
    ab.merge(&b).unwrap();
    let mut ba = b.clone();
    ba.merge(&a).unwrap();
    let expected = one.finish().unwrap();
    assert_blocks_close(&ab.finish().unwrap(), &expected, 1e-12);
    assert_blocks_close(&ba.finish().unwrap(), &expected, 1e-12);
    // the merged decimator continues the stream
    let more = ramp(37.0 / 20.0, 5);
    push_rows(&mut ab, &more).unwrap();
    push_rows(&mut one, &more).unwrap();
    assert_blocks_close(&ab.finish().unwrap(), &one.finish().unwrap(), 1e-12);
    assert_eq!(ab.n_samples(), 42);
}

#[test]
fn drain_completed_streams_blocks() {
    let mut d = Decimator::new(DecimatorConfig {
        min_count: 2,
        ..cfg(10, 20.0, 1)
    })
    .unwrap();
    let mut rows = ramp(0.0, 25); // blocks 0, 1 full; block 2 open (5 samples)
    rows.push(vec![2.0, 25.0, 0.0]); // block 4 alone (1 sample), closes block 2
    rows.push(vec![2.6, 25.0, 0.0]); // block 5 open
    let mut one = Decimator::new(DecimatorConfig {
        min_count: 2,
        ..cfg(10, 20.0, 1)
    })
    .unwrap();
    push_rows(&mut one, &rows).unwrap();

    push_rows(&mut d, &rows[..25]).unwrap();
    let first = d.drain_completed();
    assert_eq!(first.block_index, vec![0, 1]);
    assert!(d.drain_completed().is_empty());
    push_rows(&mut d, &rows[25..]).unwrap();
    let second = d.drain_completed();
    assert_eq!(second.block_index, vec![2]); // block 4 removed but below min_count
    assert!(matches!(d.finish(), Err(Error::Empty { .. }))); // block 5 has 1 sample
    push_rows(&mut d, &[vec![2.7, 25.0, 0.0]]).unwrap();
    push_rows(&mut one, &[vec![2.7, 25.0, 0.0]]).unwrap();
    let rest = d.finish().unwrap();
    let all = one.finish().unwrap();
    assert_eq!(concat(&[first, second, rest]), all);
}

#[test]
fn drained_decimator_rejects_preceding_piece() {
    let c = DecimatorConfig {
        t0_s: Some(0.0),
        ..cfg(10, 20.0, 1)
    };
    let mut early = Decimator::new(c.clone()).unwrap();
    let mut late = Decimator::new(c.clone()).unwrap();
    push_rows(&mut early, &ramp(0.0, 20)).unwrap();
    push_rows(&mut late, &ramp(2.0, 20)).unwrap();
    let _ = late.drain_completed();
    assert!(matches!(
        late.merge(&early),
        Err(Error::Incompatible { .. })
    ));
    assert!(matches!(
        early.clone().merge(&late),
        Err(Error::Incompatible { .. })
    ));
    // the other way round is fine: a drained early piece absorbs a later one
    let mut tail = Decimator::new(c).unwrap();
    push_rows(&mut tail, &ramp(4.0, 5)).unwrap();
    late.merge(&tail).unwrap();
}

fn concat(parts: &[DecimatedBlocks]) -> DecimatedBlocks {
    let mut out = DecimatedBlocks {
        n_channels: parts[0].n_channels,
        ..Default::default()
    };
    for p in parts {
        out.block_index.extend(&p.block_index);
        out.count.extend(&p.count);
        out.time_s.extend(&p.time_s);
        out.temperature_c.extend(&p.temperature_c);
        out.channels.extend(&p.channels);
    }
    out
}

/// Largest |value| any test here sums: generated channels span ±2e4 (times stay
/// below 2e3 s, temperatures within ±85 °C).
const LARGEST_VALUE: f64 = 2.0e4;

/// `rel` of the larger value, plus what summing in another order may change.
///
/// Merged pieces add a block's partial sums in another order than one push. The
/// sum of `k` values of at most `M` then differs by at most `(k - 1) eps k M` and
/// their mean by `(k - 1) eps M`, whatever the mean's own size: channels of ±2e4
/// may cancel to a mean near 0 (seen: -0.2253264004730 vs -0.2253264004733, 1e-12
/// of the mean but 1e-17 of the summands).
fn close(a: f64, b: f64, rel: f64, rows: f64) -> bool {
    a == b || (a - b).abs() <= rel * a.abs().max(b.abs()) + rows * f64::EPSILON * LARGEST_VALUE
}

fn assert_blocks_close(a: &DecimatedBlocks, b: &DecimatedBlocks, rel: f64) {
    assert_eq!(a.n_channels, b.n_channels);
    assert_eq!(a.block_index, b.block_index);
    assert_eq!(a.count, b.count);
    for (x, y) in [
        (&a.time_s, &b.time_s),
        (&a.temperature_c, &b.temperature_c),
        (&a.channels, &b.channels),
    ] {
        assert_eq!(x.len(), y.len());
        let width = x.len() / a.count.len().max(1);
        for (k, (p, q)) in x.iter().zip(y.iter()).enumerate() {
            let rows = a.count[k / width] as f64;
            assert!(
                close(*p, *q, rel, rows),
                "{p} vs {q} (block of {rows} rows)"
            );
        }
    }
}

// ---------------------------------------------------------------- properties

const NC: usize = 2;

/// A stream of strictly increasing times (with gaps), occasional non-finite values.
fn stream() -> impl Strategy<Value = Vec<[f64; 2 + NC]>> {
    prop::collection::vec(
        (
            0.001f64..0.2,              // time step
            prop::bool::weighted(0.05), // big gap
            -40.0f64..85.0,             // temperature
            prop::array::uniform2(-2.0e4f64..2.0e4),
            0u8..40, // which value (if any) is made non-finite
        ),
        0..120,
    )
    .prop_map(|steps| {
        let mut t = 1000.0;
        steps
            .into_iter()
            .map(|(dt, gap, temp, ch, bad)| {
                t += dt + if gap { 3.3 } else { 0.0 };
                let mut row = [t, temp, ch[0], ch[1]];
                match bad {
                    0 => row[1] = f64::NAN,
                    1 => row[2] = f64::INFINITY,
                    2 => row[3] = f64::NEG_INFINITY,
                    _ => {}
                }
                row
            })
            .collect()
    })
}

/// Split points (sorted, may repeat → empty chunks) for a stream of length n.
fn cuts(n: usize, raw: &[usize]) -> Vec<usize> {
    let mut c: Vec<usize> = raw.iter().map(|r| r % (n + 1)).collect();
    c.push(0);
    c.push(n);
    c.sort_unstable();
    c
}

fn push_slice(d: &mut Decimator, rows: &[[f64; 2 + NC]]) {
    let t: Vec<f64> = rows.iter().map(|r| r[0]).collect();
    let temp: Vec<f64> = rows.iter().map(|r| r[1]).collect();
    let ch: Vec<f64> = rows.iter().flat_map(|r| [r[2], r[3]]).collect();
    let ch = Array2::from_shape_vec((rows.len(), NC), ch).unwrap();
    d.push(&t, &temp, ch.view()).unwrap();
}

fn build(c: &DecimatorConfig, rows: &[[f64; 2 + NC]]) -> Decimator {
    let mut d = Decimator::new(c.clone()).unwrap();
    push_slice(&mut d, rows);
    d
}

fn config_strategy() -> impl Strategy<Value = DecimatorConfig> {
    (
        1usize..12,
        prop::sample::select(vec![20.0, 10.0, 7.3, 100.0]),
        1usize..4,
    )
        .prop_map(|(factor, rate_hz, min_count)| DecimatorConfig {
            factor,
            rate_hz,
            n_channels: NC,
            min_count,
            t0_s: Some(999.5),
        })
}

fn same_result(a: &Decimator, b: &Decimator, rel: Option<f64>) {
    assert_eq!(a.n_samples(), b.n_samples());
    assert_eq!(a.n_skipped_nonfinite(), b.n_skipped_nonfinite());
    match (a.finish(), b.finish()) {
        (Ok(x), Ok(y)) => match rel {
            None => assert_eq!(x, y),
            Some(r) => assert_blocks_close(&x, &y, r),
        },
        (Err(x), Err(y)) => assert_eq!(x, y),
        (x, y) => panic!("{x:?} vs {y:?}"),
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn chunked_push_is_bitwise_one_push(
        rows in stream(),
        raw in prop::collection::vec(0usize..200, 0..8),
        explicit_t0 in any::<bool>(),
        c in config_strategy(),
    ) {
        let c = DecimatorConfig { t0_s: if explicit_t0 { c.t0_s } else { None }, ..c };
        let one = build(&c, &rows);
        let mut chunked = Decimator::new(c).unwrap();
        let cut = cuts(rows.len(), &raw);
        for w in cut.windows(2) {
            push_slice(&mut chunked, &rows[w[0]..w[1]]);
        }
        same_result(&one, &chunked, None);
        prop_assert_eq!(one.config(), chunked.config());
    }

    #[test]
    fn merged_pieces_equal_one_push(
        rows in stream(),
        raw in prop::collection::vec(0usize..200, 0..6),
        reverse in any::<bool>(),
        c in config_strategy(),
    ) {
        let one = build(&c, &rows);
        let cut = cuts(rows.len(), &raw);
        let mut pieces: Vec<Decimator> = cut.windows(2).map(|w| build(&c, &rows[w[0]..w[1]])).collect();
        if reverse {
            pieces.reverse();
        }
        let mut acc = Decimator::new(c).unwrap();
        for p in &pieces {
            acc.merge(p).unwrap();
        }
        same_result(&one, &acc, Some(1e-12));
    }

    #[test]
    fn merge_is_associative(
        rows in stream(),
        i in 0usize..200,
        j in 0usize..200,
        c in config_strategy(),
    ) {
        let cut = cuts(rows.len(), &[i, j]);
        let a = build(&c, &rows[cut[0]..cut[1]]);
        let b = build(&c, &rows[cut[1]..cut[2]]);
        let cc = build(&c, &rows[cut[2]..cut[3]]);
        let mut left = a.clone();
        left.merge(&b).unwrap();
        left.merge(&cc).unwrap();
        let mut bc = b.clone();
        bc.merge(&cc).unwrap();
        let mut right = a.clone();
        right.merge(&bc).unwrap();
        same_result(&left, &right, Some(1e-12));
    }

    #[test]
    fn drain_then_finish_equals_finish(
        rows in stream(),
        raw in prop::collection::vec(0usize..200, 0..6),
        c in config_strategy(),
    ) {
        let one = build(&c, &rows);
        let mut d = Decimator::new(c).unwrap();
        let mut parts = Vec::new();
        for w in cuts(rows.len(), &raw).windows(2) {
            push_slice(&mut d, &rows[w[0]..w[1]]);
            parts.push(d.drain_completed());
        }
        if let Ok(rest) = d.finish() {
            parts.push(rest);
        }
        let drained = concat(&parts);
        match one.finish() {
            Ok(all) => prop_assert_eq!(drained, all),
            Err(_) => prop_assert!(drained.is_empty()),
        }
    }

    #[test]
    fn strided_view_equals_contiguous(rows in stream()) {
        let c = DecimatorConfig { n_channels: NC, ..DecimatorConfig::default() };
        let one = build(&c, &rows);
        let n = rows.len();
        let t: Vec<f64> = rows.iter().map(|r| r[0]).collect();
        let temp: Vec<f64> = rows.iter().map(|r| r[1]).collect();
        // channels stored column-major and viewed transposed
        let ch_t = Array2::from_shape_fn((NC, n), |(j, i)| rows[i][2 + j]);
        let view: ArrayView2<'_, f64> = ch_t.t();
        let mut d = Decimator::new(c).unwrap();
        d.push(&t, &temp, view).unwrap();
        same_result(&one, &d, None);
    }
}
