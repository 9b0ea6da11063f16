//! The key menu (manual 3.6.1, Table 2, 3.8): node-ID (`ID`), baud rate (`KBAUD`) and system
//! commands (`CODE` 011100 / 011102 / 011105 factory settings, 200000 diagnosis), and the
//! Auto-ID prompt ("New ID", 4.6.2).
//!
//! The manual gives the texts and the options; the walk between them is D-AP-9 (AP10T A1, A29,
//! A43): the parameterization key shows node-ID and baud rate for the key enable time 2005h
//! sub 2, pressed again within it opens the list (if 2005h sub 1 = 1). In the list the value
//! input key steps ID -> KBAUD -> CODE, the confirm key opens the parameter, the back key (the
//! front key) leaves. A value is entered digit by digit (digit select moves left, value input
//! counts the digit up, confirm takes it), a baud rate is chosen from its list. Sixty seconds
//! without a key leave the menu unchanged.

use crate::time::Instant;

use super::keys::{Key, KEYMAP};
use super::screen::{blink_on, put_digits, Cell, Row, CELLS};

/// Without a key for this long the menu closes without a change (D-AP-9).
pub const MENU_TIMEOUT_MS: u64 = 60_000;

/// What a confirmed menu entry asks of the device. The menu changes no parameter itself.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Effect {
    /// Set points were acknowledged by key (the status word changed).
    Acknowledged,
    /// `ID` confirmed: the new node-ID for 5F0Ah sub 1, adopted at the next initialisation
    /// (manual 4.1).
    SetNodeId(u8),
    /// `KBAUD` confirmed: the value for 5F0Ah sub 3 (0 auto baud, 1..=4 125..800 kbit/s).
    SetBaud(u8),
    /// `CODE` 011100 / 011102 / 011105: restore factory settings (manual Table 3).
    FactoryReset(ResetScope),
    /// The Auto-ID key was pressed while "New ID" showed: this device takes the node-ID (the
    /// SDO answer, the store and the re-initialisation follow, manual 4.6.2).
    AutoIdAdopted(u8),
}

/// Which parameters a manual factory reset restores (manual Table 3).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum ResetScope {
    /// CODE 011100: all parameters.
    All,
    /// CODE 011102: all except the bus parameters of Table 4.
    AllExceptBus,
    /// CODE 011105: only the bus parameters of Table 4.
    BusOnly,
}

/// CODE for "load factory settings, all parameters".
pub const CODE_RESET_ALL: u32 = 11_100;
/// CODE for "all except bus parameters".
pub const CODE_RESET_ALL_EXCEPT_BUS: u32 = 11_102;
/// CODE for "only bus parameters".
pub const CODE_RESET_BUS: u32 = 11_105;
/// CODE for "start diagnosis".
pub const CODE_DIAGNOSIS: u32 = 200_000;

/// The parameters of the menu's list, in the order of Table 2.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Item {
    /// Node-ID.
    Id,
    /// Baud rate.
    Kbaud,
    /// System commands.
    Code,
}

impl Item {
    /// The label the display shows.
    pub const fn label(self) -> &'static str {
        match self {
            Item::Id => "ID",
            Item::Kbaud => "KBAUD",
            Item::Code => "CODE",
        }
    }

    const fn next(self) -> Item {
        match self {
            Item::Id => Item::Kbaud,
            Item::Kbaud => Item::Code,
            Item::Code => Item::Id,
        }
    }
}

/// The `KBAUD` list: 5F0Ah sub 3 values in the order the manual lists them (no 1000 kbit/s,
/// AP10T A30).
pub const BAUD_LIST: [u8; 5] = [0, 1, 2, 3, 4];

/// The position in [`BAUD_LIST`] of the setting `code` (the first for one not in the list):
/// the list holds each setting at its own value.
fn baud_index(code: u8) -> u8 {
    const _: () = {
        let mut i = 0;
        while i < BAUD_LIST.len() {
            assert!(BAUD_LIST[i] as usize == i);
            i += 1;
        }
    };
    if (code as usize) < BAUD_LIST.len() {
        code
    } else {
        0
    }
}

