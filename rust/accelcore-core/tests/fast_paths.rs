//! The kernels' fast paths give, bit for bit, what their row-by-row
//! definitions give:
//!
//! - the decimator's block runs (chunks with finite, increasing times and
//!   contiguous channels) against a row-by-row oracle of the block formula,
//!   including times placed exactly on, just below and just above block edges;
//! - the binner's same-bin runs (contiguous rows) against the row-by-row path
//!   it takes for strided rows;
//! - `LeastSquares` reading contiguous rows as slices against strided views.
use accelcore_core::{
    BinnerConfig, DecimatedBlocks, Decimator, DecimatorConfig, LeastSquares, TemperatureBinner,
};
use ndarray::{Array2, ArrayView2, Axis, Slice};
use proptest::prelude::*;

/// Block means straight from the documented formula, one row at a time.
fn oracle(c: &DecimatorConfig, t: &[f64], temp: &[f64], ch: &Array2<f64>) -> DecimatedBlocks {
    let nc = c.n_channels;
    let t0 = c.t0_s.or(t.first().copied()).unwrap_or(0.0);
    // (k, count, sum_t, sum_temp, sums)
    let mut blocks: Vec<(i64, u64, f64, f64, Vec<f64>)> = Vec::new();
    for i in 0..t.len() {
        let row = ch.row(i);
        if !(t[i].is_finite() && temp[i].is_finite() && row.iter().all(|v| v.is_finite())) {
            continue;
        }
        #[allow(clippy::cast_possible_truncation)]
        let k = ((t[i] - t0) * c.rate_hz / c.factor as f64).floor() as i64;
        if blocks.last().is_none_or(|b| b.0 != k) {
            blocks.push((k, 0, 0.0, 0.0, vec![0.0; nc]));
        }
        let b = blocks.last_mut().unwrap();
        b.1 += 1;
        b.2 += t[i];
        b.3 += temp[i];
        for (s, v) in b.4.iter_mut().zip(row.iter()) {
            *s += v;
        }
    }
    let mut out = DecimatedBlocks {
        n_channels: nc,
        ..DecimatedBlocks::default()
    };
    for (k, count, st, sp, sums) in blocks {
        if count >= c.min_count as u64 {
            #[allow(clippy::cast_precision_loss)]
            let n = count as f64;
            out.block_index.push(k);
            out.count.push(count);
            out.time_s.push(st / n);
            out.temperature_c.push(sp / n);
            out.channels.extend(sums.iter().map(|s| s / n));
        }
    }
    out
}

/// The least `f64` above finite `x`.
fn next_up(x: f64) -> f64 {
    if x == 0.0 {
        f64::from_bits(1)
    } else if x > 0.0 {
        f64::from_bits(x.to_bits() + 1)
    } else {
        f64::from_bits(x.to_bits() - 1)
    }
}

/// Times that are strictly increasing and often sit on a block edge
/// (`t0 + k * factor / rate`), one ulp either side of it, or after a gap.
fn edge_times(t0: f64, period: f64, steps: &[(u8, f64)]) -> Vec<f64> {
    let mut out: Vec<f64> = Vec::with_capacity(steps.len());
    let mut t = t0 - 0.37 * period;
    for &(kind, frac) in steps {
        let k = ((t - t0) / period).floor() + 1.0;
        let edge = t0 + k * period;
        let candidate = match kind % 8 {
            0 => edge,
            1 => -next_up(-edge),
            2 => next_up(edge),
            3 => t + 7.3 * period, // a gap
            _ => t + frac * period,
        };
        if candidate > t {
            t = candidate;
        } else {
            t = next_up(t);
        }
        out.push(t);
    }
    out
}

