//! The AP10T's display: two rows of six 7-segment digits with decimal points, driven by a Holtek
//! HT1621 (32 segment × 4 common RAM-mapped LCD driver) over its three-wire serial interface,
//! which the board clocks from SPI2 (MOSI = DATA, SCK = WR, NSS = CS; RD not connected).
//!
//! # The HT1621's serial protocol
//!
//! Every transfer starts with CS low and a 3-bit mode: `100` for commands, `101` for a write.
//! A command is the 8-bit code and one don't-care bit; several may follow one `100`. A write
//! gives a 6-bit start address (most significant bit first) and then four data bits per
//! address, D0 (COM0) first, the address counting up after each nibble and wrapping from 31 to
//! 0. Bits are latched on the rising edge of WR (SPI mode 0, most significant bit of each byte
//! first). A transfer whose bit count is not a multiple of eight is padded so that the extra bits
//! change nothing: [`frame`] repeats the first nibbles after the wrap, and the one bit after the
//! four [`INIT`] commands is an unfinished command, which CS going high discards.
//!
//! # The board's wiring (segment to RAM)
//!
//! Digit `k` (0..=5 the upper row, 6..=11 the lower row, left to right) uses driver segments
//! `2k` and `2k + 1`; RAM address = segment number, data bit = common:
//!
//! | RAM address | COM0 (D0) | COM1 (D1) | COM2 (D2) | COM3 (D3) |
//! |---|---|---|---|---|
//! | 2k | a | b | c | dp |
//! | 2k + 1 | f | g | e | d |
//!
//! Segments 24..=31 are not connected (their RAM is written 0). Segment letters are the usual
//! ones: a top, b upper right, c lower right, d bottom, e lower left, f upper left, g middle,
//! dp the decimal point after the digit.
//!
//! # What the display can show
//!
//! [`glyph`] is the 7-segment font: digits, the letters a 7-segment display can show (upper or
//! lower case as the shape allows, so 'b' and 'B' look alike), '-', '_' and blank. Texts like the
//! manual's "FULLL" and "---" fit; the menu texts ("ID", "KBAUD", "New ID") are the device's to
//! spell with these glyphs.

/// Digits per row.
pub const DIGITS: usize = 6;
/// Rows.
pub const ROWS: usize = 2;

/// Segment a (top).
pub const A: u8 = 1 << 0;
/// Segment b (upper right).
pub const B: u8 = 1 << 1;
/// Segment c (lower right).
pub const C: u8 = 1 << 2;
/// Segment d (bottom).
pub const D: u8 = 1 << 3;
/// Segment e (lower left).
pub const E: u8 = 1 << 4;
/// Segment f (upper left).
pub const F: u8 = 1 << 5;
/// Segment g (middle).
pub const G: u8 = 1 << 6;
/// The decimal point after the digit.
pub const DP: u8 = 1 << 7;

/// The 7-segment shape of an ASCII character, `None` if a 7-segment digit cannot show it.
pub const fn glyph(c: u8) -> Option<u8> {
    // One table lookup (the font as a `match` compiles to a few hundred bytes of branches).
    if c < FONT_FIRST || c >= FONT_FIRST + FONT.len() as u8 {
        return None;
    }
    match FONT[(c - FONT_FIRST) as usize] {
        NO_GLYPH => None,
        g => Some(g),
    }
}

/// The first character [`FONT`] has a row for (blank).
const FONT_FIRST: u8 = b' ';
/// A [`FONT`] row for a character with no shape (no glyph lights the point).
const NO_GLYPH: u8 = DP;
/// [`shape`] of every character from blank to 'z'.
const FONT: [u8; (b'z' - b' ' + 1) as usize] = {
    let mut t = [NO_GLYPH; (b'z' - b' ' + 1) as usize];
    let mut i = 0;
    while i < t.len() {
        if let Some(g) = shape(FONT_FIRST + i as u8) {
            t[i] = g;
        }
        i += 1;
    }
    t
};