/// The setting at position `i` of [`BAUD_LIST`] (counted round).
fn baud_at(i: u8) -> u8 {
    BAUD_LIST[i as usize % BAUD_LIST.len()]
}

/// A baud-rate setting (5F0Ah sub 3) as text.
pub const fn baud_text(code: u8) -> &'static str {
    const TEXTS: [&str; 7] = ["AUTO", "125", "250", "500", "800", "1000", "---"];
    TEXTS[if code < 6 { code as usize } else { 6 }]
}

/// One line of the diagnosis list (manual 3.8.2; D-AP-9): an error and how often it occurred.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct DiagEntry {
    /// The error's EMCY code (its type, shown in hex on the lower row).
    pub code: u16,
    /// Total number of occurrences.
    pub count: u16,
}

/// A number being entered digit by digit.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Entry {
    /// The number as entered so far (under 10^`len`).
    value: u32,
    /// Number of digits (3 for the node-ID, 6 for a CODE).
    pub len: u8,
    /// The selected digit, counted from the right (0 = least significant).
    pub pos: u8,
}

/// 10^`i` for the digit positions of an [`Entry`].
const POW10: [u32; CELLS] = [1, 10, 100, 1_000, 10_000, 100_000];

impl Entry {
    fn new(value: u32, len: u8) -> Entry {
        Entry { value, len, pos: 0 }
    }

    /// The entered number.
    pub fn value(&self) -> u32 {
        self.value
    }

    fn select_left(&mut self) {
        // The leftmost digit wraps round to the rightmost (`pos` < `len` always).
        self.pos = if self.pos + 1 < self.len { self.pos + 1 } else { 0 };
    }

    fn count_up(&mut self) {
        let p = POW10[self.pos as usize % CELLS];
        // 9 counts up to 0.
        self.value = if self.value / p % 10 < 9 { self.value + p } else { self.value - 9 * p };
    }

    /// The digits right-aligned, the selected one blank in the dark half of the blink period.
    fn row(&self, now: Instant) -> Row {
        let mut row = Row::BLANK;
        put_digits(&mut row, self.value, 10, self.len as usize, 0);
        if !blink_on(now) {
            row.0[CELLS - 1 - self.pos as usize % CELLS] = Cell::BLANK;
        }
        row
    }
}

/// Where the panel is.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Mode {
    /// The set points (the menu's top level).
    Normal,
    /// Power-up display test since the instant given (manual 2.1).
    PowerUp(Instant),
    /// Node-ID and baud rate shown until the instant given (the key enable time).
    Info(Instant),
    /// The list of parameters.
    List(Item),
    /// Entering the node-ID.
    EditId(Entry),
    /// Choosing the baud rate: index into [`BAUD_LIST`].
    Baud(u8),
    /// Entering a CODE.
    EditCode(Entry),
    /// The diagnosis list, showing entry `n` (0 = error number 1, the latest).
    Diagnosis(u8),
    /// Auto-ID waits for the key: the node-ID offered.
    AutoId(u8),
}

/// How long the power-up display test lasts, in milliseconds (the LEDs light one after the
/// other, a quarter each).
pub const POWER_UP_MS: u64 = 1000;

/// What the menu needs to know of the device.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct MenuContext {
    /// 5F0Ah sub 1.
    pub node_id: u8,
    /// 5F0Ah sub 3.
    pub baud: u8,
    /// 2005h sub 1: configuration by keyboard enabled.
    pub config_enable: bool,
}

/// Label on the left, value on the right (the value wins where they overlap).
pub fn label_value(label: &str, value: &str) -> Row {
    overlay(Row::left(label), Row::right(value))
}

/// `value` over `row`: its lit cells replace the row's.
fn overlay(mut row: Row, value: Row) -> Row {
    for (c, vc) in row.0.iter_mut().zip(value.0) {
        if vc.ch != b' ' || vc.dp {
            *c = vc;
        }
    }
    row
}

