//! The whole front panel as one pure state machine: set points in (RPDO data), keys in (press
//! and release at an instant), parameters in (a [`Params`] value the device builds from its
//! dictionary); screen, LEDs, backlight, status word, TPDO data and [`Effect`]s out.

use crate::time::Instant;

use super::keys::{AckKeys, Key, KeySet, KEYMAP};
use super::leds::{self, Backlight, Bicolour, Leds, LightConfig};
use super::menu::{DiagEntry, Effect, MenuContext, Mode, POWER_UP_MS};
use super::screen::{next_blink_edge, set_point_blinks, set_point_row, Row, RowStyle, Screen};
use super::setpoint::{SetPoints, Which};
use super::words::{cw, StatusWord};

/// The parameters the panel reads, each from its object.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Params {
    /// 5F0Bh = 1: row 2 off.
    pub row2_off: bool,
    /// 5F11h: decimal places of numeric set points (0..=4).
    pub decimals: u8,
    /// 5F12h sub 1 = 1: display rotated by 180°.
    pub rotated: bool,
    /// 5F12h sub 2-9: LEDs and backlight.
    pub lights: LightConfig,
    /// 5F1Ch sub 0: the acknowledgement keys.
    pub ack_keys: AckKeys,
    /// 5F1Ch sub 1 = 1: unacknowledged set points are shown steadily (0: they flash).
    pub steady_unacknowledged: bool,
    /// 2003h: key enable of [`KEYMAP`]`.enabled_by_2003`.
    pub key_enable_2003: bool,
    /// 2004h: key enable of [`KEYMAP`]`.enabled_by_2004`.
    pub key_enable_2004: bool,
    /// 2005h sub 1: configuration by keyboard enabled.
    pub config_enable: bool,
    /// 2005h sub 2: key enable time, seconds (1..=60).
    pub config_delay_s: u8,
    /// 5F0Ah sub 1: node-ID (shown and edited in the menu).
    pub node_id: u8,
    /// 5F0Ah sub 3: baud rate setting (0 auto, 1..=5).
    pub baud: u8,
}

impl Params {
    /// The factory settings.
    pub const FACTORY: Params = Params {
        row2_off: false,
        decimals: 0,
        rotated: false,
        lights: LightConfig::FACTORY,
        ack_keys: AckKeys::StarAndFront,
        steady_unacknowledged: false,
        key_enable_2003: true,
        key_enable_2004: true,
        config_enable: true,
        config_delay_s: 5,
        node_id: 0x7D,
        baud: 0,
    };

    fn menu(&self) -> MenuContext {
        MenuContext { node_id: self.node_id, baud: self.baud, config_enable: self.config_enable }
    }

    fn style(&self, sps: &SetPoints) -> RowStyle {
        RowStyle {
            decimals: self.decimals,
            extended: sps.control & cw::EXTENDED_RANGE != 0,
            steady_unacknowledged: self.steady_unacknowledged,
        }
    }

    /// Whether `key`'s own function is enabled (2003h / 2004h).
    fn enabled(&self, key: Key) -> bool {
        (key != KEYMAP.enabled_by_2003 || self.key_enable_2003)
            && (key != KEYMAP.enabled_by_2004 || self.key_enable_2004)
    }
}

/// Why [`Params::write`] refused a value.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum ParamError {
    /// The object is none of the panel's parameters.
    NotAPanelParameter,
    /// The value is outside the object's range (the dictionary answers 06090030h first).
    OutOfRange,
}

/// The objects [`Params`] carries, as (index, sub-index).
pub const PANEL_OBJECTS: [(u16, u8); 19] = [
    (0x2003, 0),
    (0x2004, 0),
    (0x2005, 1),
    (0x2005, 2),
    (0x5F0A, 1),
    (0x5F0A, 3),
    (0x5F0B, 0),
    (0x5F11, 0),
    (0x5F12, 1),
    (0x5F12, 2),
    (0x5F12, 3),
    (0x5F12, 4),
    (0x5F12, 5),
    (0x5F12, 6),
    (0x5F12, 7),
    (0x5F12, 8),
    (0x5F12, 9),
    (0x5F1C, 0),
    (0x5F1C, 1),
];

