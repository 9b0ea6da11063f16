//! The interface between a node and its shell (the firmware's main loop, the virtual bus of
//! the host tests, the simulator): frames and controller events in, time in, outputs out. A
//! CANopen node and a J1939 node both implement [`Station`], so one shell drives either.

use crate::context::{BusEvent, Context, Output};
use crate::frame::{Frame, RxId};
use crate::time::Instant;

/// Most frame kinds [`Station::rx_ids`] lists: LSS, NMT, SDO, guarding and SYNC, two for each
/// of up to [`crate::pdo::MAX_RPDOS`] RPDOs and one for each TPDO.
pub const MAX_RX_IDS: usize = 5 + 2 * crate::pdo::MAX_RPDOS + crate::pdo::MAX_TPDOS;

/// The list [`Station::rx_ids`] returns.
pub type RxIds = heapless::Vec<RxId, MAX_RX_IDS>;

/// Most acceptance masks [`Station::rx_masks`] lists (a J1939 node: four).
pub const MAX_RX_MASKS: usize = 4;

/// The list [`Station::rx_masks`] returns: (identifier, mask) pairs over 29-bit identifiers; a
/// frame passes when `id & mask == identifier & mask`.
pub type RxMasks = heapless::Vec<(u32, u32), MAX_RX_MASKS>;

/// A node as its shell drives it. The shell feeds it with [`Station::on_frame`],
/// [`Station::on_bus_event`] and [`Station::poll`], carries out the [`Output`]s it takes from
/// [`Station::next_output`] (reporting stores with [`Station::store_done`]), programs its
/// acceptance filters from [`Station::rx_ids`] whenever [`Station::rx_ids_generation`]
/// changes, and sleeps until [`Station::next_deadline`]. Nothing here waits or reads a clock.
pub trait Station {
    /// Handles one received frame.
    fn on_frame(&mut self, frame: &Frame, now: Instant);

    /// The CAN controller reported `event`.
    fn on_bus_event(&mut self, event: BusEvent, now: Instant);

    /// Runs the timers due at `now`.
    fn poll(&mut self, now: Instant);

    /// When [`Station::poll`] must next run; `None` when nothing is scheduled.
    fn next_deadline(&self) -> Option<Instant>;

    /// Takes the next thing the shell must do.
    fn next_output(&mut self) -> Option<Output>;

    /// The shell has finished (`Ok`) or failed the [`Output::Store`] it was given.
    fn store_done(&mut self, result: Result<(), ()>, now: Instant);

    /// Every frame the node acts on in some state, for the acceptance filters; frames of any
    /// other kind it ignores.
    fn rx_ids(&self) -> RxIds;

    /// The frames the node acts on that exact identifiers cannot list, as masks over 29-bit
    /// data frames (a J1939 node: claims from any source). Empty by default (CANopen). They
    /// change only when [`Station::rx_ids_generation`] does.
    fn rx_masks(&self) -> RxMasks {
        RxMasks::new()
    }

    /// A number that changes whenever [`Station::rx_ids`] may have changed.
    fn rx_ids_generation(&self) -> u32;

    /// The shared state: what a store persists, the active bit rate.
    fn context(&self) -> &Context;

    /// Is the node detecting its bit rate? The shell then runs the controller silent (no ACK,
    /// no error frame) at the rate of the last `Output::SetBitrate`, with its filters open
    /// (`Node::listen_only`). False by default.
    fn listen_only(&self) -> bool {
        false
    }
}

/// A station with a device the shell also feeds directly (sensor samples, key presses).
pub trait DeviceStation: Station {
    /// The device type.
    type Device;

    /// The device.
    fn device(&self) -> &Self::Device;

    /// The device and the context together, for the shell's samples.
    fn split(&mut self) -> (&mut Self::Device, &mut Context);
}
