//! The AP10T set point display: its front panel as pure state machines (what the two LCD rows,
//! the two bi-colour LEDs and the backlight show, what the four keys and the key menu do, and
//! the control word 5F0Ch / status word 5F19h), its dictionary ([`table`]) and the CANopen
//! device that wires the panel to it ([`device`]).
//!
//! - [`words`]: control word and status word as typed values (manual Tables 10, 11).
//! - [`setpoint`]: set points from RPDO1/RPDO2, validity, acknowledgement, TPDO data.
//! - [`screen`]: rows of six cells as text, number formatting, "FULLL", "---", the extended
//!   range, flashing, 180° rotation onto the LCD's digits.
//! - [`leds`]: LEDs (acknowledgement-dependent or by control word) and backlight.
//! - [`keys`]: keys, acknowledgement keys of 5F1Ch, and [`keys::KEYMAP`], the one table of
//!   which key does what.
//! - [`menu`]: ID / KBAUD / CODE, diagnosis, "New ID".
//! - [`panel`]: all of it together, [`Panel`].
//! - [`table`]: the object dictionary.
//! - [`device`]: the CANopen device, [`Ap10t`].
//!
//! Time is an argument everywhere; every blinking thing runs on one clock (D-AP-6) from
//! `Instant::ZERO` ([`screen::BLINK_PERIOD_MS`]). The decisions are D-AP-1 … in
//! `docs/decisions.md`, section "AP10T".

pub mod device;
pub mod keys;
pub mod leds;
pub mod menu;
pub mod panel;
pub mod screen;
pub mod setpoint;
pub mod table;
pub mod words;

pub use device::Ap10t;
pub use keys::{Key, KeySet, KEYMAP};
pub use menu::{DiagEntry, Effect, Mode, ResetScope};
pub use panel::{Panel, ParamError, Params, View};
pub use screen::{Row, Screen};
pub use setpoint::{SetPoint, SetPoints, Which};
pub use words::{ControlWord, StatusWord};
