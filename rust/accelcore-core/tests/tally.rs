//! `RunTally`: chunking and merging do not change the statistics, which equal a
//! plain re-computation, and agree with the decimator's count of skipped rows.

use accelcore_core::{ChannelRange, Decimator, DecimatorConfig, RawStats, RunTally};
use ndarray::Array2;
use proptest::prelude::*;

/// A value that is often repeated (clipping), sometimes NaN or infinite.
fn value() -> impl Strategy<Value = f64> {
    prop_oneof![
        6 => (-3i32..=3).prop_map(f64::from),
        3 => -1e3f64..1e3,
        1 => Just(f64::NAN),
        1 => Just(f64::INFINITY),
    ]
}

/// Rows of (time step, time missing, temperature, channels): strictly increasing finite times.
fn rows(n_channels: usize) -> impl Strategy<Value = (Vec<f64>, Vec<f64>, Vec<f64>)> {
    proptest::collection::vec(
        (
            prop_oneof![8 => Just(0.05f64), 2 => 0.001f64..1.0],
            prop::bool::weighted(0.1),
            prop_oneof![9 => -40.0f64..85.0, 1 => Just(f64::NAN)],
            proptest::collection::vec(value(), n_channels),
        ),
        0..120,
    )
    .prop_map(|rows| {
        let (mut time, mut temp, mut channels) = (vec![], vec![], vec![]);
        let mut t = 0.0;
        for (step, missing, temperature, values) in rows {
            t += step;
            time.push(if missing { f64::NAN } else { t });
            temp.push(temperature);
            channels.extend(values);
        }
        (time, temp, channels)
    })
}

/// The statistics computed the plainest way, from the whole arrays.
fn plain(time: &[f64], temp: &[f64], channels: &[f64], nc: usize, rate_hz: f64) -> RawStats {
    let n = time.len();
    let finite_t: Vec<f64> = time.iter().copied().filter(|t| t.is_finite()).collect();
    let dts: Vec<f64> = finite_t.windows(2).map(|w| w[1] - w[0]).collect();
    let row_ok = |i: usize| {
        time[i].is_finite()
            && temp[i].is_finite()
            && channels[i * nc..(i + 1) * nc].iter().all(|v| v.is_finite())
    };
    let channel_ranges = (0..nc)
        .map(|c| {
            let col: Vec<f64> = (0..n)
                .map(|i| channels[i * nc + c])
                .filter(|v| v.is_finite())
                .collect();
            let min = col.iter().copied().fold(f64::INFINITY, f64::min);
            let max = col.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            ChannelRange {
                min,
                max,
                n_at_min: col.iter().filter(|&&v| v == min).count() as u64,
                n_at_max: col.iter().filter(|&&v| v == max).count() as u64,
            }
        })
        .collect();
    RawStats {
        n_rows: n as u64,
        n_skipped_nonfinite: (0..n).filter(|&i| !row_ok(i)).count() as u64,
        first_time_s: finite_t.first().copied().unwrap_or(f64::NAN),
        last_time_s: finite_t.last().copied().unwrap_or(f64::NAN),
        n_gaps: dts.iter().filter(|&&dt| dt > 1.5 * (1.0 / rate_hz)).count() as u64,
        max_interval_s: dts.iter().copied().fold(0.0, f64::max),
        channel_ranges,
    }
}

/// Equal, with NaN equal to NaN.
fn same(a: &RawStats, b: &RawStats) -> bool {
    let t = |x: f64, y: f64| x == y || (x.is_nan() && y.is_nan());
    a.n_rows == b.n_rows
        && a.n_skipped_nonfinite == b.n_skipped_nonfinite
        && t(a.first_time_s, b.first_time_s)
        && t(a.last_time_s, b.last_time_s)
        && a.n_gaps == b.n_gaps
        && a.max_interval_s == b.max_interval_s
        && a.channel_ranges == b.channel_ranges
}

fn tally_of(time: &[f64], temp: &[f64], channels: &[f64], nc: usize) -> RunTally {
    let mut tally = RunTally::new(nc, 20.0).unwrap();
    let view = Array2::from_shape_vec((time.len(), nc), channels.to_vec()).unwrap();
    tally.push(time, temp, view.view()).unwrap();
    tally
}

