//! What the two rows show: six character cells each, a decimal point after every cell, the
//! layout of the board's LCD (`board_plan::lcd`: two rows of six 7-segment digits, digit `k` of
//! a row left to right, its decimal point after it). A test reads a row as text
//! ([`Row::text`]); the LCD driver takes the cells ([`Screen::physical`] for the 180° mount).
//!
//! Set point rendering (manual 3.2, 3.2.1; D-AP-1, D-AP-2, D-AP-4): numbers right-aligned with 5F11h
//! decimal places (the point is a segment, not a cell; leading zeros as "0.05"), "FULLL" outside
//! -19999..=99999, in the extended range (control word bit 3, acknowledged set points only)
//! values down to -999999, the sign and the highest digit alternating where both do not fit;
//! ASCII set points as six characters, byte 0 leftmost; "---" for an invalid set point.
//!
//! Blinking runs on one clock from `Instant::ZERO` (power-on): lit in the first half of every
//! [`BLINK_PERIOD_MS`] (AP10T A5: the manual gives no timing).

use crate::time::Instant;

use super::setpoint::SetPoint;

/// Character cells per row.
pub const CELLS: usize = 6;

/// Period of every blinking thing (flashing set points, the alternating sign, a selected digit,
/// blinking LEDs and backlight), in milliseconds; lit (or: the sign shown) in its first half.
pub const BLINK_PERIOD_MS: u64 = 1000;

/// Smallest number shown in the standard range (manual 3.2 NOTICE).
pub const STANDARD_MIN: i32 = -19_999;
/// Largest number shown (in either range).
pub const MAX: i32 = 99_999;
/// Smallest number shown in the extended range (manual 3.2.1).
pub const EXTENDED_MIN: i32 = -999_999;

/// Whether blinking things are in their lit half at `now`.
pub fn blink_on(now: Instant) -> bool {
    (now.phase(BLINK_PERIOD_MS as u32 * 1000) as u64) < BLINK_PERIOD_MS * 500
}

/// The next half-period boundary after `now` (when blinking things next change).
pub fn next_blink_edge(now: Instant) -> Instant {
    let half = BLINK_PERIOD_MS * 500;
    let t = now.as_micros();
    Instant::from_micros(t - now.phase(half as u32) as u64 + half)
}

/// One character position: an ASCII character (space = blank) and the decimal point after it.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Cell {
    /// The character; what the LCD cannot show is the driver's to substitute.
    pub ch: u8,
    /// The decimal point after the character is lit.
    pub dp: bool,
}

impl Cell {
    /// A blank cell.
    pub const BLANK: Cell = Cell { ch: b' ', dp: false };
}

/// One row, cells left to right.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Row(pub [Cell; CELLS]);

/// A row as text: up to six characters and six points.
pub type RowText = heapless::String<{ 2 * CELLS }>;

impl Row {
    /// All cells blank.
    pub const BLANK: Row = Row([Cell::BLANK; CELLS]);

    /// Lays `text` into cells, a '.' after a character lighting that character's point (any
    /// other '.' takes a blank cell of its own), as many cells as fit.
    fn cells(text: &[u8]) -> ([Cell; CELLS], usize) {
        let mut cells = [Cell::BLANK; CELLS];
        let mut n = 0;
        for &c in text {
            if c == b'.' && n > 0 && cells[n - 1].ch != b' ' && !cells[n - 1].dp {
                cells[n - 1].dp = true;
                continue;
            }
            if n == CELLS {
                break;
            }
            cells[n] = if c == b'.' { Cell { ch: b' ', dp: true } } else { Cell { ch: c, dp: false } };
            n += 1;
        }
        (cells, n)
    }

    /// `text` from the left (menu labels, ASCII set points); cut after six cells.
    pub fn left(text: &str) -> Row {
        Row(Row::cells(text.as_bytes()).0)
    }

    /// `text` right-aligned (numbers, "---", "FULLL"); cut after six cells.
    pub fn right(text: &str) -> Row {
        let (cells, n) = Row::cells(text.as_bytes());
        let mut row = Row::BLANK;
        row.0[CELLS - n..].copy_from_slice(&cells[..n]);
        row
    }