/// The font as the shapes are drawn; [`glyph`] reads it from [`FONT`].
const fn shape(c: u8) -> Option<u8> {
    Some(match c {
        b'0' | b'O' => A | B | C | D | E | F,
        b'1' | b'I' => B | C,
        b'2' | b'Z' | b'z' => A | B | D | E | G,
        b'3' => A | B | C | D | G,
        b'4' => B | C | F | G,
        b'5' | b'S' | b's' => A | C | D | F | G,
        b'6' => A | C | D | E | F | G,
        b'7' => A | B | C,
        b'8' => A | B | C | D | E | F | G,
        b'9' => A | B | C | D | F | G,
        b'A' | b'a' => A | B | C | E | F | G,
        b'B' | b'b' => C | D | E | F | G,
        b'C' => A | D | E | F,
        b'c' => D | E | G,
        b'D' | b'd' => B | C | D | E | G,
        b'E' | b'e' => A | D | E | F | G,
        b'F' | b'f' => A | E | F | G,
        b'G' | b'g' => A | C | D | E | F,
        b'H' => B | C | E | F | G,
        b'h' => C | E | F | G,
        b'i' => C,
        b'J' | b'j' => B | C | D | E,
        b'L' | b'l' => D | E | F,
        b'N' | b'n' => C | E | G,
        b'o' => C | D | E | G,
        b'P' | b'p' => A | B | E | F | G,
        b'Q' | b'q' => A | B | C | F | G,
        b'R' | b'r' => E | G,
        b'T' | b't' => D | E | F | G,
        b'U' => B | C | D | E | F,
        b'u' | b'V' | b'v' => C | D | E,
        b'Y' | b'y' => B | C | D | F | G,
        b'-' => G,
        b'_' => D,
        b' ' => 0,
        _ => return None,
    })
}

/// Why a text does not fit a row.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum RenderError {
    /// More than [`DIGITS`] characters (decimal points do not count).
    TooLong,
    /// A character a 7-segment digit cannot show.
    Unsupported(u8),
}

/// One row as segment bits, left to right.
pub type Row = [u8; DIGITS];

/// Renders `text` right-aligned into a row. A '.' lights the decimal point of the character
/// before it (a leading '.' or a second one in a row stands on a blank digit of its own).
pub fn render(text: &str) -> Result<Row, RenderError> {
    let mut cells = [0u8; DIGITS];
    let mut n = 0;
    let mut dot_allowed = false;
    for &c in text.as_bytes() {
        if c == b'.' && dot_allowed {
            cells[n - 1] |= DP;
            dot_allowed = false;
            continue;
        }
        if n == DIGITS {
            return Err(RenderError::TooLong);
        }
        cells[n] = if c == b'.' { DP } else { glyph(c).ok_or(RenderError::Unsupported(c))? };
        dot_allowed = c != b'.';
        n += 1;
    }
    let mut row = [0u8; DIGITS];
    row[DIGITS - n..].copy_from_slice(&cells[..n]);
    Ok(row)
}

/// What the whole display shows.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct Screen {
    /// The upper and the lower row.
    pub rows: [Row; ROWS],
}

/// A character turned by 180°: the segments swap top and bottom, left and right (a<->d,
/// b<->e, c<->f; g stays).
pub const fn upside_down(seg: u8) -> u8 {
    // a, b, c are bits 0-2 and d, e, f bits 3-5: the turn swaps the two groups of three.
    (seg & (A | B | C)) << 3 | (seg >> 3) & (A | B | C) | seg & (G | DP)
}

/// What the board's LCD shows of the AP10T's screen (`od_core::devices::ap10t::Screen`, the
/// rows as the reader reads them): each cell as its glyph, upside down on a display mounted
/// turned by 180° (as `Screen::physical` lays it out: the rows swapped, each read right to
/// left, a point on the digit of the character after it), its decimal point lit. A character
/// the 7-segment digits cannot draw (K, M, W, X ...; the screen model keeps them, D-AP-5) is
/// shown as segment d alone, a low bar that says "something is here".
pub fn from_screen(screen: &od_core::devices::ap10t::Screen) -> Screen {
    let mut out = Screen::default();
    for p in 0..ROWS {
        for k in 0..DIGITS {
            out.rows[p][k] = segments(screen, p, k);
        }
    }
    out
}

