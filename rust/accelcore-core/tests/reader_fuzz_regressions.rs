//! Stable-Rust side of the reader fuzzing (issue 7, "never crash").
//!
//! - Replays every input in `fuzz/regressions/` (crashes once found by
//!   `cargo +nightly fuzz run read_run`, see `fuzz/fuzz_targets/read_run.rs`)
//!   with the same configurations (`fuzz/formats.rs`: the first byte picks one).
//! - Hand-made nasty inputs, each with the outcome it must have.
//! - A bounded random-input fuzz loop (proptest): arbitrary bytes and
//!   token-built near-valid logs. `ACCELCORE_FUZZ_CASES` sets the number of
//!   cases (default 512, a few seconds in debug; CI may raise it).

#[path = "../../../fuzz/formats.rs"]
mod formats;

use std::io::Read;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use accelcore_core::reader::MAX_LINE_BYTES;
use accelcore_core::{
    plan_split, read_run_from, read_run_range, CsvFormat, DecimatorConfig, Error, RunData,
};
use proptest::prelude::*;

fn regressions_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/regressions")
}

fn read(text: &[u8]) -> Result<RunData, Error> {
    read_run_from(
        text,
        "nasty.csv",
        &CsvFormat::default(),
        DecimatorConfig::default(),
    )
}

fn parse_error_at(result: Result<RunData, Error>, want_line: u64, needle: &str) {
    match result {
        Err(Error::Parse { line, reason, .. }) => {
            assert_eq!(line, want_line, "{reason}");
            assert!(reason.contains(needle), "{reason:?} lacks {needle:?}");
        }
        other => panic!("expected a parse error at line {want_line}, got {other:?}"),
    }
}

#[test]
fn every_saved_fuzz_input_is_handled() {
    let dir = regressions_dir();
    let mut n = 0;
    for entry in std::fs::read_dir(&dir).expect("fuzz/regressions exists") {
        let path = entry.unwrap().path();
        if !path.is_file() || path.extension().is_some_and(|e| e == "md") {
            continue;
        }
        let data = std::fs::read(&path).unwrap();
        let start = Instant::now();
        formats::check(&data);
        assert!(
            start.elapsed() < Duration::from_secs(20),
            "{} took {:?}",
            path.display(),
            start.elapsed()
        );
        n += 1;
    }
    assert!(n > 0, "no input in {}", dir.display());
}

#[test]
fn wide_header_gets_small_batches_not_a_huge_allocation() {
    // 100k extra columns: a batch of 8192 rows would need 6.5 GB.
    let mut text = b"time_s,temp_c,x,y,z".to_vec();
    let n_extra = 100_000;
    for i in 0..n_extra {
        text.extend_from_slice(format!(",c{i}").as_bytes());
    }
    text.push(b'\n');
    for t in 0..3 {
        text.extend_from_slice(format!("{t},20,1,2,3").as_bytes());
        text.extend(std::iter::repeat_n(&b",1"[..], n_extra).flatten());
        text.push(b'\n');
    }
    let run = read(&text).unwrap();
    assert_eq!(run.n_rows, 3);
    assert_eq!(run.channel_names.len(), 3 + n_extra);
}