    /// The row as a reader sees it: the cells' characters with a '.' after each lit point,
    /// blanks at both ends removed ("-123.45", "FULLL", "" for a dark row).
    pub fn text(&self) -> RowText {
        let mut s = RowText::new();
        for c in self.0 {
            // Capacity is two per cell: cannot fail.
            let _ = s.push(c.ch as char);
            if c.dp {
                let _ = s.push('.');
            }
        }
        let trimmed = s.trim_matches(' ');
        let mut out = RowText::new();
        let _ = out.push_str(trimmed);
        out
    }

    /// All six cells as text, blanks kept (exact positions), e.g. " FULLL".
    pub fn cells_text(&self) -> RowText {
        let mut s = RowText::new();
        for c in self.0 {
            let _ = s.push(c.ch as char);
            if c.dp {
                let _ = s.push('.');
            }
        }
        s
    }
}

/// `value` with `decimals` places, right-aligned, if it fits six cells (sign included).
pub fn number(value: i32, decimals: u8) -> Option<Row> {
    let (row, fits) = digits_row(value, decimals);
    fits.then_some(row)
}

/// `value` with `decimals` places (at most 4) right-aligned, and whether its sign fitted too;
/// when it did not, the row holds the six lowest digits without the sign.
fn digits_row(value: i32, decimals: u8) -> (Row, bool) {
    let decimals = decimals.min(4) as usize;
    let mut row = Row::BLANK;
    // Every digit, at least one before the point.
    let (rest, i) = put_digits(&mut row, value.unsigned_abs(), 10, decimals + 1, decimals);
    let fits = rest == 0 && (value >= 0 || i < CELLS);
    if value < 0 && fits {
        row.0[CELLS - 1 - i].ch = b'-';
    }
    (row, fits)
}

/// The one number formatter: the digits of `n` in `radix` (10 or 16, upper-case hex) into
/// `row` from the right, at least `min` of them (leading zeros) and as many as `n` needs or fit,
/// the point lit after the digit `point` places from the right (none for 0). Returns what is
/// left of `n` (0 if every digit fitted) and the number of cells used.
pub(crate) fn put_digits(row: &mut Row, mut n: u32, radix: u32, min: usize, point: usize) -> (u32, usize) {
    let mut i = 0;
    while i < CELLS && (n > 0 || i < min) {
        let d = (n % radix) as u8;
        let ch = if d < 10 { b'0' + d } else { b'A' + d - 10 };
        row.0[CELLS - 1 - i] = Cell { ch, dp: point > 0 && i == point };
        n /= radix;
        i += 1;
    }
    (n, i)
}

/// "FULLL" (manual 3.2).
pub fn full() -> Row {
    FULL
}

/// "---" (manual 3.2).
pub fn no_set_point() -> Row {
    DASHES
}

/// A set point as text, six ASCII characters from byte 0 (D-AP-5): a NUL or any byte outside
/// the printable range is a blank, a '.' lights the point of the character before it.
pub fn ascii(bytes: &[u8; 6]) -> Row {
    let mut clean = [b' '; 6];
    for (c, &b) in clean.iter_mut().zip(bytes) {
        if (0x20..0x7F).contains(&b) {
            *c = b;
        }
    }
    Row(Row::cells(&clean).0)
}

/// How a set point row is rendered.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct RowStyle {
    /// Decimal places 5F11h (0..=4; more is taken as 4).
    pub decimals: u8,
    /// Control word bit 3: extended display range.
    pub extended: bool,
    /// 5F1Ch sub 1 = 1: unacknowledged set points are shown steadily.
    pub steady_unacknowledged: bool,
}

