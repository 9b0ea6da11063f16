//! `board-plan`: everything the firmware shell decides about its peripherals that can be
//! computed without them, so that host tests cover it.
//!
//! - [`timing`]: bxCAN bit timing for every CANopen bit rate from the APB1 clock;
//! - [`alarm`]: wake-up times the TIM2 time driver can program (and Renode's timer model fire);
//! - [`filters`]: the node's receive identifiers packed into bxCAN filter banks;
//! - [`errors`]: the controller's error register turned into [`od_core::node::BusEvent`]s;
//! - [`sensor`]: the SPI angle sensor's frame and the raw counts the devices take;
//! - [`straps`]: the product variant from the strap pins, the serial number from the MCU;
//! - [`lcd`] and [`keys`]: the AP10T's display (7-segment font, HT1621 transfers) and key
//!   debouncing;
//! - [`reset`]: why the MCU reset, from the RCC's reset flags;
//! - [`txq`]: the transmit queue that hands frames to the mailboxes in priority order;
//! - [`mailbox`]: a frame in the transmit mailboxes' registers, and which mailbox takes it;
//! - [`rxq`]: the ring the receive interrupt fills and the main loop empties;
//! - [`watchdog`]: the independent watchdog's register values for its timeout.
//!
//! The hardware side (Embassy, registers, pins) is in the `boards` crate and in `firmware/`,
//! which are built for `thumbv7m-none-eabi` only.
#![cfg_attr(not(test), no_std)]
#![deny(missing_docs)]

pub mod alarm;
pub mod errors;
pub mod filters;
pub mod keys;
pub mod lcd;
pub mod mailbox;
pub mod reset;
pub mod rxq;
pub mod sensor;
pub mod straps;
pub mod timing;
pub mod txq;
pub mod watchdog;