/// The segments of physical digit `k` of row `p` for `screen` (see [`from_screen`]).
fn segments(screen: &od_core::devices::ap10t::Screen, p: usize, k: usize) -> u8 {
    let turned = screen.rotated;
    // The cell shown on physical digit k of row p, and the one after it as read.
    let (cells, i) = if turned { (&screen.rows[1 - p].0, DIGITS - 1 - k) } else { (&screen.rows[p].0, k) };
    let g = glyph(cells[i].ch).unwrap_or(D);
    let (g, dp) = if turned { (upside_down(g), i > 0 && cells[i - 1].dp) } else { (g, cells[i].dp) };
    g | if dp { DP } else { 0 }
}

/// `frame(&from_screen(screen))` in one pass, without the segment screen in between (the
/// board's path from the device's screen to the driver).
pub fn screen_frame(screen: &od_core::devices::ap10t::Screen) -> [u8; FRAME_LEN] {
    let mut bytes = FRAME_HEAD;
    for p in 0..ROWS {
        for k in 0..DIGITS {
            put_digit(&mut bytes, p * DIGITS + k, segments(screen, p, k));
        }
    }
    bytes[FRAME_LEN - 1] = bytes[1];
    bytes
}

/// RAM addresses of the HT1621.
pub const RAM_NIBBLES: usize = 32;

/// The HT1621's display RAM for `screen`: one nibble per address, bit `n` = COM`n`.
pub fn ram(screen: &Screen) -> [u8; RAM_NIBBLES] {
    let mut ram = [0u8; RAM_NIBBLES];
    for (k, &s) in screen.rows.iter().flatten().enumerate() {
        let bit = |mask: u8, to: u8| if s & mask != 0 { 1 << to } else { 0 };
        ram[2 * k] = bit(A, 0) | bit(B, 1) | bit(C, 2) | bit(DP, 3);
        ram[2 * k + 1] = bit(F, 0) | bit(G, 1) | bit(E, 2) | bit(D, 3);
    }
    ram
}

/// Packs a bit stream into bytes, most significant bit first.
struct Bits<const N: usize> {
    bytes: [u8; N],
    len: usize,
}

impl<const N: usize> Bits<N> {
    const fn new() -> Self {
        Bits { bytes: [0; N], len: 0 }
    }

    /// Appends the `count` low bits of `value`, most significant first.
    const fn msb_first(mut self, value: u32, count: u32) -> Self {
        let mut i = count;
        while i > 0 {
            i -= 1;
            if value >> i & 1 != 0 {
                self.bytes[self.len / 8] |= 0x80 >> (self.len % 8);
            }
            self.len += 1;
        }
        self
    }
}

/// HT1621 command codes.
pub mod command {
    /// Turn on the system oscillator.
    pub const SYS_EN: u8 = 0x01;
    /// Turn on the LCD bias generator.
    pub const LCD_ON: u8 = 0x03;
    /// System clock from the on-chip 256 kHz RC oscillator.
    pub const RC_256K: u8 = 0x18;
    /// 1/3 bias, four commons.
    pub const BIAS_THIRD_4COM: u8 = 0x29;
}

/// The transfer that starts the driver: oscillator on, internal RC clock, 1/3 bias with four
/// commons, display on (39 bits and one discarded pad bit).
pub const INIT: [u8; 5] = {
    let codes = [command::SYS_EN, command::RC_256K, command::BIAS_THIRD_4COM, command::LCD_ON];
    let mut bits = Bits::<5>::new().msb_first(0b100, 3);
    let mut i = 0;
    while i < codes.len() {
        bits = bits.msb_first(codes[i] as u32, 8).msb_first(0, 1);
        i += 1;
    }
    bits.bytes
};