impl Params {
    /// The value of a panel parameter object as the dictionary holds it (`None`: not one).
    pub fn read(&self, index: u16, sub: u8) -> Option<u32> {
        let b = |f: bool| Some(f as u32);
        match (index, sub) {
            (0x2003, 0) => b(self.key_enable_2003),
            (0x2004, 0) => b(self.key_enable_2004),
            (0x2005, 1) => b(self.config_enable),
            (0x2005, 2) => Some(self.config_delay_s as u32),
            (0x5F0A, 1) => Some(self.node_id as u32),
            (0x5F0A, 3) => Some(self.baud as u32),
            (0x5F0B, 0) => b(self.row2_off),
            (0x5F11, 0) => Some(self.decimals as u32),
            (0x5F12, 1) => b(self.rotated),
            (0x5F12, s @ 2..=5) => b(self.lights.ack_dependent[s as usize - 2]),
            (0x5F12, 6) => b(self.lights.flash_leds),
            (0x5F12, 7) => b(self.lights.backlight_white),
            (0x5F12, 8) => b(self.lights.backlight_red),
            (0x5F12, 9) => b(self.lights.flash_backlight),
            (0x5F1C, 0) => Some(self.ack_keys.raw() as u32),
            (0x5F1C, 1) => b(self.steady_unacknowledged),
            _ => None,
        }
    }

    /// Takes a value written to a panel parameter object (by SDO, a restore, a load at
    /// power-up), checked against the object's range.
    pub fn write(&mut self, index: u16, sub: u8, value: u32) -> Result<(), ParamError> {
        let i = PANEL_OBJECTS.iter().position(|&o| o == (index, sub)).ok_or(ParamError::NotAPanelParameter)?;
        self.write_nth(i, value)
    }

    /// [`Params::write`] to the `i`th of [`PANEL_OBJECTS`].
    pub(crate) fn write_nth(&mut self, i: usize, value: u32) -> Result<(), ParamError> {
        let Some(&(lo, hi)) = PANEL_RANGES.get(i) else { return Err(ParamError::NotAPanelParameter) };
        if !(lo as u32..=hi as u32).contains(&value) {
            return Err(ParamError::OutOfRange);
        }
        let v = value as u8;
        // A byte-sized value in place, else a flag (its range is 0..=1).
        let byte = match i {
            3 => &mut self.config_delay_s,
            4 => &mut self.node_id,
            5 => &mut self.baud,
            7 => &mut self.decimals,
            17 => {
                self.ack_keys = AckKeys::from_raw(v).ok_or(ParamError::OutOfRange)?;
                return Ok(());
            }
            _ => {
                *match i {
                    0 => &mut self.key_enable_2003,
                    1 => &mut self.key_enable_2004,
                    2 => &mut self.config_enable,
                    6 => &mut self.row2_off,
                    8 => &mut self.rotated,
                    9..=12 => &mut self.lights.ack_dependent[i - 9],
                    13 => &mut self.lights.flash_leds,
                    14 => &mut self.lights.backlight_white,
                    15 => &mut self.lights.backlight_red,
                    16 => &mut self.lights.flash_backlight,
                    _ => &mut self.steady_unacknowledged,
                } = v == 1;
                return Ok(());
            }
        };
        *byte = v;
        Ok(())
    }
}

/// The range of each of [`PANEL_OBJECTS`], (lowest, highest): flags 0..=1, 2005h sub 2 the key
/// enable time 1..=60 s, 5F0Ah sub 1 the node-ID 1..=127, 5F0Ah sub 3 the baud rate 0..=5,
/// 5F11h 0..=4 decimal places, 5F1Ch sub 0 0..=2.
const PANEL_RANGES: [(u8, u8); 19] = [
    (0, 1),
    (0, 1),
    (0, 1),
    (1, 60),
    (1, 0x7F),
    (0, 5),
    (0, 1),
    (0, 4),
    (0, 1),
    (0, 1),
    (0, 1),
    (0, 1),
    (0, 1),
    (0, 1),
    (0, 1),
    (0, 1),
    (0, 1),
    (0, 2),
    (0, 1),
];

impl Default for Params {
    fn default() -> Self {
        Params::FACTORY
    }
}

/// Everything the operator sees at one instant.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct View {
    /// The LCD.
    pub screen: Screen,
    /// The two LEDs.
    pub leds: Leds,
    /// The backlight.
    pub backlight: Backlight,
}

