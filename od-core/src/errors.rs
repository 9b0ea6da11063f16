//! The error conditions of a device, whatever transport reports them: which conditions are
//! active, the error register (1001h) they make, and the error history (1003h).
//!
//! A device raises and clears conditions with [`crate::context::Context::set_error`]; each
//! change is recorded here and announced at once as the transport has set it up ([`Gate`],
//! [`Announce`]): the CANopen node sends an EMCY frame (`crate::emcy`), holds it until its
//! boot-up message, or drops it, as its NMT state and 1014h allow; a J1939 node will report the
//! active conditions in DM1. The rules
//! (D-EMCY-n in `docs/decisions.md`):
//! - a rising condition sets its bits in 1001h (bit 0 whenever any error is active), enters its
//!   code at 1003h.01 (older entries moving one sub-index up) and announces `code`;
//! - a falling condition recomputes 1001h from the conditions still active and announces the
//!   "error reset" 0000h; it is not entered in the history;
//! - setting a condition to the state it has does nothing ("only once per error event").

use crate::abort::Abort;
use crate::frame::Frame;
use crate::od::Od;
use crate::output::Outbox;
use crate::wire::emcy::NO_ERROR;

/// Index of the error register.
pub const ERROR_REGISTER: u16 = 0x1001;
/// Index of the pre-defined error field (error history).
pub const ERROR_HISTORY: u16 = 0x1003;
/// 1001h bit 0: generic error, set while any error condition is active.
pub const GENERIC: u8 = 0x01;

/// Most error conditions active at once that are tracked. The manuals list at most seven
/// codes per device.
pub const MAX_ACTIVE: usize = 16;
/// Most announcements held until the transport may send them (the CANopen boot-up message).
pub const MAX_DEFERRED: usize = 8;

/// What the transport does with an announcement now.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Gate {
    /// Send it ([`Errors::announce_with`] builds the frame).
    Send,
    /// Hold it until [`crate::context::Context::release_deferred`] (CANopen INITIALISATION).
    Defer,
    /// Drop it (CANopen STOPPED); 1001h and 1003h still record the change.
    Drop,
}

/// How a transport puts one announcement on the bus: the frame for (code, error register),
/// given the dictionary and the node-ID, or `None` if it may not be sent (an invalid 1014h).
pub type Announce = fn(od: &Od, node_id: u8, code: u16, register: u8) -> Option<Frame>;

fn announce_nothing(_: &Od, _: u8, _: u16, _: u8) -> Option<Frame> {
    None
}

/// One active error condition: its code and the 1001h bits it sets.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
struct Active {
    code: u16,
    bits: u8,
}

/// The active error conditions, how the transport announces their changes, and the
/// announcements it holds.
#[derive(Clone)]
pub struct Errors {
    active: heapless::Vec<Active, MAX_ACTIVE>,
    /// (code, error register) of announcements held by [`Gate::Defer`].
    deferred: heapless::Deque<(u16, u8), MAX_DEFERRED>,
    /// `deferred` is not empty: one load for the idle tick.
    waiting: bool,
    gate: Gate,
    announce: Announce,
}

impl Default for Errors {
    fn default() -> Errors {
        Errors {
            active: heapless::Vec::new(),
            deferred: heapless::Deque::new(),
            waiting: false,
            gate: Gate::Defer,
            announce: announce_nothing,
        }
    }
}

impl Errors {
    /// Is the condition `code` active?
    pub fn is_active(&self, code: u16) -> bool {
        self.active.iter().any(|a| a.code == code)
    }

    /// The error register as the active conditions make it.
    pub fn register(&self) -> u8 {
        let mut reg = 0;
        for a in &self.active {
            reg |= a.bits | GENERIC;
        }
        reg
    }