/// What a set point's row shows at `now`.
pub fn set_point_row(sp: &SetPoint, style: RowStyle, now: Instant) -> Row {
    let lit = blink_on(now);
    if !sp.valid {
        return DASHES;
    }
    if !sp.acknowledged && !style.steady_unacknowledged && !lit {
        return Row::BLANK;
    }
    if sp.ascii {
        return ascii(&sp.bytes);
    }
    let v = sp.number();
    let extended = style.extended && sp.acknowledged && (EXTENDED_MIN..STANDARD_MIN).contains(&v);
    if extended || (STANDARD_MIN..=MAX).contains(&v) {
        // Every value of the standard range fits; one of the extended range that needs all
        // six cells for its digits alternates its leftmost cell between '-' (lit half of
        // the blink period) and the highest digit.
        let (mut row, fits) = digits_row(v, style.decimals);
        if !fits && lit {
            row.0[0].ch = b'-';
        }
        return row;
    }
    FULL
}

/// Six characters as a row, every point dark.
const fn text_row(text: &[u8; CELLS]) -> Row {
    let mut row = Row::BLANK;
    let mut i = 0;
    while i < CELLS {
        row.0[i].ch = text[i];
        i += 1;
    }
    row
}

/// "FULLL" right-aligned.
const FULL: Row = text_row(b" FULLL");
/// "---" right-aligned.
const DASHES: Row = text_row(b"   ---");

/// Whether a set point's row changes with time (flashing or alternating).
pub fn set_point_blinks(sp: &SetPoint, style: RowStyle) -> bool {
    if !sp.valid {
        return false;
    }
    if !sp.acknowledged {
        return !style.steady_unacknowledged;
    }
    let v = sp.number();
    !sp.ascii && style.extended && (EXTENDED_MIN..=-100_000).contains(&v)
}

/// A cell as the LCD mounted 180° rotated must light it (see [`Screen::physical`]).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct PhysicalCell {
    /// The character.
    pub ch: u8,
    /// Draw the character upside down (segments a<->d, b<->e, c<->f).
    pub upside_down: bool,
    /// Light this digit's decimal point segment.
    pub dp: bool,
}

/// The whole display: the rows as the reader sees them.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Screen {
    /// Upper and lower row as read (row 0 = set point 1 in normal operation).
    pub rows: [Row; 2],
    /// 5F12h sub 1 = 1: the display is mounted rotated by 180°.
    pub rotated: bool,
}

impl Screen {
    /// Both rows dark.
    pub const BLANK: Screen = Screen { rows: [Row::BLANK; 2], rotated: false };

