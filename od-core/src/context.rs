//! The context every transport shares: the dictionary, the outputs for the shell, the stored
//! parameters and the error conditions, with the node's address and bit rate.
//!
//! A CANopen node ([`crate::node::Node`]) and a J1939 node both own one and hand it to their
//! services and their device per call. This module imports no service: what a service needs
//! from another, the node passes in.

use crate::abort::Abort;
use crate::bitrate::Bitrate;
use crate::errors::Errors;
use crate::od::{Entry, Group, GroupMask, Od};
use crate::storage::{self, Parameters, Storage, LOAD, SAVE};
use crate::time::Instant;

pub use crate::output::{Outbox, Output, OUTBOX_DEPTH};

/// Which reset the node performs (NMT 81h / 82h, power-on).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum ResetKind {
    /// Power-on or NMT Reset Node (81h): application and communication re-initialised.
    Node,
    /// NMT Reset Communication (82h): communication re-initialised only.
    Communication,
}

impl ResetKind {
    /// The storage groups this reset reloads.
    pub const fn groups(self) -> GroupMask {
        match self {
            ResetKind::Node => GroupMask::ALL,
            ResetKind::Communication => GroupMask(Group::Comm.bit()),
        }
    }
}

/// What the CAN controller reports besides frames. The shell passes each change it sees to
/// the node's `on_bus_event`; the device turns them into its diagnosis objects and error
/// conditions (5000h, 1002h, 8120h, 8140h as its manual says).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum BusEvent {
    /// The controller entered the error-passive state (an error counter above 127).
    ErrorPassive,
    /// The controller is error active again (both error counters back below 128).
    ErrorActive,
    /// The controller went bus-off (transmit error counter above 255); it sends nothing.
    BusOff,
    /// The controller recovered from bus-off (128 × 11 recessive bits) and is error active.
    BusOffRecovered,
    /// A received frame was lost because the receive FIFO was full.
    RxOverrun,
    /// The controller detected a protocol error of this kind (its last error code).
    ProtocolError(CanError),
    /// The controller's current error counters (for 1002h), reported when they change.
    ErrorCounters {
        /// Receive error counter.
        rx: u8,
        /// Transmit error counter.
        tx: u8,
    },
}

/// The kind of a CAN protocol error (ISO 11898-1), as controllers report it.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum CanError {
    /// Bit stuffing violated.
    Stuff,
    /// A fixed-form field held an illegal bit.
    Form,
    /// No node acknowledged a transmitted frame.
    Acknowledge,
    /// A transmitted bit read back different (recessive or dominant).
    Bit,
    /// The received CRC did not match.
    Crc,
}

/// The result of a successful dictionary write.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Written {
    /// Done: confirm now.
    Done,
    /// The value was accepted but the confirmation waits for the shell (a 1010h "save"):
    /// the SDO server answers when the node reports the store done.
    Deferred,
}

/// The state every transport and the device share.
pub struct Context {
    /// Object dictionary.
    pub od: Od,
    /// The node's address: the active CANopen node-ID (1..=127, or 255 while unconfigured),
    /// which the dictionary's "+ node-ID" defaults follow.
    pub node_id: u8,
    /// Active bit rate.
    pub bitrate: Bitrate,
    /// Outputs for the shell.
    pub out: Outbox,
    /// Stored parameters: what a reset loads, pending restores and saves.
    pub storage: Storage,
    /// Error conditions, 1001h and 1003h.
    pub errors: Errors,
}

impl Parameters for Context {
    fn od(&self) -> &Od {
        &self.od
    }
    fn node_id(&self) -> u8 {
        self.node_id
    }
}

impl Context {
    /// A context with `od`, `storage`, `node_id` and `bitrate`, nothing queued, no error.
    pub fn new(od: Od, storage: Storage, node_id: u8, bitrate: Bitrate) -> Context {
        Context { od, node_id, bitrate, out: Outbox::default(), storage, errors: Errors::default() }
    }

    /// Does the node take part in CANopen (has a valid node-ID)?
    pub fn configured(&self) -> bool {
        (1..=127).contains(&self.node_id)
    }

    /// Sets or clears the error condition `code` (for example FF15h, 8120h) with the 1001h
    /// bits `register_bits` (bit 0 is implied): 1001h and 1003h follow, and the transport
    /// announces the change (CANopen: one EMCY, "error reset" 0000h on a falling condition).
    /// Calling it again with the same state does nothing. Code 0000h is ignored.
    pub fn set_error(&mut self, code: u16, register_bits: u8, active: bool, now: Instant) {
        let _ = now;
        self.errors.set(&mut self.od, self.node_id, &mut self.out, code, register_bits, active);
    }

    /// Sends the announcements held while the gate was [`crate::errors::Gate::Defer`], if it
    /// lets them through now (the CANopen node after its boot-up message).
    #[inline]
    pub fn release_deferred(&mut self) {
        self.errors.release(&self.od, self.node_id, &mut self.out);
    }

    /// Asks the shell to persist `mask` ([`Output::Store`]); the result comes back through
    /// the node's `store_done`. One store at a time: 08000022h while one is under way.
    /// 1010h uses it, and so does LSS "store configuration" with [`GroupMask::LSS`].
    pub fn request_store(&mut self, mask: GroupMask) -> Result<(), Abort> {
        self.storage.begin_save(mask)?;
        self.out.push(Output::Store(mask));
        Ok(())
    }

    /// 1010h sub 1..4 (entry `pos`): "save" stores the selected groups; the answer waits for
    /// the shell.
    pub fn on_store(&mut self, pos: usize, value: u32) -> Result<Written, Abort> {
        if value != SAVE {
            return Err(Abort::CANNOT_STORE);
        }
        let mask = storage::group_of(&self.od, pos).ok_or(Abort::CANNOT_STORE)?;
        self.request_store(mask)?;
        Ok(Written::Deferred)
    }

    /// 1011h sub 1..4 (entry `pos`): "load" marks the selected groups; the next reset loads
    /// their defaults. RAM and flash are unchanged until then.
    pub fn on_restore(&mut self, pos: usize, value: u32) -> Result<Written, Abort> {
        if value != LOAD {
            return Err(Abort::CANNOT_STORE);
        }
        let mask = storage::group_of(&self.od, pos).ok_or(Abort::CANNOT_STORE)?;
        self.storage.mark_restore(mask);
        Ok(Written::Done)
    }

    /// The shell finished (`ok`) or failed the store requested: see [`Storage`]. A power-on
    /// fault the store fixed clears its error condition.
    pub fn store_done(&mut self, ok: bool, now: Instant) {
        if self.storage.finish_save(&self.od, self.node_id, ok) {
            self.set_error(storage::EMCY_DATA_SET, 0, false, now);
        }
    }

    /// Re-initialises the dictionary for a reset of `kind` (the stored values, or the
    /// defaults 1011h marked, on the entries `restores` picks).
    pub fn reload(&mut self, kind: ResetKind, restores: impl Fn(&Entry, GroupMask) -> bool) {
        self.storage.reload(&mut self.od, self.node_id, kind.groups(), restores);
    }

    /// After the boot-up: report a power-on that found the parameter flash unusable.
    pub fn boot_up(&mut self, now: Instant) {
        if self.storage.fault() {
            self.set_error(storage::EMCY_DATA_SET, 0, true, now);
        }
    }
}