    /// The codes of the active conditions (a J1939 DM1).
    pub fn active(&self) -> impl Iterator<Item = u16> + '_ {
        self.active.iter().map(|a| a.code)
    }

    /// How the transport builds its announcement frames.
    pub fn announce_with(&mut self, announce: Announce) {
        self.announce = announce;
    }

    /// What happens to an announcement now (the transport sets it as its state changes).
    pub fn set_gate(&mut self, gate: Gate) {
        self.gate = gate;
    }

    /// The gate in force.
    pub fn gate(&self) -> Gate {
        self.gate
    }

    /// Are announcements held?
    #[inline]
    pub fn has_deferred(&self) -> bool {
        self.waiting
    }

    /// Drops the announcements held and holds one for every condition still active (after a
    /// CANopen reset: the new session learns of each).
    pub fn defer_active(&mut self) {
        self.deferred.clear();
        let register = self.register();
        for a in &self.active {
            let _ = self.deferred.push_back((a.code, register));
        }
        self.waiting = !self.deferred.is_empty();
    }

    /// Takes the oldest held announcement.
    fn take_deferred(&mut self) -> Option<(u16, u8)> {
        let next = self.deferred.pop_front();
        self.waiting = !self.deferred.is_empty();
        next
    }

    /// Announces (code, register) through the gate.
    fn announce(&mut self, od: &Od, node_id: u8, out: &mut Outbox, code: u16, register: u8) {
        match self.gate {
            Gate::Send => {
                if let Some(frame) = (self.announce)(od, node_id, code, register) {
                    out.send(frame);
                }
            }
            Gate::Defer => {
                let _ = self.deferred.push_back((code, register));
                self.waiting = true;
            }
            Gate::Drop => {}
        }
    }

    /// Sends the held announcements, if the gate now lets them through.
    pub(crate) fn release(&mut self, od: &Od, node_id: u8, out: &mut Outbox) {
        if !self.waiting || self.gate == Gate::Defer {
            return;
        }
        while let Some((code, register)) = self.take_deferred() {
            self.announce(od, node_id, out, code, register);
        }
    }

    /// Sets or clears condition `code` in `od`'s 1001h and 1003h and announces the change
    /// (see the module rules). Code 0000h is not a condition and is ignored.
    pub(crate) fn set(
        &mut self,
        od: &mut Od,
        node_id: u8,
        out: &mut Outbox,
        code: u16,
        register_bits: u8,
        active: bool,
    ) {
        if code == NO_ERROR {
            return;
        }
        let at = self.active.iter().position(|a| a.code == code);
        let sent = match (active, at) {
            (true, None) => {
                // Full: the condition still reaches the bus, 1001h and 1003h; only its falling
                // edge cannot be matched. Seven codes per device make this unreachable.
                let _ = self.active.push(Active { code, bits: register_bits });
                history_push(od, code);
                code
            }
            (false, Some(i)) => {
                // `swap_remove` without its overlapping copy (a `memmove` in the image).
                if let Some(last) = self.active.pop() {
                    if i < self.active.len() {
                        self.active[i] = last;
                    }
                }
                NO_ERROR
            }
            _ => return,
        };
        let mut register = self.register();
        if active && at.is_none() {
            register |= register_bits | GENERIC;
        }
        od.set_value(ERROR_REGISTER, 0, register as u32);
        self.announce(od, node_id, out, sent, register);
    }
}

/// How many members (sub-indices after it) the object whose sub 0 is at `head` declares: the
/// history's capacity, for its push and its clear.
#[inline(never)]
fn members(od: &Od, head: usize) -> usize {
    let table = od.table();
    let index = table.get(head).map_or(0, |e| e.index);
    table.get(head + 1..).unwrap_or(&[]).iter().take_while(|e| e.index == index).count()
}

/// Enters `code` at 1003h.01; older entries move up one sub-index, the oldest falls out when
/// the history is full; sub 0 counts the entries.
fn history_push(od: &mut Od, code: u16) {
    let Some(head) = od.pos(ERROR_HISTORY, 0) else {
        return;
    };
    let capacity = members(od, head);
    if capacity == 0 {
        return;
    }
    for k in (1..capacity).rev() {
        let older = od.get(head + k);
        od.set(head + k + 1, older);
    }
    od.set(head + 1, code as u32);
    let count = (od.get(head) as usize + 1).min(capacity);
    od.set(head, count as u32);
}

/// Checks a write to 1003h sub 0 (entry `pos`): only 0, which clears the history; on `Ok`
/// the caller stores the value.
pub fn clear_history(od: &mut Od, pos: usize, value: u32) -> Result<(), Abort> {
    if value != 0 {
        return Err(Abort::INVALID_VALUE);
    }
    for k in 1..=members(od, pos) {
        od.set(pos + k, 0);
    }
    Ok(())
}

/// Refuses reads the dictionary alone cannot judge: a 1003h entry above the error count
/// (08000024h "no data available", CiA 301 §7.5.2.4).
#[inline]
pub fn check_read(od: &Od, index: u16, sub: u8) -> Result<(), Abort> {
    if index != ERROR_HISTORY || sub == 0 {
        return Ok(());
    }
    match od.value(ERROR_HISTORY, 0) {
        Some(count) if sub as u32 > count => Err(Abort::NO_DATA),
        _ => Ok(()),
    }
}
