//! The reader's fast path (whole rows parsed straight from its buffer) gives what
//! the line-by-line path gives, bit for bit, errors included.
//!
//! The oracle is the same reader fed one byte per `read` call: its buffer then
//! never holds a whole row ahead of the line being read, so every line takes the
//! slow path (`memchr` for the line end, then `parse_row`).

use std::fmt::Write as _;
use std::io::Read;

use accelcore_core::{read_run_from, CsvFormat, DecimatorConfig, Error, RunData};
use proptest::prelude::*;

/// A reader that hands out one byte per call.
struct OneByte<'a>(&'a [u8]);

impl Read for OneByte<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        match (self.0.split_first(), buf.first_mut()) {
            (Some((&b, rest)), Some(slot)) => {
                *slot = b;
                self.0 = rest;
                Ok(1)
            }
            _ => Ok(0),
        }
    }
}

fn formats() -> Vec<CsvFormat> {
    vec![
        CsvFormat::default(),
        CsvFormat {
            delimiter: b';',
            time_scale_to_s: 1e-3,
            ..CsvFormat::default()
        },
        CsvFormat {
            delimiter: b'\t',
            keep_extra_columns: false,
            ..CsvFormat::default()
        },
    ]
}

/// Both readings, shown with `{:?}` (NaN equals NaN, -0.0 differs from 0.0, and
/// every finite double prints as its shortest round-trip decimal: equal text is
/// equal bits).
fn both(text: &[u8], format: &CsvFormat) -> (String, String) {
    let config = DecimatorConfig {
        factor: 3,
        ..DecimatorConfig::default()
    };
    let fast: Result<RunData, Error> = read_run_from(text, "log.csv", format, config.clone());
    let slow = read_run_from(OneByte(text), "log.csv", format, config);
    (format!("{fast:?}"), format!("{slow:?}"))
}

#[test]
fn plain_logs_and_their_edge_cases_read_alike() {
    let mut rows = String::new();
    for i in 0..2000 {
        writeln!(
            rows,
            "{:.2},{:.3},{:.6},-{:.6},+{}",
            f64::from(i) * 0.05,
            -20.0 + f64::from(i) * 0.01,
            1.5 + f64::from(i % 7) * 1e-6,
            0.25 * f64::from(i % 5),
            i % 100
        )
        .unwrap();
    }
    for text in [
        format!("time_s,temp_c,x,y,z\n{rows}"),
        format!("time_s,temp_c,x,y,z\r\n{}", rows.replace('\n', "\r\n")),
        format!("time_s,temp_c,x,y,z\n{rows}1e3,2,3,4,5\n"),
        format!("time_s,temp_c,x,y,z\n{rows}200.5,2,3,4"),
        format!("time_s,temp_c,x,y,z\n{rows}200.5,2,3,4,5"),
        format!("time_s,temp_c,x,y,z\n{rows}99.95,2,3,4,5\n"),
        format!("time_s,temp_c,x,y,z\n{rows}\n\n 200, 1,2,3,4\n"),
        format!("time_s,temp_c,x,y,z\n{rows}200,1,2,3,4,5\n"),
        format!("time_s,temp_c,x,y,z\n{rows}200,1,,3,4\n201,.5,5.,-.5,+0\n"),
        format!("time_s,temp_c,x,y,z\n{rows}200,1,1234567890123456,3,4\n"),
        format!("time_s,temp_c,x,y,z\n{rows}200,1,123456789012345,3,4\n"),
        format!("time_s,temp_c,x,y,z\n{rows}200,1,1.2.3,3,4\n"),
        format!("time_s,temp_c,x,y,z\n{rows}200,1,nan,3,4\r\n201,2,3,4,5\r"),
        // Cells that start like the column's last one and go on, or change sign.
        format!(
            "time_s,temp_c,x,y,z\n{rows}200,1.5,2,3,4\n201,1.55,2.5,3,4\n202,1.555,2.55,-3,+4\n\
             203,-1.555,25.5,-3.0,+4.\n204,1.5,2,3,4\n205,12345678,.5,5.,-0\n206,1234567.8,1,1,1\n"
        ),
    ] {
        let (fast, slow) = both(text.as_bytes(), &CsvFormat::default());
        assert_eq!(fast, slow, "{}", &text[text.len().saturating_sub(80)..]);
    }
}