impl core::fmt::Display for View {
    /// One line for a log or a live view: both rows cell by cell (as read, blanks kept, a '.'
    /// after a lit point), the LEDs and the backlight, e.g.
    /// `[ 12345|   ---] LED red/off light white+red`.
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let led = |b: Bicolour| match (b.green, b.red) {
            (false, false) => "off",
            (true, false) => "green",
            (false, true) => "red",
            (true, true) => "orange",
        };
        let light = match (self.backlight.white, self.backlight.red) {
            (false, false) => "off",
            (true, false) => "white",
            (false, true) => "red",
            (true, true) => "white+red",
        };
        write!(
            f,
            "[{}|{}] LED {}/{} light {}{}",
            self.screen.rows[0].cells_text(),
            self.screen.rows[1].cells_text(),
            led(self.leds.left),
            led(self.leds.right),
            light,
            if self.screen.rotated { " rotated" } else { "" }
        )
    }
}

/// The quarter of the power-up display test (started at `since`) that `now` is in: 0..=3 while
/// it runs, the LED element lit. The test lasts a second: its elapsed time fits 32 bits (a
/// 64-bit division is a library routine of about 1 KiB on the Cortex-M3).
#[inline(never)]
fn power_up_quarter(since: Instant, now: Instant) -> u32 {
    let elapsed = now.micros_since(since).min(u32::MAX as u64) as u32;
    elapsed / (POWER_UP_MS as u32 * 250)
}

/// Set points, keys and menu of one AP10T.
#[derive(Clone, PartialEq, Eq, Debug)]
pub struct Panel {
    /// The parameters in effect; the device updates them when an object changes.
    pub params: Params,
    sps: SetPoints,
    held: KeySet,
    mode: Mode,
    last_key: Instant,
    diag: heapless::Vec<DiagEntry, 8>,
}

impl Panel {
    /// A panel at its top level with nothing received.
    pub fn new(params: Params) -> Panel {
        Panel {
            params,
            sps: SetPoints::new(),
            held: KeySet::NONE,
            mode: Mode::Normal,
            last_key: Instant::ZERO,
            diag: heapless::Vec::new(),
        }
    }

    /// Starts the power-up display test at `now` (manual 2.1): every segment on, the four LED
    /// elements lit one after the other, for [`POWER_UP_MS`]; keys do nothing meanwhile.
    pub fn power_up(&mut self, now: Instant) {
        self.mode = Mode::PowerUp(now);
    }

    /// The set points and the last control word.
    pub fn set_points(&self) -> &SetPoints {
        &self.sps
    }

    /// RPDO1 (`Sp1`) or RPDO2 (`Sp2`) data arrived (8 bytes).
    pub fn receive(&mut self, which: Which, data: &[u8; 8]) {
        self.sps.receive(which, data);
    }

    /// The lines the diagnosis shows (error number 1 first = the latest); at most 8 are kept.
    pub fn set_diagnosis(&mut self, entries: &[DiagEntry]) {
        self.diag.clear();
        for e in entries.iter().take(self.diag.capacity()) {
            let _ = self.diag.push(*e);
        }
    }

    /// The diagnosis list itself, for the device to fill in place.
    pub(crate) fn diagnosis_mut(&mut self) -> &mut heapless::Vec<DiagEntry, 8> {
        &mut self.diag
    }

    /// Auto-ID (manual 4.6.2): a write of `new_id` to 5F0Ah sub 2 arrived; "New ID" shows until
    /// the Auto-ID key ([`Effect::AutoIdAdopted`]) or [`Panel::end_auto_id`]. An ID outside
    /// 1..=127 is refused (`false`; the SDO server answers with an abort).
    pub fn start_auto_id(&mut self, new_id: u8) -> bool {
        if !(1..=127).contains(&new_id) {
            return false;
        }
        self.mode = Mode::AutoId(new_id);
        true
    }

    /// Auto-ID ended without this device (another one answered, the master reset the node).
    pub fn end_auto_id(&mut self) {
        if matches!(self.mode, Mode::AutoId(_)) {
            self.mode = Mode::Normal;
        }
    }

    /// The mode in effect at `now`.
    pub fn mode(&self, now: Instant) -> Mode {
        self.mode.at(now, self.last_key)
    }

    /// The keys held down.
    pub fn held(&self) -> KeySet {
        self.held
    }