fn decimator_case(
) -> impl Strategy<Value = (DecimatorConfig, Vec<f64>, Vec<f64>, Array2<f64>, Vec<usize>)> {
    (
        1usize..13,
        prop::sample::select(vec![20.0, 19.7, 100.0, 3.0, 0.1]),
        0usize..11,
        prop::option::of(-1.0e4f64..1.0e4),
        1usize..3,
        prop::collection::vec((any::<u8>(), 0.01f64..0.6), 0..400),
        prop::collection::vec(0u16..1000, 0..6),
        any::<u64>(),
    )
        .prop_map(
            |(factor, rate_hz, nc, t0_s, min_count, steps, raw_cuts, seed)| {
                let config = DecimatorConfig {
                    factor,
                    rate_hz,
                    n_channels: nc,
                    min_count,
                    t0_s,
                };
                #[allow(clippy::cast_precision_loss)]
                let period = factor as f64 / rate_hz;
                let t = edge_times(t0_s.unwrap_or(123.25), period, &steps);
                let n = t.len();
                let mut state = seed | 1;
                let mut next = move || {
                    state ^= state << 13;
                    state ^= state >> 7;
                    state ^= state << 17;
                    state
                };
                let mut value = |scale: f64| {
                    let r = next();
                    match r % 97 {
                        0 => f64::NAN,
                        1 => f64::INFINITY,
                        #[allow(clippy::cast_precision_loss)]
                        _ => scale * ((r >> 11) as f64 / (1u64 << 53) as f64 - 0.5),
                    }
                };
                let temp: Vec<f64> = (0..n).map(|_| value(80.0)).collect();
                let ch = Array2::from_shape_fn((n, nc), |_| value(3.0e4));
                let mut cuts: Vec<usize> =
                    raw_cuts.iter().map(|&c| usize::from(c) % (n + 1)).collect();
                cuts.push(0);
                cuts.push(n);
                cuts.sort_unstable();
                (config, t, temp, ch, cuts)
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    #[test]
    fn decimator_block_runs_equal_row_by_row_oracle(
        (config, t, temp, ch, cuts) in decimator_case()
    ) {
        let expected = oracle(&config, &t, &temp, &ch);
        let mut d = Decimator::new(config).unwrap();
        for w in cuts.windows(2) {
            let view = ch.slice_axis(Axis(0), Slice::from(w[0]..w[1]));
            d.push(&t[w[0]..w[1]], &temp[w[0]..w[1]], view).unwrap();
        }
        match d.finish() {
            Ok(got) => prop_assert_eq!(got, expected),
            Err(_) => prop_assert!(expected.is_empty()),
        }
    }
}

/// Rows every other row of a twice-as-tall array: the same values, strided.
fn strided(a: &Array2<f64>) -> Array2<f64> {
    let mut big = Array2::zeros((2 * a.nrows(), a.ncols()));
    big.slice_axis_mut(Axis(0), Slice::new(0, None, 2))
        .assign(a);
    big
}

fn every_other(a: &Array2<f64>) -> ArrayView2<'_, f64> {
    a.slice_axis(Axis(0), Slice::new(0, None, 2))
}

/// Bin the rows as contiguous rows (the same-bin runs) and as strided rows (row
/// by row); both must fail, or give the same bits (NaN-aware: empty bins are NaN).
fn same_binning(
    config: BinnerConfig,
    t: &[f64],
    temp: &[f64],
    ch: &Array2<f64>,
) -> Result<(), TestCaseError> {
    let mut fast = TemperatureBinner::new(config.clone()).unwrap();
    fast.push(t, temp, ch.view()).unwrap();
    let tall = strided(ch);
    let mut slow = TemperatureBinner::new(config).unwrap();
    slow.push(t, temp, every_other(&tall)).unwrap();
    match (fast.finish(), slow.finish()) {
        (Ok(a), Ok(b)) => {
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            prop_assert_eq!(&a.count, &b.count);
            prop_assert_eq!(bits(&a.mean), bits(&b.mean));
            prop_assert_eq!(bits(&a.variance), bits(&b.variance));
            prop_assert_eq!(bits(&a.time_s), bits(&b.time_s));
            prop_assert_eq!(bits(&a.temperature_c), bits(&b.temperature_c));
            prop_assert_eq!(
                (a.n_below, a.n_above, a.n_nonfinite),
                (b.n_below, b.n_above, b.n_nonfinite)
            );
        }
        (Err(_), Err(_)) => {}
        (a, b) => prop_assert!(false, "one path failed: {:?} vs {:?}", a.is_ok(), b.is_ok()),
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn binner_same_bin_runs_equal_row_by_row(
        nc in 0usize..11,
        steps in prop::collection::vec((-0.4f64..0.4, 0u8..60), 0..400),
        width in prop::sample::select(vec![0.5, 0.25, 1.0 / 3.0, 7.0]),
        seed in any::<u64>(),
    ) {
        let n = steps.len();
        let mut temp = Vec::with_capacity(n);
        let mut tc = -3.0;
        for &(dt, bad) in &steps {
            tc += dt;
            temp.push(match bad {
                0 => f64::NAN,
                1 => f64::INFINITY,
                _ => tc,
            });
        }
        #[allow(clippy::cast_precision_loss)]
        let t: Vec<f64> = (0..n).map(|i| 0.5 * i as f64).collect();
        let mut state = seed | 1;
        let ch = Array2::from_shape_fn((n, nc), |(i, j)| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            if state % 89 == 0 {
                f64::NAN
            } else {
                #[allow(clippy::cast_precision_loss)]
                let noise = (state >> 11) as f64 / (1u64 << 53) as f64;
                #[allow(clippy::cast_precision_loss)]
                let offset = 16_000.0 + i as f64 * 1e-3 + j as f64;
                offset + 1e-6 * noise
            }
        });
        let config = BinnerConfig { lo_c: -2.0, hi_c: 4.0, width_c: width, n_channels: nc };
        same_binning(config, &t, &temp, &ch)?;
    }

    #[test]
    fn binner_runs_equal_row_by_row_on_bin_edges(
        nc in 1usize..5,
        picks in prop::collection::vec((0u8..8, 0usize..40, 0u8..40), 1..300),
        lo_c in prop::sample::select(vec![-40.0, 0.0, 0.3, -2.7]),
        width in prop::sample::select(vec![0.5, 0.1, 1.0 / 3.0, 0.7]),
        n_bins in 1usize..12,
    ) {
        // Temperatures on the bin edges `lo_c + b * width` (the formula's own
        // edges, which need not be where the quotient turns), one or two ulps
        // either side, on the window's ends, and now and then a NaN or an
        // infinity in the time or a channel, or a channel that overflows the
        // accumulators (`add` then leaves them infinite or NaN).
        #[allow(clippy::cast_precision_loss)]
        let hi_c = lo_c + n_bins as f64 * width - 0.25 * width;
        let n = picks.len();
        let mut t = Vec::with_capacity(n);
        let mut temp = Vec::with_capacity(n);
        let mut ch = Array2::zeros((n, nc));
        for (i, &(kind, b, bad)) in picks.iter().enumerate() {
            #[allow(clippy::cast_precision_loss)]
            let edge = lo_c + (b % (n_bins + 2)) as f64 * width;
            temp.push(match kind {
                0 | 1 => edge,
                2 => next_up(edge),
                3 => -next_up(-edge),
                4 => next_up(next_up(edge)),
                5 => hi_c,
                6 => -next_up(-hi_c),
                _ => edge + 0.37 * width,
            });
            #[allow(clippy::cast_precision_loss)]
            t.push(i as f64 * 0.05);
            for j in 0..nc {
                #[allow(clippy::cast_precision_loss)]
                let v = 1.5 + 1e-3 * ((i * 7 + j * 3) % 11) as f64;
                ch[[i, j]] = v;
            }
            match bad {
                0 => t[i] = f64::NAN,
                1 => ch[[i, nc - 1]] = f64::INFINITY,
                2 => ch[[i, 0]] = f64::NAN,
                3 => ch[[i, 0]] = if i % 2 == 0 { 1.7e308 } else { -1.7e308 },
                _ => {}
            }
        }
        let config = BinnerConfig { lo_c, hi_c, width_c: width, n_channels: nc };
        same_binning(config, &t, &temp, &ch)?;
    }

    #[test]
    fn least_squares_slices_equal_strided_views(
        n in 0usize..200,
        p in 1usize..5,
        m in 1usize..4,
        weight_kind in 0u8..3,
        seed in any::<u64>(),
    ) {
        let mut state = seed | 1;
        let mut uniform = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            #[allow(clippy::cast_precision_loss)]
            let u = (state >> 11) as f64 / (1u64 << 53) as f64;
            u
        };
        let x = Array2::from_shape_fn((n, p), |(_, j)| if j == 0 { 1.0 } else { 40.0 * uniform() - 10.0 });
        let y = Array2::from_shape_fn((n, m), |_| uniform());
        let w: Vec<f64> = (0..n)
            .map(|i| match weight_kind {
                0 => 10.0,                                  // repeated (block counts)
                1 => if i % 7 == 3 { 0.0 } else { 10.0 },   // with zero weights
                _ => (1.0 + (i % 4) as f64).sqrt(),         // varying
            })
            .collect();
        let mut fast = LeastSquares::with_responses(p, m, None).unwrap();
        fast.push_multi(x.view(), y.view(), Some(&w)).unwrap();
        let (xt, yt) = (strided(&x), strided(&y));
        let mut slow = LeastSquares::with_responses(p, m, None).unwrap();
        slow.push_multi(every_other(&xt), every_other(&yt), Some(&w)).unwrap();
        for j in 0..m {
            match (fast.finish_response(j), slow.finish_response(j)) {
                (Ok(a), Ok(b)) => {
                    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    prop_assert_eq!(bits(&a.coefficients), bits(&b.coefficients));
                    prop_assert_eq!(a.residual_sum_squares.to_bits(), b.residual_sum_squares.to_bits());
                    prop_assert_eq!(bits(&a.covariance), bits(&b.covariance));
                }
                (Err(_), Err(_)) => {}
                (a, b) => prop_assert!(false, "one path failed: {:?} vs {:?}", a.is_ok(), b.is_ok()),
            }
        }
    }
}
