//! The reader's fast path: whole data rows parsed straight from its buffer.
//!
//! A row takes it when every cell is a plain decimal (`[+-]digits[.digits]`, 1 to
//! 15 digits) and the line ends in `\n` or `\r\n`; anything else goes to the
//! line-by-line path, which gives the same values for the rows this accepts.
//! Logs keep each column's cell layout (sign, digits before and after the point)
//! from row to row, so each column remembers the layout of its last cell
//! ([`Layout`]): a cell of the same layout is checked and converted eight bytes
//! at a time at a position known in advance; any other cell is read byte by
//! byte ([`plain_cell`]) and its layout learnt. Both give the integer of all the
//! digits over an exact power of ten, hence the same double.

use super::POW10;

/// Whether rows split by `delimiter` may take [`parse_line_fast`]: not a byte a
/// plain decimal or a line end is made of (the slow path handles any delimiter).
pub(super) fn fast_delimiter(delimiter: u8) -> bool {
    !matches!(
        delimiter,
        b'0'..=b'9' | b'.' | b'+' | b'-' | b'\r' | b'\n' | b' '
    )
}

/// One byte repeated in every byte of a word.
const fn bytes(b: u8) -> u64 {
    0x0101_0101_0101_0101 * b as u64
}

/// The layout of a column's last cell, with the masks that check and convert
/// the next one in one 8-byte word (cells of 1 to 8 bytes; `len == 0`: none).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(super) struct Layout {
    /// Bytes of the cell.
    len: usize,
    /// The cell is negative (its first byte is `-`).
    negative: bool,
    /// Digits after the point (the point may be there with none after it).
    n_fraction: usize,
    /// High bit of every byte that must be a digit.
    digit_bits: u64,
    /// All bits of every byte that must be a sign or the point, and those bytes.
    fixed_mask: u64,
    fixed: u64,
    /// The digits made contiguous: the bytes before the point (`low`), or'ed
    /// with those after it moved down one byte (`>> up << down`, `& high`).
    low: u64,
    up: u32,
    down: u32,
    high: u64,
    /// Then moved to the top bytes, alone: `<< shift`, `& mask`.
    shift: u32,
    mask: u64,
}

impl Layout {
    /// The layout of `cell`, a plain decimal as [`plain_cell`] accepted it, or
    /// the empty layout when it does not fit in a word.
    fn of(cell: &[u8]) -> Self {
        let len = cell.len();
        if len == 0 || len > 8 {
            return Self::default();
        }
        let signed = matches!(cell[0], b'-' | b'+');
        let point = cell.iter().position(|&b| b == b'.');
        let int_end = point.unwrap_or(len);
        let first = usize::from(signed);
        let (n_int, n_fraction) = (int_end - first, point.map_or(0, |p| len - p - 1));
        let byte = |i: usize| 0xFFu64 << (8 * i);
        let (mut digit_bits, mut fixed_mask, mut fixed) = (0, 0, 0);
        for (i, &b) in cell.iter().enumerate() {
            if b.is_ascii_digit() {
                digit_bits |= 0x80 << (8 * i);
            } else {
                fixed_mask |= byte(i);
                fixed |= u64::from(b) << (8 * i);
            }
        }
        // With digits after the point, those move down one byte, over it.
        let (low, up, down, high) = match point {
            Some(p) if n_fraction > 0 => (
                !(u64::MAX << (8 * p)),
                8 * (p as u32 + 1),
                8 * p as u32,
                u64::MAX,
            ),
            _ => (u64::MAX, 0, 0, 0),
        };
        // The n digits, now bytes [first, first + n), moved to the top n bytes.
        let n = n_int + n_fraction;
        Self {
            len,
            negative: cell[0] == b'-',
            n_fraction,
            digit_bits,
            fixed_mask,
            fixed,
            low,
            up,
            down,
            high,
            shift: (8 * (8 - first - n)) as u32,
            mask: u64::MAX << (8 * (8 - n)),
        }
    }

    /// The cell at `pos` if it has this layout: its value and the index after it.
    #[inline]
    fn read(&self, buf: &[u8], pos: usize) -> Option<(f64, usize)> {
        let word: [u8; 8] = buf.get(pos..pos + 8)?.try_into().ok()?;
        let w = u64::from_le_bytes(word);
        // Byte values 0..=9 for digits, anything else above 9. The high bit of
        // `x + 0x76 | x` is set for the bytes that are not digits; a carry out of
        // a byte (x >= 0x8a) only reaches bytes after one that already failed.
        let x = w ^ bytes(b'0');
        let not_digit = x.wrapping_add(bytes(0x76)) | x;
        if self.len == 0
            || (not_digit & self.digit_bits) | ((w & self.fixed_mask) ^ self.fixed) != 0
        {
            return None;
        }
        let digits = (x & self.low) | (((x >> self.up) << self.down) & self.high);
        let mantissa = eight_digits((digits << self.shift) & self.mask);
        // At most 8 digits: `mantissa < 10^8`, exact as an i64 and as a double.
        let value = mantissa as i64 as f64 / POW10[self.n_fraction];
        Some((if self.negative { -value } else { value }, pos + self.len))
    }
}

