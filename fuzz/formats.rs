//! The reader configurations the fuzzers exercise, shared by the cargo-fuzz
//! target (`fuzz/fuzz_targets/read_run.rs`) and the stable replay test
//! (`rust/accelcore-core/tests/reader_fuzz_regressions.rs`). The first byte of
//! a fuzz input picks one (`pick % FORMATS`), the rest is the file.

use accelcore_core::{CsvFormat, DecimatorConfig};

/// Number of configurations.
pub(crate) const FORMATS: usize = 4;

/// Configuration number `pick % FORMATS`.
pub(crate) fn format(pick: u8) -> (CsvFormat, DecimatorConfig) {
    let default = CsvFormat::default();
    match usize::from(pick) % FORMATS {
        0 => (default, DecimatorConfig::default()),
        1 => (
            CsvFormat {
                delimiter: b';',
                keep_extra_columns: false,
                time_scale_to_s: 1e-3,
                ..default
            },
            DecimatorConfig {
                factor: 1,
                min_count: 2,
                ..DecimatorConfig::default()
            },
        ),
        2 => (
            CsvFormat {
                delimiter: b'\t',
                channel_columns: vec!["x".into()],
                ..default
            },
            DecimatorConfig {
                factor: 3,
                rate_hz: 1e-300,
                ..DecimatorConfig::default()
            },
        ),
        _ => (
            // One-letter names so that random input finds a valid header quickly;
            // extreme scales to reach overflow paths.
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
    }
}

/// Read `data[1..]` with the configuration `data[0]` picks, and check the
/// invariants of a successful read. Panics only on a broken invariant.
pub(crate) fn check(data: &[u8]) {
    let Some((&pick, file)) = data.split_first() else {
        return;
    };
    let (format, config) = format(pick);
    if let Ok(run) = accelcore_core::read_run_from(file, "fuzz.csv", &format, config) {
        assert!(!run.blocks.is_empty(), "Ok with no block");
        assert_eq!(
            run.blocks.channels.len(),
            run.blocks.len() * run.blocks.n_channels
        );
        assert_eq!(run.blocks.n_channels, run.channel_names.len());
        assert_eq!(run.channel_ranges.len(), run.channel_names.len());
        assert!(run.n_skipped_nonfinite <= run.n_rows);
        assert!(run.n_truncated_rows <= 1);
        let kept: u64 = run.blocks.count.iter().sum();
        // Every row is averaged into a block (kept or under min_count) or skipped.
        assert!(kept + run.n_skipped_nonfinite <= run.n_rows);
        assert!(run.blocks.block_index.windows(2).all(|w| w[0] < w[1]));
    }
}