proptest! {
    #[test]
    fn one_push_equals_the_plain_computation(
        (nc, (time, temp, channels)) in (0usize..4).prop_flat_map(|nc| (Just(nc), rows(nc)))
    ) {
        let got = tally_of(&time, &temp, &channels, nc).finish();
        let want = plain(&time, &temp, &channels, nc, 20.0);
        prop_assert!(same(&got, &want), "{:?} != {:?}", got, want);
    }

    #[test]
    fn merged_pieces_equal_one_push(
        (nc, (time, temp, channels), cuts) in (0usize..4).prop_flat_map(|nc| {
            (Just(nc), rows(nc), proptest::collection::vec(0.0f64..1.0, 0..4))
        })
    ) {
        let n = time.len();
        let mut bounds: Vec<usize> = cuts.iter().map(|c| (c * n as f64) as usize).collect();
        bounds.extend([0, n]);
        bounds.sort_unstable();
        let whole = tally_of(&time, &temp, &channels, nc).finish();
        let mut merged = RunTally::new(nc, 20.0).unwrap();
        let mut chunked = RunTally::new(nc, 20.0).unwrap();
        for w in bounds.windows(2) {
            let (a, b) = (w[0], w[1]);
            let piece = tally_of(&time[a..b], &temp[a..b], &channels[a * nc..b * nc], nc);
            merged.merge(&piece).unwrap();
            let view = Array2::from_shape_vec((b - a, nc), channels[a * nc..b * nc].to_vec())
                .unwrap();
            chunked.push(&time[a..b], &temp[a..b], view.view()).unwrap();
        }
        prop_assert!(same(&merged.finish(), &whole), "merge");
        prop_assert!(same(&chunked.finish(), &whole), "chunks");
        let resumed = RunTally::resume(whole.clone(), 20.0).unwrap().finish();
        prop_assert!(same(&resumed, &whole), "resume");
    }

    #[test]
    fn skipped_rows_agree_with_the_decimator(
        (nc, (time, temp, channels)) in (0usize..4).prop_flat_map(|nc| (Just(nc), rows(nc)))
    ) {
        let mut decimator = Decimator::new(DecimatorConfig {
            n_channels: nc,
            ..DecimatorConfig::default()
        })
        .unwrap();
        let view = Array2::from_shape_vec((time.len(), nc), channels.clone()).unwrap();
        decimator.push(&time, &temp, view.view()).unwrap();
        let stats = tally_of(&time, &temp, &channels, nc).finish();
        prop_assert_eq!(stats.n_skipped_nonfinite, decimator.n_skipped_nonfinite());
        prop_assert_eq!(stats.n_rows, decimator.n_samples());
    }
}

/// Bitwise equal (so a zero's sign counts), NaN equal to NaN.
fn same_bits(a: &RawStats, b: &RawStats) -> bool {
    let t = |x: f64, y: f64| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan());
    same(a, b)
        && t(a.max_interval_s, b.max_interval_s)
        && a.channel_ranges
            .iter()
            .zip(&b.channel_ranges)
            .all(|(x, y)| t(x.min, y.min) && t(x.max, y.max))
}

proptest! {
    #[test]
    fn rows_pushed_a_column_at_a_time_equal_rows_one_by_one(
        (nc, (time, temp, channels), cuts, finite) in (0usize..8).prop_flat_map(|nc| {
            (
                Just(nc),
                rows(nc),
                proptest::collection::vec(0.0f64..1.0, 0..4),
                prop::bool::weighted(0.7),
            )
        })
    ) {
        // Mostly all-finite batches (the fast path), with zeros of both signs;
        // otherwise NaN and infinite values, missing times and temperatures.
        let (mut time, mut temp, mut channels) = (time, temp, channels);
        if finite {
            let mut t = 0.0;
            for x in &mut time {
                t = if x.is_finite() { *x } else { t + 0.05 };
                *x = t;
            }
            for (i, x) in temp.iter_mut().chain(channels.iter_mut()).enumerate() {
                if !x.is_finite() {
                    *x = if i % 2 == 0 { 0.0 } else { -0.0 };
                }
            }
        }
        let n = time.len();
        let mut bounds: Vec<usize> = cuts.iter().map(|c| (c * n as f64) as usize).collect();
        bounds.extend([0, n]);
        bounds.sort_unstable();
        let mut by_row = RunTally::new(nc, 20.0).unwrap();
        for i in 0..n {
            by_row.push_row(time[i], temp[i], &channels[i * nc..(i + 1) * nc]);
        }
        let mut by_column = RunTally::new(nc, 20.0).unwrap();
        for w in bounds.windows(2) {
            let (a, b) = (w[0], w[1]);
            by_column.push_rows(&time[a..b], &temp[a..b], &channels[a * nc..b * nc]);
        }
        let (want, got) = (by_row.finish(), by_column.finish());
        prop_assert!(same_bits(&got, &want), "{:?} != {:?}", got, want);
    }
}