#[test]
fn cells_of_one_width_with_the_sign_or_point_elsewhere_read_alike() {
    // Each column cycles through cells of one width: a sign or a point in another
    // byte than the previous cell's must not be read with the previous layout.
    let temps = ["-2.013", "12.013", "+2.013", "2.0135", "-0.013", "00.013"];
    let xs = [
        "1.2345", "12.345", "123.45", "1234.5", "12345.", ".12345", "-1.234",
    ];
    let ys = ["5", "-5", "+5", "55", "-0", "0"];
    let mut text = String::from("time_s,temp_c,x,y,z\n");
    for i in 0..500 {
        let (a, b, c) = (temps[i % 6], xs[(i / 2) % 7], ys[(i / 3) % 6]);
        writeln!(text, "{i}.5,{a},{b},{c},{}", xs[(i * 5) % 7]).unwrap();
    }
    let (fast, slow) = both(text.as_bytes(), &CsvFormat::default());
    assert_eq!(fast, slow);
}

/// One cell: mostly plain decimals, sometimes anything a log may hold.
fn cell() -> impl Strategy<Value = String> {
    prop_oneof![
        8 => "[+-]?[0-9]{1,6}\\.[0-9]{1,7}",
        2 => "[+-]?[0-9]{1,9}",
        1 => "[+-]?[0-9]{0,17}\\.?[0-9]{0,17}",
        1 => "[+-]?[0-9]{1,3}\\.[0-9]{1,3}[eE][+-]?[0-9]{1,2}",
        1 => prop_oneof![
            Just(String::new()),
            Just(" 1.25 ".to_string()),
            Just("nan".to_string()),
            Just("-inf".to_string()),
            Just("+".to_string()),
            Just(".".to_string()),
            Just("1..2".to_string()),
            Just("0x10".to_string()),
        ],
    ]
}

/// Cells of a few same-width shapes, so that consecutive rows often share a width.
fn pool_cell() -> impl Strategy<Value = String> {
    (
        0usize..4,
        prop_oneof![Just(""), Just("-"), Just("+")],
        "[0-9]{6}",
    )
        .prop_map(|(point, sign, digits)| {
            let (a, b) = digits.split_at(point + 1);
            format!("{sign}{a}.{b}")
        })
}

/// One line: usually five cells, then a line end of any kind.
fn line() -> impl Strategy<Value = String> {
    (
        prop::collection::vec(prop_oneof![3 => cell(), 2 => pool_cell()], 4..=6),
        prop_oneof![
            8 => Just("\n"),
            2 => Just("\r\n"),
            1 => Just("\r"),
            1 => Just("\n\n"),
            1 => Just(" \n"),
        ],
        any::<bool>(),
    )
        .prop_map(|(cells, end, tab)| {
            let joined = cells.join(if tab { "\t" } else { "," });
            format!("{joined}{end}")
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn random_logs_read_alike(
        lines in prop::collection::vec(line(), 0..60),
        increasing in prop::collection::vec(0u32..200_000, 0..60),
        cut in any::<bool>(),
    ) {
        // Mostly valid logs: the first cell becomes an increasing time where given.
        let mut t = 0u32;
        let mut body = String::new();
        for (i, line) in lines.iter().enumerate() {
            match increasing.get(i) {
                Some(&step) if line.contains(',') || line.contains('\t') => {
                    t += step % 97 + 1;
                    let at = line.find([',', '\t']).unwrap_or(0);
                    write!(body, "{}.{:02}{}", t / 100, t % 100, &line[at..]).unwrap();
                }
                _ => body.push_str(line),
            }
        }
        if cut && !body.is_empty() {
            body.truncate(body.len() - 1);
        }
        for (format, header) in formats().iter().zip([
            "time_s,temp_c,x,y,z\n",
            "time_s;temp_c;x;y;z\n",
            "time_s\ttemp_c\tx\ty\tz\n",
        ]) {
            let text = format!("{header}{}", body.replace([',', '\t'], &char::from(format.delimiter).to_string()));
            let (fast, slow) = both(text.as_bytes(), format);
            prop_assert_eq!(fast, slow, "{:?}", text);
        }
    }
}