#[test]
fn missing_column_message_of_a_wide_header_stays_short() {
    let mut text = b"time_s,temp_c,x,y".to_vec();
    for i in 0..100_000 {
        text.extend_from_slice(format!(",c{i}").as_bytes());
    }
    text.push(b'\n');
    match read(&text) {
        Err(Error::Parse { reason, .. }) => {
            assert!(reason.contains("'z'") && reason.contains("100004 in all"));
            assert!(reason.len() < 1000, "{} bytes", reason.len());
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn overlong_line_is_an_error_not_buffered_whole() {
    // A header line, then one line of 2 MB without a line end (binary junk).
    let mut text = b"time_s,temp_c,x,y,z\n".to_vec();
    text.extend(std::iter::repeat_n(b'7', 2 * MAX_LINE_BYTES));
    parse_error_at(read(&text), 2, "line longer than");
    // The header itself too.
    let text = vec![b'a'; MAX_LINE_BYTES + 1];
    parse_error_at(read(&text), 1, "line longer than");
    // A line of exactly the limit (plus its line end) is fine.
    let mut text = b"time_s,temp_c,x,y,z\n0,20,1,2,3".to_vec();
    text.extend(std::iter::repeat_n(b' ', MAX_LINE_BYTES - 11));
    text.push(b'\n');
    assert_eq!(read(&text).unwrap().n_rows, 1);
}

#[test]
fn nul_bytes_bom_only_and_invalid_utf8() {
    parse_error_at(read(&[0u8; 4096]), 1, "missing column");
    parse_error_at(read(b"\xEF\xBB\xBF"), 1, "empty file");
    parse_error_at(read(b"\xEF\xBB\xBF\r\n\r\n"), 2, "empty file");
    parse_error_at(read(b"time_s,temp_\xFF,x,y,z\n"), 1, "UTF-8");
    parse_error_at(
        read(b"time_s,temp_c,x,y,z\n0,20,1,\xFF\x00,3\n"),
        2,
        "is not a number",
    );
    parse_error_at(
        read(b"time_s,temp_c,x,y,z\n0,20,1,2,3\0\n"),
        2,
        "not a number",
    );
}

#[test]
fn extreme_numbers_do_not_overflow() {
    // Times 1e308 apart overflow (t - t0) to inf; block indices saturate. (A temperature
    // of 1e308 is no temperature: `a_temperature_no_thermometer_reads_is_an_error_at_its_cell`.)
    let run =
        read(b"time_s,temp_c,x,y,z\n-1e308,20,1,2,3\n1e308,20,1,2,3\n1.7e308,20,-1e308,1e-320,0\n")
            .unwrap();
    assert_eq!(run.n_rows, 3);
    assert!(run.blocks.block_index.windows(2).all(|w| w[0] < w[1]));
    // Numbers beyond f64 parse as inf and are skipped and counted.
    let run = read(b"time_s,temp_c,x,y,z\n0,20,1,2,3\n1,1e999,1,2,3\n").unwrap();
    assert_eq!(run.n_skipped_nonfinite, 1);
    // A scale that overflows every time: no finite row, a clear error.
    let format = CsvFormat {
        time_scale_to_s: 1e300,
        ..CsvFormat::default()
    };
    let err = read_run_from(
        &b"time_s,temp_c,x,y,z\n1e10,20,1,2,3\n"[..],
        "x.csv",
        &format,
        DecimatorConfig::default(),
    )
    .unwrap_err();
    assert!(err.to_string().contains("finite values"), "{err}");
    // A tiny rate: every sample in block 0.
    let run = read_run_from(
        &b"time_s,temp_c,x,y,z\n0,20,1,2,3\n1e300,20,1,2,3\n"[..],
        "x.csv",
        &CsvFormat::default(),
        DecimatorConfig {
            rate_hz: 1e-300,
            ..DecimatorConfig::default()
        },
    )
    .unwrap();
    assert_eq!(run.blocks.len(), 1);
}

#[test]
fn delimiter_storms_and_lone_carriage_returns() {
    parse_error_at(read(b"time_s,temp_c,x,y,z\n,,,,,,,,,,,,\n"), 2, "fields");
    parse_error_at(read(b",,,,\n"), 1, "missing column");
    // Empty cells only: every row non-finite.
    parse_error_at(
        read(b"time_s,temp_c,x,y,z\n,,,,\n,,,,\n"),
        2,
        "finite values",
    );
    // A bare \r is not a line end: it stays in the cell.
    parse_error_at(
        read(b"time_s,temp_c,x,y,z\n0,20,1,2,3\r1,20,1,2,3\n"),
        2,
        "'3\r1' is not a number",
    );
    // Quotes are not CSV quoting here: a clear error, not a crash.
    parse_error_at(
        read(b"time_s,temp_c,x,y,z\n\"0\",20,1,2,3\n"),
        2,
        "not a number",
    );
}

#[test]
fn duplicate_and_aliased_column_names() {
    // A name repeated in the header: an error at line 1, at the column of the
    // second occurrence (it used to read the first column of that name in silence).
    let format = CsvFormat {
        channel_columns: vec!["time_s".into(), "y".into(), "y".into()],
        ..CsvFormat::default()
    };
    match read_run_from(
        &b"time_s,temp_c,y,y\n0,20,1,2\n1,20,1,2\n"[..],
        "x.csv",
        &format,
        DecimatorConfig::default(),
    ) {
        Err(Error::Parse {
            path,
            line,
            column,
            reason,
        }) => {
            assert_eq!((path.as_str(), line, column), ("x.csv", 1, 4));
            assert!(reason.contains("'y' appears twice") && reason.contains("columns 3 and 4"));
        }
        other => panic!("{other:?}"),
    }
    // The same with a blank line before the header: the header's own line is named.
    parse_error_at(
        read_run_from(
            &b"\ntime_s,temp_c,x,y,z,x\n0,20,1,2,3,4\n"[..],
            "x.csv",
            &CsvFormat::default(),
            DecimatorConfig::default(),
        ),
        2,
        "'x' appears twice",
    );
    // Distinct header names, one requested for two roles (time and a channel):
    // the reader reads that column for both (the session checks its mapping).
    let run = read_run_from(
        &b"time_s,temp_c,y,z\n0,20,1,2\n1,20,1,2\n"[..],
        "x.csv",
        &format,
        DecimatorConfig::default(),
    )
    .unwrap();
    assert_eq!(run.n_rows, 2);
}

#[test]
fn repeated_header_name_is_refused_on_every_read_path() {
    // The split read (a plan, then a later piece read alone) names line 1 too,
    // not line 1 plus the lines before the piece.
    let text: String = std::iter::once("time_s,temp_c,x,y,z,y\n".to_string())
        .chain((0..50).map(|i| format!("{i},20,1,2,3,4\n")))
        .collect();
    let path = std::env::temp_dir().join(format!(
        "accelcore-repeated-header-{}.csv",
        std::process::id()
    ));
    std::fs::write(&path, &text).unwrap();
    let format = CsvFormat::default();
    let planned = plan_split(&path, &format, 2);
    let config = DecimatorConfig {
        t0_s: Some(0.0),
        min_count: 1,
        ..DecimatorConfig::default()
    };
    let piece = read_run_range(
        &path,
        &format,
        config,
        text.len() as u64 / 2,
        text.len() as u64,
    );
    std::fs::remove_file(&path).unwrap();
    for result in [planned.map(|_| ()), piece.map(|_| ())] {
        match result {
            Err(Error::Parse {
                line,
                column,
                reason,
                ..
            }) => {
                assert_eq!((line, column), (1, 6), "{reason}");
                assert!(reason.contains("'y' appears twice"), "{reason}");
            }
            other => panic!("{other:?}"),
        }
    }
}

/// A reader that fails after some bytes, like a network file system dropping out.
struct Failing<'a>(&'a [u8]);

impl Read for Failing<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        if self.0.is_empty() {
            return Err(std::io::Error::other("device went away"));
        }
        let n = buf.len().min(self.0.len()).min(7);
        buf[..n].copy_from_slice(&self.0[..n]);
        self.0 = &self.0[n..];
        Ok(n)
    }
}

