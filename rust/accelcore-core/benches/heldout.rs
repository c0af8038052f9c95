//! Time of the held-out least squares at the diagnosis's sizes, in microseconds.
//!
//! Plain timing (no criterion): `cargo bench -p accelcore-core --bench heldout --
//! --nocapture` prints one line per case (median and least of
//! `ACCELCORE_BENCH_REPEAT` runs, default 21). The shapes are those of a six-run, 2 h diagnosis: 2,740
//! windows in 144 blocks of about 19, six folds (one per run); a catalogue of 26
//! or 46 columns and 3 responses queried for subsets of 10 columns, own designs
//! of 7 to 22 columns, and a time-constant trial (8 columns, a fold's blocks
//! pushed as one block).
#![allow(clippy::print_stderr)]
use accelcore_core::BlockedLeastSquares;
use ndarray::Array2;
use std::hint::black_box;
use std::time::Instant;

/// Timed repetitions (median reported): `ACCELCORE_BENCH_REPEAT` (default 21).
fn repeats() -> usize {
    std::env::var("ACCELCORE_BENCH_REPEAT")
        .ok()
        .and_then(|v| v.parse().ok())
        .map_or(21, |v: usize| v.max(1))
}

/// Median and least wall time of `run`, in microseconds (the least is the
/// steadier on a shared machine).
fn median_us(run: &mut dyn FnMut()) -> (f64, f64) {
    run(); // warm
    let mut times: Vec<f64> = (0..repeats())
        .map(|_| {
            let start = Instant::now();
            run();
            start.elapsed().as_secs_f64() * 1e6
        })
        .collect();
    times.sort_by(f64::total_cmp);
    (times[times.len() / 2], times[0])
}

const ROWS: usize = 2740;
const BLOCKS: usize = 144;
const FOLDS: u32 = 6;

/// Pseudo-random in [-0.5, 0.5).
fn noise(i: usize, j: usize) -> f64 {
    let h = ((i * 131 + j * 7919 + 17) as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    (h >> 11) as f64 / (1u64 << 53) as f64 - 0.5
}

/// A design of `p` columns: powers of a temperature ramp per run, elapsed time,
/// gravity products and noise columns (well-conditioned enough for every fold).
fn design(p: usize, m: usize) -> (Array2<f64>, Array2<f64>, Vec<f64>) {
    let x = Array2::from_shape_fn((ROWS, p), |(i, j)| {
        let run = i * 6 / ROWS;
        let u = ((i % (ROWS / 6)) as f64 / (ROWS / 6) as f64 - 0.5) * (1.0 + 0.1 * run as f64);
        match j {
            0 => 1.0,
            1..=5 => u.powi(j as i32),
            _ => noise(i, j) + 0.3 * u.powi((j % 3) as i32),
        }
    });
    let y = Array2::from_shape_fn((ROWS, m), |(i, r)| {
        (0..p)
            .map(|j| x[[i, j]] * (1.0 + j as f64 + r as f64))
            .sum::<f64>()
            + 0.01 * noise(i, p + r)
    });
    let w = (0..ROWS).map(|i| 1.0 + (i % 7) as f64).collect();
    (x, y, w)
}

fn block_of_rows(n_blocks: usize) -> Vec<u32> {
    (0..ROWS).map(|i| (i * n_blocks / ROWS) as u32).collect()
}

fn fold_of_blocks(n_blocks: usize) -> Vec<u32> {
    (0..n_blocks)
        .map(|b| (b * FOLDS as usize / n_blocks) as u32)
        .collect()
}

#[test]
fn heldout() {
    // ACCELCORE_BENCH=push (a comma-separated list of words) runs only the
    // cases whose name holds one of them, e.g. under perf.
    let only = std::env::var("ACCELCORE_BENCH").unwrap_or_default();
    let want = |name: &str| only.is_empty() || only.split(',').any(|w| name.contains(w));
    let median_us = |name: &str, run: &mut dyn FnMut()| {
        if want(name) {
            let (median, least) = median_us(run);
            eprintln!("{name:<28} {median:9.1} us (least {least:9.1})");
        }
    };
    let block = block_of_rows(BLOCKS);
    let block_fold = fold_of_blocks(BLOCKS);
    for (p, m) in [(26, 3), (46, 3)] {
        let (x, y, w) = design(p, m);
        let push = || {
            let mut cv = BlockedLeastSquares::with_responses(p, m, BLOCKS).unwrap();
            cv.push_multi(x.view(), y.view(), Some(&w), &block).unwrap();
            cv
        };
        median_us(&format!("catalogue push p={p} m={m}"), &mut || {
            black_box(push());
        });
        let cv = push();
        median_us(&format!("catalogue folds p={p} m={m}"), &mut || {
            black_box(cv.folds(&block_fold).unwrap());
        });
        let folded = cv.folds(&block_fold).unwrap();
        let columns: Vec<usize> = (0..p).step_by(p / 10 + 1).chain([1, 2]).collect();
        let mut columns = columns;
        columns.sort_unstable();
        columns.dedup();
        median_us(
            &format!("catalogue query q={} p={p}", columns.len()),
            &mut || {
                black_box(folded.cross_validate(&columns, 1).unwrap());
            },
        );
    }
    for p in [7, 14, 22] {
        let (x, y, w) = design(p, 1);
        let y = y.column(0).to_vec();
        median_us(&format!("own push+cv p={p}"), &mut || {
            let mut cv = BlockedLeastSquares::new(p, BLOCKS).unwrap();
            cv.push(x.view(), &y, Some(&w), &block).unwrap();
            black_box(cv.cross_validate(&block_fold).unwrap());
        });
    }
    // A time-constant trial: each fold's rows pushed as one block.
    let fold_block: Vec<u32> = block.iter().map(|&b| block_fold[b as usize]).collect();
    let folds: Vec<u32> = (0..FOLDS).collect();
    for p in [8, 14] {
        let (x, y, w) = design(p, 1);
        let y = y.column(0).to_vec();
        median_us(&format!("trial push+cv p={p}"), &mut || {
            let mut cv = BlockedLeastSquares::new(p, FOLDS as usize).unwrap();
            cv.push(x.view(), &y, Some(&w), &fold_block).unwrap();
            black_box(cv.cross_validate(&folds).unwrap());
        });
    }
}
