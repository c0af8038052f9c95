//! Throughput of each kernel on one core, in samples/s.
//!
//! Plain timing (no criterion, so the workspace builds quickly): `cargo bench
//! -p accelcore-core --bench kernels -- --nocapture` prints one line per
//! kernel (median of 5 runs over 1e7 samples of time, temperature and 3 channels;
//! `ACCELCORE_BENCH_N` and `ACCELCORE_BENCH_REPEAT` change both). `lstsq12`, a
//! weighted 12-column fit, uses at most 1e6 of the rows.
#![allow(clippy::print_stderr)]
use accelcore_core::{
    read_run, BinnerConfig, CsvFormat, Decimator, DecimatorConfig, LeastSquares, TemperatureBinner,
};
use ndarray::{Array2, Axis, Slice};
use std::fmt::Write as _;
use std::hint::black_box;
use std::time::Instant;

/// Samples per run: `ACCELCORE_BENCH_N` (default 1e7).
fn n_samples() -> usize {
    std::env::var("ACCELCORE_BENCH_N")
        .ok()
        .and_then(|v| v.parse::<f64>().ok())
        .map_or(10_000_000, |v| v as usize)
}

/// Timed repetitions (median reported): `ACCELCORE_BENCH_REPEAT` (default 5).
fn repeats() -> usize {
    std::env::var("ACCELCORE_BENCH_REPEAT")
        .ok()
        .and_then(|v| v.parse().ok())
        .map_or(5, |v: usize| v.max(1))
}

fn data() -> (Vec<f64>, Vec<f64>, Array2<f64>) {
    let n = n_samples();
    // ACCELCORE_BENCH_JITTER=1: times jittered by up to 10 ms, as in `benches/data.py`.
    let jitter = std::env::var_os("ACCELCORE_BENCH_JITTER").is_some();
    let t: Vec<f64> = (0..n)
        .map(|i| {
            let dither = if jitter {
                // Row 0 is dithered too, so the grid (anchored at the first
                // time) is not aligned with the rows: blocks hold 9 to 11 of them.
                ((i as u64 + 1).wrapping_mul(0x9e37_79b9_7f4a_7c15) >> 11) as f64
                    / (1u64 << 53) as f64
            } else {
                0.0
            };
            i as f64 / 20.0 + 0.01 * dither
        })
        .collect();
    let temp: Vec<f64> = (0..n).map(|i| -20.0 + 80.0 * i as f64 / n as f64).collect();
    let ch = Array2::from_shape_fn((n, 3), |(i, j)| ((i * 7 + j * 13) % 101) as f64 * 1e-3);
    (t, temp, ch)
}

fn median_rate(mut run: impl FnMut()) -> f64 {
    let mut times: Vec<f64> = (0..repeats())
        .map(|_| {
            let start = Instant::now();
            run();
            start.elapsed().as_secs_f64()
        })
        .collect();
    times.sort_by(f64::total_cmp);
    n_samples() as f64 / times[times.len() / 2]
}

#[test]
fn throughput() {
    let (t, temp, ch) = data();
    let binner = BinnerConfig {
        lo_c: -40.0,
        hi_c: 85.0,
        ..BinnerConfig::default()
    };
    // ACCELCORE_BENCH=read (a comma-separated list) runs only those kernels, e.g. under perf.
    let only = std::env::var("ACCELCORE_BENCH").unwrap_or_default();
    let want = |name: &str| only.is_empty() || only.split(',').any(|w| w == name);
    let report = |name: &str, rate: f64| eprintln!("{name:<10} {:8.1} M samples/s", rate / 1e6);
    if want("decimate") {
        report(
            "decimate",
            median_rate(|| {
                let mut d = Decimator::new(DecimatorConfig::default()).unwrap();
                for start in (0..t.len()).step_by(8192) {
                    let end = (start + 8192).min(t.len());
                    let view = ch.slice_axis(Axis(0), Slice::from(start..end));
                    d.push(&t[start..end], &temp[start..end], view).unwrap();
                    black_box(d.drain_completed());
                }
            }),
        );
    }
    if want("scan") {
        // Memory floor: one branch-free pass over every input value.
        let flat = ch.as_slice().unwrap();
        report(
            "scan",
            median_rate(|| {
                let ok = [&t[..], &temp[..], flat]
                    .iter()
                    .all(|v| v.iter().fold(true, |ok, x| ok & x.is_finite()));
                black_box(ok);
            }),
        );
    }
    if want("bin") {
        report(
            "bin",
            median_rate(|| {
                let mut b = TemperatureBinner::new(binner.clone()).unwrap();
                b.push(&t, &temp, ch.view()).unwrap();
                black_box(b.finish().unwrap());
            }),
        );
    }
    let design = Array2::from_shape_fn((t.len(), 2), |(i, j)| if j == 0 { 1.0 } else { temp[i] });
    let y = ch.column(0).to_vec();
    if want("lstsq") {
        report(
            "lstsq",
            median_rate(|| {
                let mut ls = LeastSquares::new(2, None).unwrap();
                ls.push(design.view(), &y, None).unwrap();
                black_box(ls.finish().unwrap());
            }),
        );
    }
    if want("lstsq12") {
        // A weighted fit of 12 columns (powers of temperature, then products with a
        // second regressor), as the diagnosis's wide designs; one row in 17 of weight 0.
        // At most 1e6 rows (a 1e7-row design would take 1 GB); the rate is per row.
        let rows = t.len().min(1_000_000);
        let design = Array2::from_shape_fn((rows, 12), |(i, j)| {
            let u = (temp[i] - 20.0) / 40.0;
            let v = ch[(i, 1)] - 0.05;
            if j < 6 {
                u.powi(j as i32)
            } else {
                v * u.powi(j as i32 - 6)
            }
        });
        let w: Vec<f64> = (0..rows)
            .map(|i| {
                if i % 17 == 0 {
                    0.0
                } else {
                    1.0 + (i % 5) as f64
                }
            })
            .collect();
        let rate = median_rate(|| {
            let mut ls = LeastSquares::new(12, None).unwrap();
            ls.push(design.view(), &y[..rows], Some(&w)).unwrap();
            black_box(ls.finish().unwrap());
        });
        report("lstsq12", rate * rows as f64 / t.len() as f64);
    }
    if want("read") {
        // A 20 Hz log as `accelcore.simulate` writes it (time to 0.01 s, temperature
        // to 0.001 degC, volts to 1 uV), from disk (page cache) to decimated blocks.
        let path = std::env::temp_dir().join(format!("accelcore-bench-{}.csv", t.len()));
        let mut text = String::from("time_s,temp_c,x,y,z\n");
        for (i, (ti, tc)) in t.iter().zip(&temp).enumerate() {
            let v = |j: usize| 1.5 + ch[(i, j)] * 0.3 - 0.01 * ((i % 13) as f64);
            writeln!(text, "{ti:.2},{tc:.3},{:.6},{:.6},{:.6}", v(0), v(1), v(2)).unwrap();
        }
        std::fs::write(&path, &text).unwrap();
        let mb = text.len() as f64 / 1e6;
        let rate = median_rate(|| {
            black_box(read_run(&path, &CsvFormat::default(), DecimatorConfig::default()).unwrap());
        });
        report("read", rate);
        eprintln!("{:<10} {:8.1} MB/s", "read", rate * mb / t.len() as f64);
        std::fs::remove_file(&path).unwrap();
    }
}