/// `n` in decimal as text.
pub fn decimal(n: u32) -> heapless::String<10> {
    let mut s = heapless::String::new();
    let mut buf = [0u8; 10];
    let mut i = buf.len();
    let mut v = n;
    loop {
        i -= 1;
        buf[i] = b'0' + (v % 10) as u8;
        v /= 10;
        if v == 0 {
            break;
        }
    }
    for &b in &buf[i..] {
        let _ = s.push(b as char);
    }
    s
}

/// The hex digit `d` (0..=15) as ASCII.
const fn hex_digit(d: u8) -> u8 {
    if d < 10 {
        b'0' + d
    } else {
        b'A' + d - 10
    }
}

/// `n` as four hex digits.
pub fn hex4(n: u16) -> heapless::String<4> {
    let mut s = heapless::String::new();
    for shift in [12, 8, 4, 0] {
        let _ = s.push(hex_digit((n >> shift) as u8 & 0xF) as char);
    }
    s
}

impl Mode {
    /// The mode in effect at `now`: an expired display test, info display or idle menu is back
    /// at the top level. `last_key`: the last key press.
    pub fn at(self, now: Instant, last_key: Instant) -> Mode {
        match self.deadline(last_key) {
            Some(end) if now >= end => Mode::Normal,
            _ => self,
        }
    }

    /// When [`Mode::at`] next changes by itself.
    pub fn deadline(self, last_key: Instant) -> Option<Instant> {
        match self {
            Mode::Normal | Mode::AutoId(_) => None,
            Mode::PowerUp(since) => Some(since.add_millis(POWER_UP_MS)),
            Mode::Info(until) => Some(until),
            _ => Some(last_key.add_millis(MENU_TIMEOUT_MS)),
        }
    }

    /// A key pressed in a menu mode (not [`Mode::Normal`], whose keys the panel handles):
    /// the next mode and what the device must do.
    pub fn press(mut self, key: Key, ctx: &MenuContext) -> (Mode, Option<Effect>) {
        let effect = self.step(key, ctx);
        (self, effect)
    }

    /// [`Mode::press`] in place: the mode becomes the next one; returns what the device must do.
    /// Each mode's keys; a key a mode does not use changes nothing. The mode is changed where
    /// it is (a step is mostly one field).
    pub(crate) fn step(&mut self, key: Key, ctx: &MenuContext) -> Option<Effect> {
        let m = KEYMAP;
        match self {
            Mode::Normal | Mode::PowerUp(_) => {}
            Mode::Info(_) => {
                if key == m.parameterize && ctx.config_enable {
                    *self = Mode::List(Item::Id);
                }
            }
            Mode::AutoId(id) => {
                if key == m.auto_id {
                    let id = *id;
                    *self = Mode::Normal;
                    return Some(Effect::AutoIdAdopted(id));
                }
            }
            // One level back: the list to the set points, a parameter to the list.
            _ if key == m.back => {
                *self = match self {
                    Mode::EditId(_) => Mode::List(Item::Id),
                    Mode::Baud(_) => Mode::List(Item::Kbaud),
                    Mode::EditCode(_) | Mode::Diagnosis(_) => Mode::List(Item::Code),
                    _ => Mode::Normal,
                };
            }
            Mode::List(item) => {
                let item = *item;
                if key == m.value_input {
                    *self = Mode::List(item.next());
                } else if key == m.confirm {
                    *self = match item {
                        Item::Id => Mode::EditId(Entry::new(ctx.node_id as u32, 3)),
                        Item::Kbaud => Mode::Baud(baud_index(ctx.baud)),
                        Item::Code => Mode::EditCode(Entry::new(0, 6)),
                    };
                }
            }
            Mode::Baud(i) => {
                if key == m.value_input {
                    *i = baud_index(i.wrapping_add(1));
                } else if key == m.confirm {
                    let code = baud_at(*i);
                    *self = Mode::List(Item::Kbaud);
                    return Some(Effect::SetBaud(code));
                }
            }
            Mode::Diagnosis(n) => {
                if key == m.value_input {
                    *n = n.wrapping_add(1);
                }
            }
            Mode::EditId(e) | Mode::EditCode(e) => {
                if key == m.digit_select {
                    e.select_left();
                } else if key == m.value_input {
                    e.count_up();
                } else if key == m.confirm {
                    return self.confirm_entry();
                }
            }
        }
        None
    }

