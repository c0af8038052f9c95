//! Reading one log in pieces and merging them gives the one-pass result.
#![allow(clippy::format_push_string, clippy::cast_lossless)]

use std::io::Write;

use sha2::Digest;

use accelcore_core::{
    merge_runs, plan_split, read_run, read_run_digest, read_run_hashed, read_run_range, CsvFormat,
    DecimatorConfig, DigestAlgorithm, Error,
};

fn write_log(rows: usize, nan_every: usize, gap_at: usize) -> tempfile_path::TempLog {
    let mut text = String::from("time_s,temp_c,x,y,z,supply_v\n");
    let mut t = 0.0f64;
    for i in 0..rows {
        if i == gap_at {
            t += 3.3;
        }
        let y = if nan_every > 0 && i % nan_every == 7 {
            "nan".to_string()
        } else {
            format!("{:.6}", 1.48 + 1e-4 * (i % 13) as f64)
        };
        text.push_str(&format!(
            "{t:.3},{:.3},{:.6},{y},{:.6},{:.4}\n",
            -2.0 + 0.001 * i as f64,
            1.5 + 1e-5 * i as f64,
            1.8 - 1e-6 * i as f64,
            3.0 + 1e-4 * (i % 7) as f64
        ));
        t += 0.05;
    }
    tempfile_path::TempLog::new(&text)
}

mod tempfile_path {
    use std::path::PathBuf;

    pub(crate) struct TempLog(pub(crate) PathBuf);

    impl TempLog {
        pub(crate) fn new(text: &str) -> Self {
            use std::sync::atomic::{AtomicUsize, Ordering};
            static N: AtomicUsize = AtomicUsize::new(0);
            let n = N.fetch_add(1, Ordering::Relaxed);
            let path = std::env::temp_dir()
                .join(format!("accelcore-split-{}-{n}.csv", std::process::id()));
            let mut f = std::fs::File::create(&path).unwrap();
            super::Write::write_all(&mut f, text.as_bytes()).unwrap();
            Self(path)
        }
    }

    impl Drop for TempLog {
        fn drop(&mut self) {
            let _ = std::fs::remove_file(&self.0);
        }
    }
}

fn split_equals_one_pass(rows: usize, pieces: usize, min_count: usize) {
    let log = write_log(rows, 11, rows / 3);
    let format = CsvFormat::default();
    let config = DecimatorConfig {
        min_count,
        ..DecimatorConfig::default()
    };
    let whole = read_run(&log.0, &format, config.clone()).unwrap();
    let plan = plan_split(&log.0, &format, pieces).unwrap();
    assert!(plan.ranges.len() <= pieces);
    let piece_config = DecimatorConfig {
        t0_s: plan.t0_s,
        min_count: 1,
        ..config
    };
    let parts: Vec<_> = plan
        .ranges
        .iter()
        .map(|&(a, b)| read_run_range(&log.0, &format, piece_config.clone(), a, b).unwrap())
        .collect();
    let merged = merge_runs(&parts, min_count, 20.0).unwrap();
    assert_eq!(merged.blocks.block_index, whole.blocks.block_index);
    assert_eq!(merged.blocks.count, whole.blocks.count);
    // Joined blocks are count-weighted means of partial means: equal to rounding.
    let close = |a: &[f64], b: &[f64]| {
        a.iter()
            .zip(b)
            .all(|(x, y)| (x - y).abs() <= 1e-13 * x.abs().max(1.0))
    };
    assert!(close(&merged.blocks.time_s, &whole.blocks.time_s));
    assert!(close(
        &merged.blocks.temperature_c,
        &whole.blocks.temperature_c
    ));
    assert!(close(&merged.blocks.channels, &whole.blocks.channels));
    assert_eq!(merged.n_rows, whole.n_rows);
    assert_eq!(merged.n_skipped_nonfinite, whole.n_skipped_nonfinite);
    assert_eq!(merged.n_gaps, whole.n_gaps);
    assert_eq!(merged.max_interval_s, whole.max_interval_s);
    assert_eq!(merged.first_time_s, whole.first_time_s);
    assert_eq!(merged.last_time_s, whole.last_time_s);
    assert_eq!(merged.channel_ranges, whole.channel_ranges);
    assert_eq!(merged.channel_names, whole.channel_names);
}