/// The value of eight digit values (0..=9), the first (most significant) in
/// the lowest byte; leading zero bytes are leading zeros.
#[inline]
fn eight_digits(x: u64) -> u64 {
    const MASK: u64 = 0x0000_00FF_0000_00FF;
    const MUL1: u64 = 0x000F_4240_0000_0064; // 100 + (1_000_000 << 32)
    const MUL2: u64 = 0x0000_2710_0000_0001; // 1 + (10_000 << 32)
    let x = x.wrapping_mul(10).wrapping_add(x >> 8);
    ((x & MASK)
        .wrapping_mul(MUL1)
        .wrapping_add(((x >> 16) & MASK).wrapping_mul(MUL2)))
        >> 32
}

/// The fast path of a whole data row at the start of `buf`: every one of the
/// `fields.len()` cells a plain decimal, separated by `delimiter`, the last one
/// followed by `\n` or `\r\n`. Returns the bytes the row takes, line end
/// included, or None for anything else (an empty or other cell, another field
/// count, a row cut by the end of `buf`), which then takes the slow path.
/// `layouts` (one per field) are the columns' last layouts, updated here.
#[inline]
pub(super) fn parse_line_fast(
    buf: &[u8],
    delimiter: u8,
    fields: &mut [f64],
    layouts: &mut [Layout],
) -> Option<usize> {
    let last = fields.len().checked_sub(1)?;
    let mut pos = 0;
    for (i, (slot, layout)) in fields.iter_mut().zip(layouts.iter_mut()).enumerate() {
        // The byte after a cell: the delimiter, or the line end after the last one.
        let ends = |end: usize| match buf.get(end) {
            Some(&b) if i < last => b == delimiter,
            Some(&b) => b == b'\n' || b == b'\r',
            None => false,
        };
        let (value, end) = match layout.read(buf, pos) {
            Some((value, end)) if ends(end) => (value, end),
            // Another layout (or a longer cell that starts like the last one).
            _ => {
                let (value, end) = plain_cell(buf, pos)?;
                *layout = Layout::of(&buf[pos..end]);
                if !ends(end) {
                    return None;
                }
                (value, end)
            }
        };
        *slot = value;
        pos = end + 1;
        if i == last {
            return match buf[end] {
                b'\n' => Some(end + 1),
                _ if buf.get(end + 1) == Some(&b'\n') => Some(end + 2),
                _ => None,
            };
        }
    }
    None
}

/// A plain decimal `[+-]digits[.digits]` (1 to 15 digits) starting at `pos`, as
/// `scan_plain` computes it (the integer of all digits over an exact power of
/// ten); returns the value and the index of the first byte after it, or None.
///
/// One byte loop per run of digits: the loops' exits are predicted when the cells
/// of a column keep their width, so the next cell's position is known ahead of
/// the digits' values.
#[inline]
pub(super) fn plain_cell(buf: &[u8], pos: usize) -> Option<(f64, usize)> {
    let mut k = pos;
    let negative = match buf.get(k) {
        Some(b'-') => {
            k += 1;
            true
        }
        Some(b'+') => {
            k += 1;
            false
        }
        _ => false,
    };
    let mut mantissa: u64 = 0;
    let first = k;
    while let Some(&b) = buf.get(k) {
        let d = b.wrapping_sub(b'0');
        if d >= 10 {
            break;
        }
        mantissa = mantissa.wrapping_mul(10).wrapping_add(u64::from(d));
        k += 1;
    }
    let mut n_digits = k - first;
    let mut fraction_digits = 0;
    if buf.get(k) == Some(&b'.') {
        k += 1;
        let after_point = k;
        while let Some(&b) = buf.get(k) {
            let d = b.wrapping_sub(b'0');
            if d >= 10 {
                break;
            }
            mantissa = mantissa.wrapping_mul(10).wrapping_add(u64::from(d));
            k += 1;
        }
        fraction_digits = k - after_point;
        n_digits += fraction_digits;
    }
    if n_digits == 0 || n_digits > 15 {
        return None;
    }
    let value = mantissa as i64 as f64 / POW10[fraction_digits];
    Some((if negative { -value } else { value }, k))
}
