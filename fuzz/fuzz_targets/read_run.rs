//! Fuzz the streaming log reader: arbitrary bytes through `read_run_from`
//! with a few formats must give `Ok` or `Err`, never a panic, abort or hang.
//!
//! Run (nightly): `cargo +nightly fuzz run read_run fuzz/regressions -- -max_total_time=60`
//! from the repository root. Crashes found go to `fuzz/regressions/` and are replayed
//! on stable by `rust/accelcore-core/tests/reader_fuzz_regressions.rs`.
#![no_main]

use accelcore_core::{read_run_from, CsvFormat, DecimatorConfig};
use libfuzzer_sys::fuzz_target;

fn formats() -> [(CsvFormat, DecimatorConfig); 4] {
    let default = CsvFormat::default();
    [
        (default.clone(), DecimatorConfig::default()),
        (
            CsvFormat {
                delimiter: b';',
                keep_extra_columns: false,
                time_scale_to_s: 1e-3,
                ..default.clone()
            },
            DecimatorConfig {
                factor: 1,
                min_count: 2,
                ..DecimatorConfig::default()
            },
        ),
        (
            CsvFormat {
                delimiter: b'\t',
                channel_columns: vec!["x".into()],
                ..default.clone()
            },
            DecimatorConfig {
                factor: 3,
                rate_hz: 1e-300,
                ..DecimatorConfig::default()
            },
        ),
        (
            // Short one-letter names so the fuzzer finds valid headers quickly.
            CsvFormat {
                time_column: "t".into(),
                temperature_column: "c".into(),
                channel_columns: vec!["x".into(), "y".into()],
                time_scale_to_s: 1e300,
                ..default
            },
            DecimatorConfig {
                factor: 1_000_000,
                rate_hz: 1e300,
                ..DecimatorConfig::default()
            },
        ),
    ]
}

fuzz_target!(|data: &[u8]| {
    // The first byte picks the format so each input exercises one path deeply.
    let Some((&pick, rest)) = data.split_first() else {
        return;
    };
    let all = formats();
    let (format, config) = &all[usize::from(pick) % all.len()];
    let result = read_run_from(rest, "fuzz.csv", format, config.clone());
    if let Ok(run) = result {
        // Invariants of a successful read.
        assert!(!run.blocks.is_empty());
        assert_eq!(
            run.blocks.channels.len(),
            run.blocks.len() * run.blocks.n_channels
        );
        assert!(run.n_skipped_nonfinite <= run.n_rows);
        assert!(run.n_truncated_rows <= 1);
        assert_eq!(run.channel_ranges.len(), run.channel_names.len());
    }
});