#[test]
fn pieces_merge_to_the_one_pass_result() {
    for pieces in [1, 2, 3, 7, 16] {
        split_equals_one_pass(2000, pieces, 1);
        split_equals_one_pass(2000, pieces, 8);
    }
}

#[test]
fn more_pieces_than_lines_is_fine() {
    split_equals_one_pass(5, 64, 1);
}

#[test]
fn errors_in_a_later_piece_name_the_line_in_the_whole_file() {
    let mut text = String::from("time_s,temp_c,x,y,z\n");
    for i in 0..100 {
        let x = if i == 80 {
            "bad".to_string()
        } else {
            "1.5".to_string()
        };
        text.push_str(&format!("{:.2},20,{x},1.5,1.8\n", f64::from(i) * 0.05));
    }
    let log = tempfile_path::TempLog::new(&text);
    let format = CsvFormat::default();
    let plan = plan_split(&log.0, &format, 4).unwrap();
    let config = DecimatorConfig {
        t0_s: plan.t0_s,
        ..DecimatorConfig::default()
    };
    let errors: Vec<_> = plan
        .ranges
        .iter()
        .filter_map(|&(a, b)| read_run_range(&log.0, &format, config.clone(), a, b).err())
        .collect();
    assert_eq!(errors.len(), 1);
    assert!(
        matches!(
            &errors[0],
            Error::Parse {
                line: 82,
                column: 3,
                ..
            }
        ),
        "{:?}",
        errors[0]
    );
}

#[test]
fn a_piece_needs_the_block_origin() {
    let log = write_log(10, 0, 100);
    let err = read_run_range(
        &log.0,
        &CsvFormat::default(),
        DecimatorConfig::default(),
        0,
        100,
    )
    .unwrap_err();
    assert!(matches!(err, Error::InvalidParameter { name: "t0_s", .. }));
    assert!(matches!(merge_runs(&[], 1, 20.0), Err(Error::Empty { .. })));
}

fn hex(digest: &[u8]) -> String {
    digest.iter().fold(String::new(), |mut hex, b| {
        std::fmt::Write::write_fmt(&mut hex, format_args!("{b:02x}")).unwrap();
        hex
    })
}

#[test]
fn hashed_read_is_the_plain_read_and_the_files_sha256() {
    let config = DecimatorConfig::default();
    // A last line cut off mid-write: dropped from the data, but part of the file's
    // bytes. The digest is coreutils' `sha256sum` of the same bytes.
    let cut = tempfile_path::TempLog::new(
        "time_s,temp_c,x,y,z\n0.00,20.0,1,2,3\n0.05,20.0,1,2,3\n0.10,20.1,1,2",
    );
    let (run, digest) = read_run_hashed(&cut.0, &CsvFormat::default(), config.clone()).unwrap();
    assert_eq!(run.n_truncated_rows, 1);
    assert_eq!(
        run,
        read_run(&cut.0, &CsvFormat::default(), config.clone()).unwrap()
    );
    assert_eq!(
        hex(&digest),
        "115f2c19404e0ef6db6779d4b68a6700e719155d7612013f4c5ee75b2cf2d318"
    );
    // 60k rows (about 3 MB) span several fills of the reader's buffer: every byte is
    // hashed once, in order, as the one-shot digest of the whole file says.
    let log = write_log(60_000, 11, 30_000);
    let (run, digest) = read_run_hashed(&log.0, &CsvFormat::default(), config.clone()).unwrap();
    assert_eq!(
        run,
        read_run(&log.0, &CsvFormat::default(), config).unwrap()
    );
    let whole = sha2::Sha256::digest(std::fs::read(&log.0).unwrap());
    assert_eq!(digest, <[u8; 32]>::from(whole));
}