#[test]
fn read_error_mid_stream_is_an_io_error() {
    let err = read_run_from(
        Failing(b"time_s,temp_c,x,y,z\n0,20,1,2,3\n"),
        "flaky.csv",
        &CsvFormat::default(),
        DecimatorConfig::default(),
    )
    .unwrap_err();
    assert!(
        matches!(&err, Error::Io { path, reason } if path == "flaky.csv" && reason.contains("went away")),
        "{err:?}"
    );
}

fn cases() -> u32 {
    std::env::var("ACCELCORE_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(512)
}

/// Pieces that a log is made of, and pieces that break it.
fn token() -> impl Strategy<Value = Vec<u8>> {
    prop_oneof![
        4 => prop::sample::select(vec![
            "0", "1", "20", "-3", "0.05", "1e3", "1e308", "-1e308", "1e999", "4.9e-324", "nan",
            "NaN", "inf", "-inf", "infinity", "+", "-", ".", "e", "E5", "0x10", "1_000", " ",
            "\"", "'", "time_s", "temp_c", "x", "y", "z", "t", "c",
        ])
        .prop_map(|s| s.as_bytes().to_vec()),
        3 => prop::sample::select(vec![",", ";", "\t", "\n", "\r\n", "\r", "\n\n"])
            .prop_map(|s| s.as_bytes().to_vec()),
        1 => prop::sample::select(vec![&b"\0"[..], b"\xEF\xBB\xBF", b"\xFF", b"\xC3"])
            .prop_map(<[u8]>::to_vec),
        1 => any::<f64>().prop_map(|v| v.to_string().into_bytes()),
        1 => any::<u8>().prop_map(|b| vec![b]),
    ]
}

fn near_valid_log() -> impl Strategy<Value = Vec<u8>> {
    (
        any::<u8>(),
        prop::sample::select(vec![
            &b"time_s,temp_c,x,y,z\n"[..],
            b"time_s;temp_c;x;y;z\n",
            b"time_s\ttemp_c\tx\n",
            b"t,c,x,y\n",
            b"\xEF\xBB\xBFtime_s,temp_c,x,y,z,supply_v\r\n",
        ]),
        prop::collection::vec(token(), 0..200),
    )
        .prop_map(|(pick, header, body)| {
            let mut data = vec![pick];
            data.extend_from_slice(header);
            data.extend(body.into_iter().flatten());
            data
        })
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: cases(),
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn arbitrary_bytes_never_panic(data in prop::collection::vec(any::<u8>(), 0..2048)) {
        formats::check(&data);
    }

    #[test]
    fn near_valid_logs_never_panic(data in near_valid_log()) {
        formats::check(&data);
    }

    #[test]
    fn valid_rows_with_one_flipped_byte_never_panic(
        pick in any::<u8>(),
        n in 1usize..60,
        at in any::<prop::sample::Index>(),
        byte in any::<u8>(),
    ) {
        let mut data = vec![pick % 2];
        data.extend_from_slice(b"time_s,temp_c,x,y,z\n");
        for i in 0..n {
            data.extend_from_slice(format!("{},{},1.5,-0.25,3e-2\n", i * 50, 20 + i).as_bytes());
        }
        let i = at.index(data.len() - 1) + 1;
        data[i] = byte;
        formats::check(&data);
    }
}

#[test]
fn a_missing_column_asked_for_twice_is_named_once() {
    // A log without temperature reads its time column in the temperature's place: both
    // "n". No line names it: the first is the header, and lacks it, said once.
    let format = CsvFormat {
        time_column: "n".into(),
        temperature_column: "n".into(),
        channel_columns: vec!["ax".into(), "ay".into(), "az".into()],
        ..CsvFormat::default()
    };
    let got = read_run_from(
        b"Fs,100\nindex,ax,ay,az\n0,1,2,3\n".as_slice(),
        "dump.csv",
        &format,
        DecimatorConfig::default(),
    );
    match got {
        Err(Error::Parse { line, reason, .. }) => {
            assert_eq!(line, 1, "{reason}");
            assert!(
                reason.starts_with("missing column(s) 'n', 'ax', 'ay', 'az' in the header"),
                "{reason}"
            );
        }
        other => panic!("expected a parse error, got {other:?}"),
    }
}

#[test]
fn a_preamble_above_the_header_is_skipped_and_lines_keep_their_numbers() {
    // A logger's settings lines above the header (an Arduino dump's "Fs,100").
    let text =
        b"Fs,100\nrange,2g\n\ntime_s,temp_c,x,y,z\n0,20,1,2,3\n0.05,20,1,2,3\n0.1,20,1,x,3\n";
    // The bad cell is on line 7 of the file, column 4.
    match read(text) {
        Err(Error::Parse { line, column, .. }) => assert_eq!((line, column), (7, 4)),
        other => panic!("expected a parse error on line 7, got {other:?}"),
    }
    let good = b"Fs,100\ntime_s,temp_c,x,y,z\n0,20,1,2,3\n0.05,20,1,2,3\n";
    let run = read(good).expect("the header below the preamble");
    assert_eq!(run.n_rows, 2);
    // No line names the columns: the first line is the header, and lacks them.
    let mut none = b"a,b\n".repeat(70);
    none.extend_from_slice(b"time_s,temp_c,x,y,z\n0,20,1,2,3\n");
    parse_error_at(
        read(&none),
        1,
        "missing column(s) 'time_s', 'temp_c', 'x', 'y', 'z'",
    );
}

#[test]
fn a_temperature_no_thermometer_reads_is_an_error_at_its_cell() {
    // A corrupt cell (a logger's garbage) or a temperature in kelvin x 1000.
    for (bad, shown) in [("1e30", "1e30"), ("-300", "-300"), ("2931.5", "2931.5")] {
        let text = format!("time_s,temp_c,x,y,z\n0,20,1,2,3\n0.05,{bad},1,2,3\n0.1,20,1,2,3\n");
        match read(text.as_bytes()) {
            Err(Error::Parse {
                line,
                column,
                reason,
                ..
            }) => {
                assert_eq!((line, column), (3, 2), "{reason}");
                assert!(
                    reason.starts_with(&format!(
                        "column 'temp_c': {shown} is not a temperature in °C"
                    )),
                    "{reason}"
                );
            }
            other => panic!("expected a parse error, got {other:?}"),
        }
    }
    // Cold and hot chambers' range reads as it is.
    let ok = b"time_s,temp_c,x,y,z\n0,-70,1,2,3\n0.05,180,1,2,3\n";
    assert_eq!(read(ok).expect("in range").n_rows, 2);
}
