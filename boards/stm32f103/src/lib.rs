//! The SIKO boards on the STM32F103CB: what each product is made of, pin by pin.
//!
//! [`mcu`] is what every board shares (clocks, bxCAN and its transceiver, parameter flash,
//! watchdog, reset cause, variant straps); [`sensor`] and [`leds`] are the front-ends the
//! encoders share, [`wire`] the draw-wire board; one module per product puts them together:
//! [`sgh10`], [`sgh50`], [`wv5800m`], [`wv58mr`] and [`ap10t`]. `boards/README.md` has the pin
//! map. Every decision that can be computed without the hardware is in `board-plan`,
//! host-tested.
//!
//! The firmware drives a board's inputs and outputs through [`Io`]: sampled every
//! [`Io::period_us`] (a sensor, the keys) and shown whenever the node may have changed (LEDs,
//! display).
#![no_std]
#![deny(missing_docs)]

pub mod ap10t;
pub mod flash;
pub mod leds;
pub mod mcu;
pub mod pin;
pub mod sensor;
pub mod sgh10;
pub mod sgh50;
pub mod wire;
pub mod wv5800m;
pub mod wv58mr;

use od_core::node::{Core, Device};
use od_core::Instant;

/// A board's device-specific inputs and outputs, besides CAN.
pub trait Io<D: Device> {
    /// How often [`Io::sample`] runs, in microseconds (the device's sample period).
    fn period_us(&self, device: &D) -> u32;

    /// Reads the inputs and hands them to the device (a sensor sample, a key scan).
    fn sample(&mut self, device: &mut D, core: &mut Core, now: Instant);

    /// Shows the device's state (LEDs, display) at `now`; returns when it next changes by
    /// itself (a blinking LED), `None` if it is steady.
    fn show(&mut self, device: &D, core: &Core, now: Instant) -> Option<Instant>;
}