    /// The LCD's digits, `[physical row][physical digit]` left to right as the driver numbers
    /// them. Unrotated, this is the rows as read. Rotated by 180° (AP10T §2.3), the reader's
    /// upper row is on the LCD's lower row, right to left, each character upside down, and a
    /// point after a character falls on the point segment of the digit that shows the next
    /// character (a point after a row's last character has no segment and is lost).
    pub fn physical(&self) -> [[PhysicalCell; CELLS]; 2] {
        let mut out = [[PhysicalCell { ch: b' ', upside_down: false, dp: false }; CELLS]; 2];
        for (p, row) in out.iter_mut().enumerate() {
            for (k, cell) in row.iter_mut().enumerate() {
                if self.rotated {
                    let logical = &self.rows[1 - p].0;
                    let c = logical[CELLS - 1 - k];
                    let dp = k + 1 < CELLS && logical[CELLS - 2 - k].dp;
                    *cell = PhysicalCell { ch: c.ch, upside_down: true, dp };
                } else {
                    let c = self.rows[p].0[k];
                    *cell = PhysicalCell { ch: c.ch, upside_down: false, dp: c.dp };
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sp(v: i32, acknowledged: bool) -> SetPoint {
        let b = v.to_le_bytes();
        SetPoint { bytes: [b[0], b[1], b[2], b[3], 0, 0], ascii: false, valid: true, acknowledged }
    }

    const LIT: Instant = Instant::from_millis(100);
    const DARK: Instant = Instant::from_millis(600);

    fn show(v: i32, decimals: u8) -> RowText {
        set_point_row(&sp(v, true), RowStyle { decimals, ..RowStyle::default() }, LIT).text()
    }

    #[test]
    fn numbers_in_the_standard_range() {
        assert_eq!(show(0, 0), "0");
        assert_eq!(show(12345, 0), "12345");
        assert_eq!(show(99999, 0), "99999");
        assert_eq!(show(100000, 0), "FULLL");
        assert_eq!(show(-19999, 0), "-19999");
        assert_eq!(show(-20000, 0), "FULLL");
        assert_eq!(show(i32::MIN, 0), "FULLL");
        assert_eq!(show(i32::MAX, 0), "FULLL");
        assert_eq!(show(-5, 0), "-5");
    }

    #[test]
    fn decimal_places_are_points_not_cells() {
        assert_eq!(show(12345, 2), "123.45");
        assert_eq!(show(-12345, 2), "-123.45");
        assert_eq!(show(5, 2), "0.05");
        assert_eq!(show(-5, 4), "-0.0005");
        assert_eq!(show(-19999, 4), "-1.9999");
        assert_eq!(show(99999, 4), "9.9999");
        assert_eq!(show(0, 3), "0.000");
        assert_eq!(show(7, 9), "0.0007", "more than 4 places is 4");
        // Right-aligned, the point on the cell before the decimals.
        let row = set_point_row(&sp(-12345, true), RowStyle { decimals: 2, ..RowStyle::default() }, LIT);
        assert_eq!(row.cells_text(), "-123.45");
        assert!(row.0[3].dp && row.0.iter().filter(|c| c.dp).count() == 1);
        assert_eq!(set_point_row(&sp(42, true), RowStyle::default(), LIT).cells_text(), "    42");
    }

    #[test]
    fn extended_range_alternates_sign_and_top_digit() {
        let ext = RowStyle { extended: true, ..RowStyle::default() };
        // D27: -345678, acknowledged.
        let v = sp(-345_678, true);
        assert_eq!(set_point_row(&v, ext, LIT).text(), "-45678");
        assert_eq!(set_point_row(&v, ext, DARK).text(), "345678");
        assert_eq!(set_point_row(&v, ext, Instant::from_millis(1500)).text(), "345678");
        assert_eq!(set_point_row(&v, ext, Instant::from_millis(1499)).text(), "-45678");
        assert_eq!(set_point_row(&v, ext, Instant::from_millis(2000)).text(), "-45678");
        assert!(set_point_blinks(&v, ext));
        // Limits: -999999 shown, -1000000 FULLL; positive limit unchanged.
        assert_eq!(set_point_row(&sp(-999_999, true), ext, DARK).text(), "999999");
        assert_eq!(set_point_row(&sp(-1_000_000, true), ext, DARK).text(), "FULLL");
        assert_eq!(set_point_row(&sp(100_000, true), ext, LIT).text(), "FULLL");
        // The gap the manual leaves (-20000..-199998): what fits is shown plainly.
        assert_eq!(set_point_row(&sp(-20_000, true), ext, DARK).text(), "-20000");
        assert_eq!(set_point_row(&sp(-99_999, true), ext, DARK).text(), "-99999");
        assert!(!set_point_blinks(&sp(-99_999, true), ext));
        assert_eq!(set_point_row(&sp(-150_000, true), ext, LIT).text(), "-50000");
        assert_eq!(set_point_row(&sp(-150_000, true), ext, DARK).text(), "150000");
        // With decimal places the point stays put while the sign alternates.
        let ext2 = RowStyle { decimals: 2, ..ext };
        assert_eq!(set_point_row(&v, ext2, LIT).text(), "-456.78");
        assert_eq!(set_point_row(&v, ext2, DARK).text(), "3456.78");
        // Standard range: FULLL.
        assert_eq!(set_point_row(&v, RowStyle::default(), LIT).text(), "FULLL");
    }

    #[test]
    fn extended_range_not_for_unacknowledged_values() {
        let ext = RowStyle { extended: true, ..RowStyle::default() };
        // D27b: unacknowledged -> FULLL, flashing.
        let v = sp(-345_678, false);
        assert_eq!(set_point_row(&v, ext, LIT).text(), "FULLL");
        assert_eq!(set_point_row(&v, ext, DARK).text(), "");
        assert_eq!(set_point_row(&sp(-20_000, false), ext, LIT).text(), "FULLL");
        // Steady when 5F1Ch sub 1 = 1.
        let steady = RowStyle { steady_unacknowledged: true, ..ext };
        assert_eq!(set_point_row(&v, steady, DARK).text(), "FULLL");
        assert!(!set_point_blinks(&v, steady));
    }

    #[test]
    fn unacknowledged_values_flash() {
        let v = sp(12345, false);
        let style = RowStyle::default();
        assert!(set_point_blinks(&v, style));
        for (t, want) in [(0, "12345"), (499, "12345"), (500, ""), (999, ""), (1000, "12345"), (61_750, "")] {
            assert_eq!(set_point_row(&v, style, Instant::from_millis(t)).text(), want, "{t} ms");
        }
        assert!(!set_point_blinks(&sp(12345, true), style));
        assert_eq!(next_blink_edge(Instant::from_millis(1)), Instant::from_millis(500));
        assert_eq!(next_blink_edge(Instant::from_millis(500)), Instant::from_millis(1000));
    }

    #[test]
    fn invalid_and_ascii() {
        let mut s = sp(1, false);
        s.valid = false;
        assert_eq!(set_point_row(&s, RowStyle::default(), DARK).text(), "---");
        assert_eq!(set_point_row(&s, RowStyle::default(), DARK).cells_text(), "   ---");
        assert!(!set_point_blinks(&s, RowStyle::default()));
        let t = SetPoint { bytes: *b"AP10T ", ascii: true, valid: true, acknowledged: true };
        let style = RowStyle { decimals: 2, extended: true, ..RowStyle::default() };
        assert_eq!(set_point_row(&t, style, DARK).cells_text(), "AP10T ");
        // Unprintable bytes are blanks; a point joins the character before it.
        assert_eq!(ascii(b"AB\0\x07CD").cells_text(), "AB  CD");
        assert_eq!(ascii(b"12.345").cells_text(), "12.345 ");
        assert_eq!(ascii(b"12.345").text(), "12.345");
        assert_eq!(ascii(b".1....").cells_text(), " .1. . . . ");
    }

    #[test]
    fn layout_helpers() {
        assert_eq!(Row::left("KBAUD").cells_text(), "KBAUD ");
        assert_eq!(Row::right("ID").cells_text(), "    ID");
        assert_eq!(Row::right("1234567").text(), "123456");
        assert_eq!(full().cells_text(), " FULLL");
        assert_eq!(number(-100_000, 0), None);
        assert_eq!(number(-99_999, 0).map(|r| r.text()), Some(RowText::try_from("-99999").unwrap()));
    }

    #[test]
    fn rotation_swaps_rows_and_reverses_digits() {
        let screen = Screen { rows: [Row::right("-123.45"), Row::left("AB")], rotated: true };
        let p = screen.physical();
        let chars = |r: usize| p[r].map(|c| c.ch);
        assert_eq!(&chars(0), b"    BA");
        assert_eq!(&chars(1), b"54321-");
        assert!(p.iter().flatten().all(|c| c.upside_down));
        // The point after logical "3" (cell 3) lies between physical digits 1 and 2: physical
        // digit 1 lights it.
        let dps: [bool; 6] = p[1].map(|c| c.dp);
        assert_eq!(dps, [false, true, false, false, false, false]);
        let normal = Screen { rotated: false, ..screen };
        let p = normal.physical();
        assert_eq!(&p[0].map(|c| c.ch), b"-12345");
        assert_eq!(p[0].map(|c| c.dp), [false, false, false, true, false, false]);
        assert!(!p[0][0].upside_down);
    }

    #[test]
    fn the_fixed_rows_are_their_texts_right_aligned() {
        assert_eq!(full(), Row::right("FULLL"));
        assert_eq!(no_set_point(), Row::right("---"));
    }
}