#[test]
fn blake3_read_is_the_plain_read_and_the_files_blake3() {
    let config = DecimatorConfig::default();
    let blake3 = DigestAlgorithm::Blake3;
    assert_eq!(DigestAlgorithm::default(), blake3);
    // A last line cut off mid-write: dropped from the data, but part of the file's
    // bytes. The digest is `b3sum`'s of the same bytes (the reference implementation).
    let cut = tempfile_path::TempLog::new(
        "time_s,temp_c,x,y,z\n0.00,20.0,1,2,3\n0.05,20.0,1,2,3\n0.10,20.1,1,2",
    );
    let (run, digest) =
        read_run_digest(&cut.0, &CsvFormat::default(), config.clone(), blake3).unwrap();
    assert_eq!(run.n_truncated_rows, 1);
    assert_eq!(
        run,
        read_run(&cut.0, &CsvFormat::default(), config.clone()).unwrap()
    );
    assert_eq!(
        hex(&digest),
        "f23ac4630b5adfb38dfd526ed1859513db6ebd46b2765abc0120dea164361096"
    );
    assert_eq!(
        hex(&blake3.digest(b"")),
        "af1349b9f5f9a1a6a0404dea36dcc9499bcb25c9adc112b7cc9a93cae41f3262"
    );
    // 120k rows (about 6 MB) span several fills of the reader's 1 MiB buffer: every
    // byte is hashed once, in order, as the crate's one-shot `blake3::hash` says.
    let log = write_log(120_000, 11, 30_000);
    let bytes = std::fs::read(&log.0).unwrap();
    assert!(bytes.len() > 5 << 20, "{}", bytes.len());
    let (run, digest) =
        read_run_digest(&log.0, &CsvFormat::default(), config.clone(), blake3).unwrap();
    assert_eq!(
        run,
        read_run(&log.0, &CsvFormat::default(), config.clone()).unwrap()
    );
    assert_eq!(digest, *blake3::hash(&bytes).as_bytes());
    assert_eq!(digest, blake3.digest(&bytes));
    // SHA-256 on request is the older entry point's digest.
    let (_, sha) = read_run_digest(
        &log.0,
        &CsvFormat::default(),
        config.clone(),
        DigestAlgorithm::Sha256,
    )
    .unwrap();
    assert_eq!(
        sha,
        read_run_hashed(&log.0, &CsvFormat::default(), config)
            .unwrap()
            .1
    );
    assert_eq!(sha, <[u8; 32]>::from(sha2::Sha256::digest(&bytes)));
}

#[test]
fn digest_names_round_trip() {
    for algorithm in [DigestAlgorithm::Blake3, DigestAlgorithm::Sha256] {
        assert_eq!(
            DigestAlgorithm::from_name(algorithm.name()).unwrap(),
            algorithm
        );
    }
    assert!(matches!(
        DigestAlgorithm::from_name("md5"),
        Err(Error::InvalidParameter { name: "digest", .. })
    ));
}

#[test]
fn hashed_read_reports_the_same_errors() {
    let bad = tempfile_path::TempLog::new("time_s,temp_c,x,y,z\n0.00,20.0,1,oops,3\n");
    let plain = read_run(&bad.0, &CsvFormat::default(), DecimatorConfig::default()).unwrap_err();
    let hashed =
        read_run_hashed(&bad.0, &CsvFormat::default(), DecimatorConfig::default()).unwrap_err();
    assert_eq!(plain.to_string(), hashed.to_string());
    assert!(
        matches!(
            hashed,
            Error::Parse {
                line: 2,
                column: 4,
                ..
            }
        ),
        "{hashed}"
    );
}