    /// A key was pressed (debounced edge) at `now`.
    pub fn press(&mut self, key: Key, now: Instant) -> Option<Effect> {
        self.held = self.held.with(key, true);
        let mut mode = self.mode(now);
        self.last_key = now;
        let effect = match mode {
            // Another key while node-ID and baud rate show: back to the top level, and the
            // key does what it does there.
            Mode::Normal | Mode::Info(_) if mode == Mode::Normal || key != KEYMAP.parameterize => {
                self.top_level(&mut mode, key, now)
            }
            _ => mode.step(key, &self.params.menu()),
        };
        self.mode = mode;
        effect
    }

    /// A key was released.
    pub fn release(&mut self, key: Key) {
        self.held = self.held.with(key, false);
    }

    /// A key at the top level: acknowledgement first, where the key acknowledges and a set
    /// point waits for it (D-AP-8), else the parameterization key shows node-ID and baud rate.
    fn top_level(&mut self, mode: &mut Mode, key: Key, now: Instant) -> Option<Effect> {
        let p = &self.params;
        *mode = Mode::Normal;
        if p.ack_keys.acknowledges(key) && p.enabled(key) && self.sps.acknowledge() {
            return Some(Effect::Acknowledged);
        }
        if key == KEYMAP.parameterize {
            *mode = Mode::Info(now.add_millis(p.config_delay_s.max(1) as u64 * 1000));
        }
        None
    }

    /// The status word 5F19h (bit 9 = 0).
    pub fn status_word(&self) -> StatusWord {
        self.sps.status_word(self.held)
    }

    /// [`Panel::status_word`] as its 16 bits.
    pub fn status_bits(&self) -> u16 {
        self.sps.status_bits(self.held)
    }

    /// TPDO1 (`Sp1`) / TPDO2 (`Sp2`) data; `remote`: answering a remote request.
    pub fn tpdo(&self, which: Which, remote: bool) -> [u8; 8] {
        self.sps.tpdo(which, self.held, remote)
    }

    /// The two set point rows at `now` (the top level).
    fn set_point_rows(&self, now: Instant) -> [Row; 2] {
        let style = self.params.style(&self.sps);
        let row1 = set_point_row(&self.sps.sp[0], style, now);
        let row2 = if self.params.row2_off { Row::BLANK } else { set_point_row(&self.sps.sp[1], style, now) };
        [row1, row2]
    }

    /// What the display, LEDs and backlight show at `now`.
    pub fn view(&self, now: Instant) -> View {
        let p = &self.params;
        let mode = self.mode(now);
        let rows = match mode {
            Mode::Normal => self.set_point_rows(now),
            _ => mode.screen(now, &p.menu(), &self.diag),
        };
        let (lit, backlight) = match mode {
            // The power-up test lights the four LED elements one after the other (a quarter
            // past the last is no element).
            Mode::PowerUp(since) => (1 << power_up_quarter(since, now).min(4), Backlight { white: true, red: true }),
            _ => (leds::lit(&p.lights, &self.sps, now), leds::backlight(&p.lights, now)),
        };
        let leds = Leds::from_bits(lit);
        View { screen: Screen { rows, rotated: p.rotated }, leds, backlight }
    }

    /// When [`Panel::view`] next changes by itself after `now` (blinking, a time-out); `None`
    /// when only an input can change it. The shell redraws then (or on any input).
    pub fn next_change(&self, now: Instant) -> Option<Instant> {
        let p = &self.params;
        let mode = self.mode(now);
        let blink = match mode {
            Mode::PowerUp(since) => {
                // The next quarter (an LED element's turn), at the latest the end of the test.
                // A quarter of the running test (under four): microseconds in 32 bits.
                let next = power_up_quarter(since, now) + 1;
                return Some(since.add_micros((next * POWER_UP_MS as u32 * 250) as u64));
            }
            Mode::Normal => {
                let style = p.style(&self.sps);
                set_point_blinks(&self.sps.sp[0], style) || (!p.row2_off && set_point_blinks(&self.sps.sp[1], style))
            }
            _ => mode.blinks(),
        };
        let next = mode.deadline(self.last_key);
        if blink || leds::blinks(&p.lights, &self.sps) {
            let edge = next_blink_edge(now);
            return Some(match next {
                Some(t) if t < edge => t,
                _ => edge,
            });
        }
        next
    }
}