/// Bytes of the transfer that writes the whole display RAM.
pub const FRAME_LEN: usize = 18;

/// A digit's segments in the order the driver takes them: its two RAM nibbles, D0 first,
/// address `2k` (a, b, c, dp) then `2k + 1` (f, g, e, d).
const STREAM_ORDER: [u8; 8] = [A, B, C, DP, F, G, E, D];

/// The transfer that writes `screen`: mode `101`, address 0, the 32 nibbles (137 bits), then 7
/// pad bits that repeat the nibbles of addresses 0 and 1 where the address wrapped to.
///
/// Each digit's two nibbles are eight consecutive bits (a, b, c, dp, f, g, e, d) that start one bit
/// into a byte (the header is nine bits long); addresses 24..=31 are zero; the pad bits are
/// digit 0's first seven again.
pub fn frame(screen: &Screen) -> [u8; FRAME_LEN] {
    let mut bytes = FRAME_HEAD;
    for (k, &s) in screen.rows.iter().flatten().enumerate() {
        put_digit(&mut bytes, k, s);
    }
    bytes[FRAME_LEN - 1] = bytes[1];
    bytes
}

/// A frame's first byte (mode `101`, the address's first five bits), the rest still 0.
const FRAME_HEAD: [u8; FRAME_LEN] = {
    let mut bytes = [0u8; FRAME_LEN];
    bytes[0] = 0b1010_0000;
    bytes
};