    /// The confirm key on an entered node-ID or CODE.
    fn confirm_entry(&mut self) -> Option<Effect> {
        let (Mode::EditId(e) | Mode::EditCode(e)) = *self else { return None };
        let v = e.value();
        let (next, effect) = if let Mode::EditId(_) = self {
            // Out of 1..=127: not taken, the entry stays for a correction.
            if !(1..=127).contains(&v) {
                return None;
            }
            (Mode::List(Item::Id), Effect::SetNodeId(v as u8))
        } else {
            let scope = match v {
                CODE_RESET_ALL => ResetScope::All,
                CODE_RESET_ALL_EXCEPT_BUS => ResetScope::AllExceptBus,
                CODE_RESET_BUS => ResetScope::BusOnly,
                CODE_DIAGNOSIS => {
                    *self = Mode::Diagnosis(0);
                    return None;
                }
                _ => {
                    *self = Mode::List(Item::Code);
                    return None;
                }
            };
            (Mode::Normal, Effect::FactoryReset(scope))
        };
        *self = next;
        Some(effect)
    }

    /// The two rows of a menu mode at `now` (for [`Mode::Normal`] the panel renders the set
    /// points; here it is blank). The diagnosis shows the first eight entries of `diag` at
    /// most, as many as the panel keeps.
    #[inline(never)]
    pub fn screen(self, now: Instant, ctx: &MenuContext, diag: &[DiagEntry]) -> [Row; 2] {
        const ALL_SEGMENTS: &str = "8.8.8.8.8.8.";
        // One shape for every mode: a text from the left on the upper row with a decimal
        // `value` right-aligned over it, and the lower row: a baud rate setting's text, a
        // number, an entry.
        let mut value = None;
        // The diagnosis's error number, the upper row's first cell.
        let mut number = None;
        let mut baud = None;
        let mut lower = Row::BLANK;
        let text = match self {
            Mode::Normal => "",
            Mode::PowerUp(_) => ALL_SEGMENTS,
            Mode::Info(_) => {
                value = Some(ctx.node_id as u32);
                baud = Some(ctx.baud);
                Item::Id.label()
            }
            Mode::List(item) => {
                match item {
                    Item::Id => {
                        put_digits(&mut lower, ctx.node_id as u32, 10, 1, 0);
                    }
                    Item::Kbaud => baud = Some(ctx.baud),
                    Item::Code => {}
                }
                item.label()
            }
            Mode::EditId(e) | Mode::EditCode(e) => {
                lower = e.row(now);
                if let Mode::EditId(_) = self {
                    Item::Id.label()
                } else {
                    Item::Code.label()
                }
            }
            Mode::Baud(i) => {
                baud = Some(baud_at(i));
                Item::Kbaud.label()
            }
            Mode::Diagnosis(n) => {
                // The panel keeps eight entries: the error number is one digit.
                let diag = &diag[..diag.len().min(8)];
                if diag.is_empty() {
                    "no Err"
                } else {
                    let i = n as usize % diag.len();
                    let e = diag[i];
                    value = Some(e.count as u32);
                    put_digits(&mut lower, e.code as u32, 16, 4, 0);
                    number = Some(b'1' + i as u8);
                    ""
                }
            }
            Mode::AutoId(_) => "New ID",
        };
        let mut upper = Row::left(text);
        if let Mode::PowerUp(_) = self {
            lower = upper;
        }
        if let Some(code) = baud {
            // Right-aligned; the texts have no points.
            for (cell, &c) in lower.0.iter_mut().rev().zip(baud_text(code).as_bytes().iter().rev()) {
                cell.ch = c;
            }
        }
        if let Some(ch) = number {
            upper.0[0].ch = ch;
        }
        if let Some(v) = value {
            // The digits replace the cells they take (the value wins where they overlap).
            put_digits(&mut upper, v, 10, 1, 0);
        }
        [upper, lower]
    }

