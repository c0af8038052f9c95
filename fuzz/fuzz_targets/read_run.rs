//! Fuzz the streaming log reader: arbitrary bytes through `read_run_from`
//! with the configurations of `fuzz/formats.rs` must give `Ok` or `Err`, never
//! a panic, an abort or a hang.
//!
//! From the repository root (nightly):
//! `cargo +nightly fuzz run read_run fuzz/corpus/read_run fuzz/seeds -- -max_total_time=300`
//! A crash is written to `fuzz/artifacts/read_run/`: copy it to
//! `fuzz/regressions/`, where `rust/accelcore-core/tests/reader_fuzz_regressions.rs`
//! replays it on stable in every `cargo test`.
#![no_main]

#[path = "../formats.rs"]
mod formats;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| formats::check(data));