/// Digit `k`'s segments `s` into a frame: eight bits from bit 1 of byte `k + 1`.
fn put_digit(bytes: &mut [u8; FRAME_LEN], k: usize, s: u8) {
    let b = STREAM_ORDER.iter().fold(0u8, |b, &m| b << 1 | (s & m != 0) as u8);
    bytes[k + 1] |= b >> 1;
    bytes[k + 2] = b << 7;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reads a frame back as the HT1621 does: the mode, the address, then nibbles D0 first into
    /// successive addresses (wrapping), as many as the bits give (a last partial nibble writes
    /// its bits).
    fn clock_in(frame: &[u8]) -> (u8, u8, [u8; RAM_NIBBLES], usize) {
        let bit = |i: usize| frame[i / 8] >> (7 - i % 8) & 1;
        let mode = (bit(0) << 2) | (bit(1) << 1) | bit(2);
        let mut addr = 0u8;
        for i in 3..9 {
            addr = (addr << 1) | bit(i);
        }
        let mut ram = [0xFFu8; RAM_NIBBLES];
        let mut a = addr as usize;
        let mut i = 9;
        let mut written = 0;
        while i < frame.len() * 8 {
            let mut nib = ram[a] & 0x0F;
            for b in 0..4 {
                if i < frame.len() * 8 {
                    nib = (nib & !(1 << b)) | (bit(i) << b);
                    i += 1;
                }
            }
            ram[a] = nib;
            a = (a + 1) % RAM_NIBBLES;
            written += 1;
        }
        (mode, addr, ram, written)
    }

    #[test]
    fn the_font_table_is_the_font() {
        for c in 0..=u8::MAX {
            assert_eq!(glyph(c), shape(c), "{c:#04x}");
        }
    }

    #[test]
    fn font() {
        assert_eq!(glyph(b'8'), Some(0x7F));
        assert_eq!(glyph(b'0'), Some(A | B | C | D | E | F));
        assert_eq!(glyph(b'1'), Some(B | C));
        assert_eq!(glyph(b'F'), Some(A | E | F | G));
        assert_eq!(glyph(b'U'), Some(B | C | D | E | F));
        assert_eq!(glyph(b'L'), Some(D | E | F));
        assert_eq!(glyph(b'-'), Some(G));
        assert_eq!(glyph(b' '), Some(0));
        for c in [b'K', b'M', b'W', b'X', b'.', b'!'] {
            assert_eq!(glyph(c), None, "{}", c as char);
        }
        // Every digit is distinct, and none lights the decimal point.
        let digits: Vec<u8> = (b'0'..=b'9').map(|c| glyph(c).unwrap()).collect();
        for (i, a) in digits.iter().enumerate() {
            assert_eq!(a & DP, 0);
            assert!(digits[i + 1..].iter().all(|b| b != a));
        }
    }

    #[test]
    fn rows_are_right_aligned_with_decimal_points() {
        let g = |c| glyph(c).unwrap();
        assert_eq!(render("FULLL"), Ok([0, g(b'F'), g(b'U'), g(b'L'), g(b'L'), g(b'L')]));
        assert_eq!(render("---"), Ok([0, 0, 0, G, G, G]));
        assert_eq!(render("-123.45"), Ok([G, g(b'1'), g(b'2'), g(b'3') | DP, g(b'4'), g(b'5')]));
        assert_eq!(render("0.05"), Ok([0, 0, 0, g(b'0') | DP, g(b'0'), g(b'5')]));
        assert_eq!(render("999999"), Ok([g(b'9'); 6]));
        assert_eq!(render(".5"), Ok([0, 0, 0, 0, DP, g(b'5')]));
        assert_eq!(render("1..2"), Ok([0, 0, 0, g(b'1') | DP, DP, g(b'2')]));
        assert_eq!(render(""), Ok([0; 6]));
        assert_eq!(render("1234567"), Err(RenderError::TooLong));
        assert_eq!(render("KBAUD"), Err(RenderError::Unsupported(b'K')));
    }

    #[test]
    fn ram_follows_the_wiring_table() {
        let mut screen = Screen::default();
        screen.rows[0][0] = A | DP; // digit 0: address 0 COM0 and COM3
        screen.rows[0][5] = G | D; // digit 5: address 11 COM1 and COM3
        screen.rows[1][0] = C | E; // digit 6: address 12 COM2, address 13 COM2
        screen.rows[1][5] = B | F; // digit 11: address 22 COM1, address 23 COM0
        let ram = ram(&screen);
        let mut want = [0u8; RAM_NIBBLES];
        want[0] = 0b1001;
        want[11] = 0b1010;
        want[12] = 0b0100;
        want[13] = 0b0100;
        want[22] = 0b0010;
        want[23] = 0b0001;
        assert_eq!(ram, want);
        // All segments on: every used nibble full, the unconnected ones empty.
        let full = Screen { rows: [[0xFF; DIGITS]; ROWS] };
        let ram = super::ram(&full);
        assert!(ram[..24].iter().all(|&n| n == 0x0F) && ram[24..].iter().all(|&n| n == 0));
    }

    #[test]
    fn every_segment_of_every_digit_reaches_its_ram_bit() {
        for k in 0..ROWS * DIGITS {
            for bit in 0..8 {
                let mut screen = Screen::default();
                screen.rows[k / DIGITS][k % DIGITS] = 1 << bit;
                let (mode, addr, ram_seen, written) = clock_in(&frame(&screen));
                assert_eq!((mode, addr, written), (0b101, 0, 34));
                assert_eq!(ram_seen, ram(&screen), "digit {k} segment bit {bit}");
            }
        }
        let full = Screen { rows: [[0xFF; DIGITS]; ROWS] };
        assert_eq!(clock_in(&frame(&full)).2, ram(&full));
    }

    #[test]
    fn init_is_four_commands() {
        // 100 00000001 0 00011000 0 00101001 0 00000011 0 | pad 0
        assert_eq!(INIT, [0b1000_0000, 0b0010_0001, 0b1000_0001, 0b0100_1000, 0b0000_1100]);
    }

    #[test]
    fn frame_writes_the_whole_ram_and_the_padding_changes_nothing() {
        let screen = Screen { rows: [render("-123.45").unwrap(), render("FULLL").unwrap()] };
        let f = frame(&screen);
        assert_eq!(f.len() * 8, 3 + 6 + 32 * 4 + 7);
        let (mode, addr, ram_seen, written) = clock_in(&f);
        assert_eq!((mode, addr), (0b101, 0));
        assert_eq!(written, 34, "32 nibbles, then address 0 again and three bits of address 1");
        assert_eq!(ram_seen, ram(&screen));
        // Byte by byte for a known screen: digit 0 shows 'a' and the decimal point only.
        let mut one = Screen::default();
        one.rows[0][0] = A | DP;
        let f = frame(&one);
        // 101 000000 | address 0 = 1001 (D0 first: 1,0,0,1) | 0000 ...
        assert_eq!(f[0], 0b1010_0000);
        assert_eq!(f[1], 0b0100_1000);
        assert!(f[2..17].iter().all(|&b| b == 0));
        // Bit 136 is address 31's D3, then the pad: address 0 again (1,0,0,1) and three bits of
        // address 1 (0,0,0).
        assert_eq!(f[17], 0b0100_1000);
    }

    #[test]
    fn from_screen_lays_cells_out_as_screen_physical() {
        use od_core::devices::ap10t::screen::{Row as TextRow, Screen as TextScreen};
        let rows = [
            [TextRow::right("-123.45"), TextRow::left("AP10TX")],
            [TextRow::left("1.2.3.4.5.6."), TextRow::right("FULLL")],
            [TextRow::left(".K.W"), TextRow::right("0.05")],
        ];
        for rows in rows {
            for rotated in [false, true] {
                let screen = TextScreen { rows, rotated };
                let mut want = Screen::default();
                for (p, cells) in screen.physical().iter().enumerate() {
                    for (k, c) in cells.iter().enumerate() {
                        let g = glyph(c.ch).unwrap_or(D);
                        want.rows[p][k] = if c.upside_down { upside_down(g) } else { g } | if c.dp { DP } else { 0 };
                    }
                }
                assert_eq!(from_screen(&screen), want, "{rows:?} rotated {rotated}");
            }
        }
    }

    #[test]
    fn screen_frame_is_the_frame_of_from_screen() {
        use od_core::devices::ap10t::screen::{Row as TextRow, Screen as TextScreen};
        let rows = [
            [TextRow::right("-123.45"), TextRow::left("AP10TX")],
            [TextRow::left("1.2.3.4.5.6."), TextRow::right("FULLL")],
            [TextRow::left(".K.W"), TextRow::right("8.8.8.8.8.8.")],
        ];
        for rows in rows {
            for rotated in [false, true] {
                let screen = TextScreen { rows, rotated };
                assert_eq!(screen_frame(&screen), frame(&from_screen(&screen)), "{rows:?} rotated {rotated}");
            }
        }
    }

    #[test]
    fn the_ap10t_screen_on_the_segments() {
        use od_core::devices::ap10t::screen::{Row as TextRow, Screen as TextScreen};
        let mut screen = TextScreen { rows: [TextRow::right("123.45"), TextRow::left("AP10TX")], rotated: false };
        let lcd = from_screen(&screen);
        assert_eq!(lcd.rows[0], render("123.45").unwrap());
        // 'X' has no glyph: a low bar.
        let mut want = render("AP10T ").unwrap();
        want[5] = D;
        assert_eq!(lcd.rows[1], want);
        // Turned by 180°: the lower row upside down and reversed on top.
        screen.rows[1] = TextRow::right("7.");
        screen.rotated = true;
        let lcd = from_screen(&screen);
        assert_eq!(lcd.rows[0][0], upside_down(glyph(b'7').unwrap()));
        assert_eq!(lcd.rows[0][1..], [0; 5]);
        assert_eq!(upside_down(glyph(b'7').unwrap()), D | E | F);
        assert_eq!(upside_down(upside_down(0xFF)), 0xFF);
        assert_eq!(upside_down(glyph(b'8').unwrap()), glyph(b'8').unwrap());
    }
}