    /// Whether the mode's rows change with the blink clock.
    pub fn blinks(self) -> bool {
        matches!(self, Mode::EditId(_) | Mode::EditCode(_))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const CTX: MenuContext = MenuContext { node_id: 0x7D, baud: 0, config_enable: true };
    const T: Instant = Instant::from_millis(100);

    fn texts(m: Mode, now: Instant) -> [heapless::String<12>; 2] {
        m.screen(now, &CTX, &[]).map(|r| r.text())
    }

    #[test]
    fn entry_digits() {
        let mut e = Entry::new(125, 3);
        assert_eq!(e.value(), 125);
        e.count_up();
        assert_eq!(e.value(), 126);
        e.select_left();
        e.count_up();
        assert_eq!(e.value(), 136);
        e.select_left();
        e.select_left();
        assert_eq!(e.pos, 0, "wraps round to the rightmost digit");
        for _ in 0..4 {
            e.count_up();
        }
        assert_eq!(e.value(), 130, "9 counts up to 0");
        assert_eq!(e.row(T).cells_text(), "   130");
        assert_eq!(e.row(Instant::from_millis(700)).cells_text(), "   13 ");
    }

    #[test]
    fn labels_and_values() {
        assert_eq!(label_value("ID", "125").cells_text(), "ID 125");
        assert_eq!(label_value("ID", "1").cells_text(), "ID   1");
        assert_eq!(label_value("1", "3").cells_text(), "1    3");
        assert_eq!(texts(Mode::Info(T), T), ["ID 125", "AUTO"]);
        assert_eq!(texts(Mode::AutoId(5), T), ["New ID", ""]);
        assert_eq!(texts(Mode::List(Item::Kbaud), T), ["KBAUD", "AUTO"]);
        assert_eq!(texts(Mode::List(Item::Code), T), ["CODE", ""]);
        assert_eq!(texts(Mode::PowerUp(T), T), ["8.8.8.8.8.8.", "8.8.8.8.8.8."]);
        assert_eq!(baud_text(5), "1000");
        assert_eq!(hex4(0x8120), "8120");
        assert_eq!(hex4(0xFF0A), "FF0A");
        assert_eq!(decimal(0), "0");
        assert_eq!(decimal(u32::MAX), "4294967295");
    }

    #[test]
    fn diagnosis_rows() {
        let diag = [DiagEntry { code: 0x8120, count: 3 }, DiagEntry { code: 0x8140, count: 12 }];
        let rows = |n| Mode::Diagnosis(n).screen(T, &CTX, &diag).map(|r| r.cells_text());
        assert_eq!(rows(0), ["1    3", "  8120"]);
        assert_eq!(rows(1), ["2   12", "  8140"]);
        assert_eq!(rows(2), rows(0), "wraps round");
        assert_eq!(Mode::Diagnosis(0).screen(T, &CTX, &[]).map(|r| r.text()), ["no Err", ""]);
    }

    #[test]
    fn timeouts() {
        let info = Mode::Info(Instant::from_millis(5000));
        assert_eq!(info.at(Instant::from_millis(4999), Instant::ZERO), info);
        assert_eq!(info.at(Instant::from_millis(5000), Instant::ZERO), Mode::Normal);
        let list = Mode::List(Item::Id);
        let last = Instant::from_millis(10);
        assert_eq!(list.at(last.add_millis(MENU_TIMEOUT_MS - 1), last), list);
        assert_eq!(list.at(last.add_millis(MENU_TIMEOUT_MS), last), Mode::Normal);
        assert_eq!(list.deadline(last), Some(last.add_millis(MENU_TIMEOUT_MS)));
        assert_eq!(Mode::AutoId(3).at(Instant::from_millis(1_000_000), Instant::ZERO), Mode::AutoId(3));
        let p = Mode::PowerUp(Instant::ZERO);
        assert_eq!(p.at(Instant::from_millis(999), Instant::ZERO), p);
        assert_eq!(p.at(Instant::from_millis(1000), Instant::ZERO), Mode::Normal);
    }
}
