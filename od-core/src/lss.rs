//! LSS slave (CiA 305) on 7E5h (master to slave) / 7E4h (slave to master).
//!
//! The SGH10, SGH50 and WV5800M manuals (§4.6 / §5.6) describe the services of their Table 10
//! (Table 15 on the WV5800M): switch state global and selective, configure node-ID, configure
//! and activate bit timing, store configuration and the inquire services. Beyond the manuals
//! the slave answers what standard LSS masters use to find nodes: identify remote slave,
//! identify non-configured remote slave and LSS Fastscan, as CiA 305 defines them.
//!
//! The LSS address is 1018h sub 1..4 (vendor-ID, product code, revision number, serial
//! number). Configure node-ID and configure bit timing set the *pending* values, which are the
//! dictionary entries hooked [`CoreHook::PendingNodeId`] and [`CoreHook::PendingBitrate`]
//! (5F0Ah.01/.02 on the SIKO encoders); an NMT reset activates the node-ID (`node.rs`), and so
//! does switching an unconfigured node back to LSS waiting (CiA 305), but not a bit rate LSS
//! configured ([`Lss::rate_awaits_activation`]): that one waits for activate bit timing or a
//! power cycle. Activate bit timing switches
//! to the pending bit rate after delay d1 and, after d2, restarts communication on it with a
//! boot-up (the manuals). The bit-rate code the pending entry holds is the device's
//! ([`crate::device::Device::bitrate_codes`]), not the CiA 305 table index.
//!
//! The messages are [`crate::wire::lss`]'s [`Request`]s and [`Response`]s; this module is the
//! slave's state machine over them, reading and answering them straight as bytes (D-ARCH-8's
//! reason, as for SDO). Every decision the manuals leave open is in
//! `docs/decisions.md`, section "LSS".

use crate::bitrate::Bitrate;
use crate::context::{Context, Output};
use crate::frame::Frame;
use crate::od::{CoreHook, GroupMask, Od};
use crate::time::{Duration, Instant};
use crate::wire::lss::response;
use crate::wire::{exactly_8, u32_le};

pub use crate::wire::lss::{
    cs, error, IdentifyStep, LssState, Part, Request, Response, FASTSCAN_RESET, MASTER_ID as RX_ID, SLAVE_ID as TX_ID,
};

/// The node-ID of a node that has none ("not configured", CiA 305): it takes part in LSS only.
pub const UNCONFIGURED: u8 = 0xFF;

/// What the node must do after an LSS frame or tick.
#[must_use]
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum LssEvent {
    /// Nothing beyond the outputs already queued.
    None,
    /// An activate bit timing started: the node leaves the bus (NMT INITIALISATION, no
    /// service sends) until its boot-up on the new rate.
    Switching,
    /// Reset communication (NMT 82h semantics: the pending node-ID and bit rate become
    /// active, boot-up follows): an unconfigured node got a node-ID and was switched back to
    /// LSS waiting.
    ResetCommunication,
    /// An activate bit timing has run its two delays: communication restarts on the new rate
    /// (NMT INITIALISATION, then the boot-up message) with the active node-ID and every
    /// parameter kept.
    BootUp,
}

/// An activate bit timing under way: the rate switches one `delay` after the request, the
/// boot-up goes out one `delay` later; the node sends nothing meanwhile.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
struct Switch {
    /// The end of the delay under way: the rate's switch, then (once `adopted`) the boot-up.
    due: Instant,
    delay: Duration,
    adopted: bool,
    /// An unconfigured node with a pending node-ID was switched to LSS waiting meanwhile: it
    /// activates the node-ID at the end of the switch instead of at once.
    activate: bool,
}

/// LSS slave state.
#[derive(Clone, Debug)]
pub struct Lss {
    /// The device has an LSS slave (and both pending entries).
    enabled: bool,
    state: LssState,
    /// The device's coding of the pending bit-rate entry, as (code, rate).
    codes: &'static [(u32, Bitrate)],
    /// Position of the pending node-ID entry.
    pending_node_id: usize,
    /// Position of the pending bit-rate entry.
    pending_bitrate: usize,
    /// Parts of the LSS address that switch state selective has matched so far, in order.
    selective: u8,
    /// Steps of identify remote slave passed so far, in order.
    identify: u8,
    /// Fastscan LSSPos: the part the next Fastscan request must compare.
    fastscan_pos: Part,
    /// A store configuration waits for the shell's result.
    storing: bool,
    /// An activate bit timing under way.
    switch: Option<Switch>,
    /// The code configure bit timing wrote into the pending bit-rate entry, until activate
    /// bit timing applies it: an NMT reset does not (CiA 305: activate bit timing or a power
    /// cycle; issue 13 point 9, D-LSS-15). Kept over NMT resets, gone at power-off.
    configured_rate: Option<u32>,
}

impl Lss {
    /// The LSS slave of a node whose dictionary is `od`: enabled when the device has one
    /// (`has_lss`) and its dictionary declares the entries hooked `PendingNodeId` and
    /// `PendingBitrate`; `codes` is the device's bit-rate coding of the latter.
    pub fn new(od: &Od, has_lss: bool, codes: &'static [(u32, Bitrate)]) -> Lss {
        let node_id = od.find_hook(CoreHook::PendingNodeId);
        let bitrate = od.find_hook(CoreHook::PendingBitrate);
        Lss {
            enabled: has_lss && node_id.is_some() && bitrate.is_some(),
            state: LssState::Waiting,
            codes,
            pending_node_id: node_id.unwrap_or(0),
            pending_bitrate: bitrate.unwrap_or(0),
            selective: 0,
            identify: 0,
            fastscan_pos: Part::Vendor,
            storing: false,
            switch: None,
            configured_rate: None,
        }
    }

    /// Does the node answer LSS?
    pub fn enabled(&self) -> bool {
        self.enabled
    }

    /// The LSS state (the WV5800M shows LSS configuration on its LEDs).
    pub fn state(&self) -> LssState {
        self.state
    }

    /// Is an activate bit timing under way? The node then sends nothing and handles only LSS
    /// switch state global.
    pub fn switching(&self) -> bool {
        self.switch.is_some()
    }

    /// Back to LSS waiting with no service half done.
    fn enter_waiting(&mut self) {
        self.state = LssState::Waiting;
        self.selective = 0;
        self.identify = 0;
        self.fastscan_pos = Part::Vendor;
    }
}

/// The code of `rate` in the device's coding.
fn code_of(codes: &[(u32, Bitrate)], rate: Bitrate) -> Option<u32> {
    codes.iter().find(|(_, b)| *b == rate).map(|(c, _)| *c)
}

/// The rate `code` stands for in the device's coding.
fn rate_of(codes: &[(u32, Bitrate)], code: u32) -> Option<Bitrate> {
    codes.iter().find(|(c, _)| *c == code).map(|(_, b)| *b)
}

impl Lss {
    /// The pending node-ID (what the next reset activates).
    fn pending_node_id(&self, ctx: &Context) -> u8 {
        ctx.od.get(self.pending_node_id) as u8
    }

    /// Does the node have no valid node-ID, neither active nor pending (CiA 305
    /// "non-configured")? Only such a node takes part in Fastscan and answers 4Ch.
    fn non_configured(&self, ctx: &Context) -> bool {
        !ctx.configured() && !(1..=127).contains(&self.pending_node_id(ctx))
    }

    /// Answers with command specifier `cs` and bytes 1..=4 `tail` ([`response`]: the
    /// [`Response`] the tests read back).
    fn send(&mut self, ctx: &mut Context, cs: u8, tail: u32) {
        ctx.out.send(Frame::std(TX_ID, &response(cs, tail)));
    }

    /// Switch state global. True when the node must now activate its pending node-ID: CiA 305
    /// has a node without a node-ID that got one activate it on its own when switched back to
    /// waiting (no NMT command can reach it); a configured node waits for NMT reset communication.
    fn switch_global(&mut self, ctx: &mut Context, to: LssState) -> bool {
        let was = self.state;
        match to {
            LssState::Configuration => {
                self.state = LssState::Configuration;
                false
            }
            LssState::Waiting => {
                self.enter_waiting();
                was == LssState::Configuration && !ctx.configured() && (1..=127).contains(&self.pending_node_id(ctx))
            }
        }
    }

    /// Handles a frame on 7E5h. Requests the LSS state does not allow, and malformed frames, are
    /// ignored without an answer (the manuals' Table 10; CiA 305 has no error answer for them).
    /// During an activate bit timing only switch state global, which has no answer, is handled.
    ///
    /// The request is read straight from its bytes, as [`Request::parse`] reads it (its tests
    /// document the messages): no request value is built and matched again.
    pub fn on_frame(&mut self, ctx: &mut Context, frame: &Frame, now: Instant) -> LssEvent {
        if !self.enabled {
            return LssEvent::None;
        }
        let Some(d) = exactly_8(frame.payload()) else {
            return LssEvent::None;
        };
        let (c, value) = (d[0], u32_le(d, 1));
        if c == cs::SWITCH_STATE_GLOBAL {
            let to = match d[1] {
                0 => LssState::Waiting,
                1 => LssState::Configuration,
                _ => return LssEvent::None,
            };
            let activate = self.switch_global(ctx, to);
            return match self.switch.as_mut() {
                // During a bit-rate switch the activation waits for its end.
                Some(s) => {
                    s.activate |= activate;
                    LssEvent::None
                }
                None if activate => LssEvent::ResetCommunication,
                None => LssEvent::None,
            };
        }
        if self.switching() {
            return LssEvent::None;
        }
        let configuration = self.state == LssState::Configuration;
        match c {
            0x40..=0x43 if !configuration => {
                if let Some(part) = Part::from_index(c - cs::SWITCH_STATE_SELECTIVE) {
                    self.switch_selective(ctx, part, value);
                }
            }
            0x46..=0x4B => {
                if let Some(step) = IdentifyStep::from_index(c - cs::IDENTIFY_REMOTE_SLAVE) {
                    self.identify(ctx, step, value);
                }
            }
            cs::IDENTIFY_NON_CONFIGURED_REMOTE_SLAVE if self.non_configured(ctx) => {
                self.send(ctx, cs::IDENTIFY_NON_CONFIGURED_SLAVE, 0)
            }
            cs::FASTSCAN if !configuration => {
                let bit_checked = d[5];
                if bit_checked > 31 && bit_checked != FASTSCAN_RESET {
                    return LssEvent::None;
                }
                if let (Some(sub), Some(next)) = (Part::from_index(d[6]), Part::from_index(d[7])) {
                    self.fastscan(ctx, value, bit_checked, sub, next);
                }
            }
            cs::CONFIGURE_NODE_ID if configuration => {
                // 1..127, or FFh to make the node unconfigured (CiA 305).
                let id = d[1];
                let error = if (1..=127).contains(&id) || id == UNCONFIGURED {
                    let pos = self.pending_node_id;
                    ctx.od.set(pos, id as u32);
                    error::OK
                } else {
                    error::OUT_OF_RANGE
                };
                self.send(ctx, cs::CONFIGURE_NODE_ID, error as u32);
            }
            cs::CONFIGURE_BIT_TIMING if configuration => {
                // Only the CiA table (selector 0), and only the rates the device codes: index 5
                // (100 kbit/s, "reserved"), 8 (10 kbit/s) and 9 (automatic) have no code.
                let code = match d[1] {
                    0 => Bitrate::from_cia_index(d[2]).and_then(|rate| code_of(self.codes, rate)),
                    _ => None,
                };
                let error = match code {
                    Some(code) => {
                        let pos = self.pending_bitrate;
                        ctx.od.set(pos, code);
                        self.configured_rate = Some(code);
                        error::OK
                    }
                    None => error::OUT_OF_RANGE,
                };
                self.send(ctx, cs::CONFIGURE_BIT_TIMING, error as u32);
            }
            // Not while a store waits for the shell: its answer would fall into the silence.
            cs::ACTIVATE_BIT_TIMING if configuration && !ctx.storage.saving() => {
                let delay = Duration::from_millis(u16::from_le_bytes([d[1], d[2]]) as u64);
                self.switch = Some(Switch { due: now + delay, delay, adopted: false, activate: false });
                // The node leaves the bus until its boot-up on the new rate: no service sends.
                return LssEvent::Switching;
            }
            // A repeated request gets the one answer when the shell is done.
            cs::STORE_CONFIGURATION if configuration && !self.storing => {
                if ctx.request_store(GroupMask::LSS).is_ok() {
                    self.storing = true;
                } else {
                    // A 1010h save is under way: this store cannot start.
                    self.send(ctx, cs::STORE_CONFIGURATION, error::STORE_FAILED as u32);
                }
            }
            0x5A..=0x5D if configuration => {
                if let Some(part) = Part::from_index(c - cs::INQUIRE_IDENTITY) {
                    let value = part_value(&ctx.od, part);
                    self.send(ctx, c, value);
                }
            }
            cs::INQUIRE_NODE_ID if configuration => {
                let id = ctx.node_id;
                self.send(ctx, cs::INQUIRE_NODE_ID, id as u32);
            }
            // Selective and Fastscan in configuration, configuration services in waiting, the
            // refused cases above, and unknown commands.
            _ => {}
        }
        LssEvent::None
    }

    /// Switch state selective: the four parts must come in order and all match (CiA 305).
    fn switch_selective(&mut self, ctx: &mut Context, part: Part, value: u32) {
        let lss = &mut *self;
        let expected = if part == Part::Vendor { 0 } else { lss.selective };
        if part.index() != expected || part_value(&ctx.od, part) != value {
            lss.selective = 0;
            return;
        }
        if part == Part::Serial {
            lss.selective = 0;
            lss.state = LssState::Configuration;
            self.send(ctx, cs::SWITCH_STATE_SELECTIVE_RESPONSE, 0);
        } else {
            lss.selective = expected + 1;
        }
    }

    /// Identify remote slave: vendor and product equal, revision and serial within the bounds,
    /// six steps in order; a slave that passed all answers 4Fh (CiA 305).
    fn identify(&mut self, ctx: &mut Context, step: IdentifyStep, value: u32) {
        let expected = if step == IdentifyStep::Vendor { 0 } else { self.identify };
        if step.index() != expected || !step.passes(part_value(&ctx.od, step.part()), value) {
            self.identify = 0;
            return;
        }
        if step == IdentifyStep::SerialHigh {
            self.identify = 0;
            self.send(ctx, cs::IDENTIFY_SLAVE, 0);
        } else {
            self.identify = expected + 1;
        }
    }

    /// LSS Fastscan (CiA 305): only non-configured slaves in LSS waiting take part. BitChecked
    /// 80h resets LSSPos and is confirmed by every such slave. Otherwise a slave whose LSSPos is
    /// LSSSub and whose address part equals IDNumber in bits 31..BitChecked confirms and moves
    /// LSSPos to LSSNext; after the last bit (BitChecked 0) of the last part (LSSNext < LSSSub)
    /// it enters LSS configuration.
    fn fastscan(&mut self, ctx: &mut Context, id: u32, bit_checked: u8, sub: Part, next: Part) {
        if !self.non_configured(ctx) {
            return;
        }
        if bit_checked == FASTSCAN_RESET {
            self.fastscan_pos = Part::Vendor;
        } else {
            // `parse` guarantees bit_checked <= 31.
            let mask = u32::MAX << bit_checked;
            if self.fastscan_pos != sub || (part_value(&ctx.od, sub) ^ id) & mask != 0 {
                return;
            }
            self.fastscan_pos = next;
            if bit_checked == 0 && next.index() < sub.index() {
                self.state = LssState::Configuration;
            }
        }
        self.send(ctx, cs::IDENTIFY_SLAVE, 0);
    }

    /// Runs the activate bit timing delays: after d1 the node switches to the pending rate
    /// ([`Output::SetBitrate`]); after d2 it asks for its boot-up on the new rate
    /// ([`LssEvent::BootUp`], or [`LssEvent::ResetCommunication`] for an unconfigured node
    /// switched to LSS waiting meanwhile).
    pub fn poll(&mut self, ctx: &mut Context, now: Instant) -> LssEvent {
        let Some(switch) = self.switch.as_mut() else {
            return LssEvent::None;
        };
        if !switch.adopted && now >= switch.due {
            switch.adopted = true;
            switch.due += switch.delay;
            self.configured_rate = None;
            let code = ctx.od.get(self.pending_bitrate);
            if let Some(rate) = rate_of(self.codes, code) {
                ctx.bitrate = rate;
                ctx.out.push(Output::SetBitrate(rate));
            }
        }
        match self.switch {
            Some(s) if s.adopted && now >= s.due => {
                self.switch = None;
                if s.activate {
                    LssEvent::ResetCommunication
                } else {
                    LssEvent::BootUp
                }
            }
            _ => LssEvent::None,
        }
    }

    /// Does the pending bit-rate entry hold a rate that configure bit timing set and activate
    /// bit timing has not applied yet? An NMT reset then leaves the bit rate alone: only
    /// activate bit timing or a power cycle (with the rate stored) applies it (CiA 305, the
    /// manuals' 4.6.2.2 / 5.6.2.2; issue 13 point 9, D-LSS-15). Once the entry holds another
    /// code (a 5F0Ah.02 write, a restore) the reset applies that one, as the manual's "after
    /// re-initialization" says.
    pub fn rate_awaits_activation(&self, od: &Od) -> bool {
        self.configured_rate.is_some_and(|code| code == od.get(self.pending_bitrate))
    }

    /// An SDO client wrote the pending bit-rate entry (5F0Ah.02): that value is the one the
    /// next reset adopts, even if it equals the code LSS configured (D-LSS-14, D-LSS-15).
    pub fn rate_written(&mut self) {
        self.configured_rate = None;
    }

    /// When the next LSS delay ends.
    pub fn next_deadline(&self) -> Option<Instant> {
        self.switch.map(|s| s.due)
    }

    /// After an NMT reset (or the one LSS asked for): the slave starts again in LSS waiting
    /// (CiA 305, and the manuals: "After starting, the device will be in the LSS waiting state").
    /// A store under way still gets its answer.
    pub fn reset(&mut self) {
        self.enter_waiting();
        self.switch = None;
    }

    /// The shell finished a store. Returns false if LSS did not ask for it (the SDO server did);
    /// otherwise answers store configuration: 00h on success, 02h "error occurred during storing".
    pub fn store_done(&mut self, ctx: &mut Context, ok: bool) -> bool {
        if !self.storing {
            return false;
        }
        self.storing = false;
        let error = if ok { error::OK } else { error::STORE_FAILED };
        self.send(ctx, cs::STORE_CONFIGURATION, error as u32);
        true
    }
}

/// A part's value in the dictionary (1018h sub 1..4); 0 if not declared.
fn part_value(od: &Od, part: Part) -> u32 {
    od.value(0x1018, part.index() + 1).unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bitrate::SIKO_CODES;
    use crate::devices::sgh10;
    use crate::storage::{self, Loaded};

    /// The SGH10's dictionary in a context (node-ID 1, serial 1234) and its LSS slave: no
    /// device, no node.
    fn slave() -> (Context, Lss) {
        let (od, storage, node_id) = storage::power_on(sgh10::TABLE, &Loaded::Blank, 1);
        let mut ctx = Context::new(od, storage, node_id, Bitrate::K500);
        ctx.od.set_value(0x1018, 4, 1234);
        let lss = Lss::new(&ctx.od, true, SIKO_CODES);
        (ctx, lss)
    }

    fn send(lss: &mut Lss, ctx: &mut Context, request: Request) -> Option<Response> {
        let event = lss.on_frame(ctx, &Frame::std(RX_ID, &request.emit()), Instant::ZERO);
        assert_eq!(event, LssEvent::None);
        match ctx.out.pop() {
            Some(Output::Frame(f)) => {
                assert_eq!(f.id, crate::frame::CanId::Std(TX_ID));
                Response::parse(f.payload())
            }
            _ => None,
        }
    }

    #[test]
    fn selective_switch_then_configure_and_inquire() {
        let (mut c, mut lss) = slave();
        let address = [Part::Vendor, Part::Product, Part::Revision, Part::Serial].map(|p| part_value(&c.od, p));
        assert_eq!(address[3], 1234);
        // Configuration services are ignored in LSS waiting.
        assert_eq!(send(&mut lss, &mut c, Request::ConfigureNodeId(5)), None);
        for (part, value) in Part::ALL.into_iter().zip(address) {
            let answer = send(&mut lss, &mut c, Request::SwitchStateSelective { part, value });
            assert_eq!(answer, (part == Part::Serial).then_some(Response::SwitchStateSelective));
        }
        assert_eq!(lss.state(), LssState::Configuration);
        assert_eq!(
            send(&mut lss, &mut c, Request::ConfigureNodeId(0)),
            Some(Response::ConfigureNodeId { error: error::OUT_OF_RANGE, spec: 0 })
        );
        assert_eq!(
            send(&mut lss, &mut c, Request::ConfigureNodeId(5)),
            Some(Response::ConfigureNodeId { error: 0, spec: 0 })
        );
        assert_eq!(storage::pending(&c.od, CoreHook::PendingNodeId), Some(5));
        assert_eq!(c.node_id, 1, "active only after a reset");
        assert_eq!(send(&mut lss, &mut c, Request::InquireNodeId), Some(Response::InquireNodeId(1)));
        assert_eq!(
            send(&mut lss, &mut c, Request::InquireIdentity(Part::Serial)),
            Some(Response::InquireIdentity { part: Part::Serial, value: 1234 })
        );
    }

    #[test]
    fn store_configuration_answers_when_the_shell_is_done() {
        let (mut c, mut lss) = slave();
        send(&mut lss, &mut c, Request::SwitchStateGlobal(LssState::Configuration));
        assert_eq!(send(&mut lss, &mut c, Request::StoreConfiguration), None);
        assert!(c.storage.saving());
        // The Output::Store was queued before any answer.
        assert!(lss.store_done(&mut c, false));
        assert_eq!(
            c.out.pop().and_then(|o| match o {
                Output::Frame(f) => Response::parse(f.payload()),
                _ => None,
            }),
            Some(Response::StoreConfiguration { error: error::STORE_FAILED, spec: 0 })
        );
        assert!(!lss.store_done(&mut c, true), "nothing asked: the SDO server's store");
    }

    /// The slave as it read requests before (through [`Request::parse`], then a match on the
    /// request): the reference `on_frame` must agree with.
    fn reference(lss: &mut Lss, ctx: &mut Context, frame: &Frame, now: Instant) -> LssEvent {
        if !lss.enabled {
            return LssEvent::None;
        }
        let Some(request) = Request::parse(frame.payload()) else {
            return LssEvent::None;
        };
        if let Request::SwitchStateGlobal(to) = request {
            let activate = lss.switch_global(ctx, to);
            return match lss.switch.as_mut() {
                // During a bit-rate switch the activation waits for its end.
                Some(s) => {
                    s.activate |= activate;
                    LssEvent::None
                }
                None if activate => LssEvent::ResetCommunication,
                None => LssEvent::None,
            };
        }
        if lss.switching() {
            return LssEvent::None;
        }
        match (lss.state, request) {
            (LssState::Waiting, Request::SwitchStateSelective { part, value }) => {
                lss.switch_selective(ctx, part, value)
            }
            (_, Request::IdentifyRemoteSlave { step, value }) => lss.identify(ctx, step, value),
            (_, Request::IdentifyNonConfiguredRemoteSlave) if lss.non_configured(ctx) => {
                lss.send(ctx, cs::IDENTIFY_NON_CONFIGURED_SLAVE, 0)
            }
            (LssState::Waiting, Request::Fastscan { id, bit_checked, sub, next }) => {
                lss.fastscan(ctx, id, bit_checked, sub, next)
            }
            (LssState::Configuration, Request::ConfigureNodeId(id)) => {
                // 1..127, or FFh to make the node unconfigured (CiA 305).
                let error = if (1..=127).contains(&id) || id == UNCONFIGURED {
                    let pos = lss.pending_node_id;
                    ctx.od.set(pos, id as u32);
                    error::OK
                } else {
                    error::OUT_OF_RANGE
                };
                lss.send(ctx, cs::CONFIGURE_NODE_ID, error as u32);
            }
            (LssState::Configuration, Request::ConfigureBitTiming { selector, index }) => {
                // Only the CiA table (selector 0), and only the rates the device codes: index 5
                // (100 kbit/s, "reserved"), 8 (10 kbit/s) and 9 (automatic) have no code.
                let code = match selector {
                    0 => Bitrate::from_cia_index(index).and_then(|rate| code_of(lss.codes, rate)),
                    _ => None,
                };
                let error = match code {
                    Some(code) => {
                        let pos = lss.pending_bitrate;
                        ctx.od.set(pos, code);
                        lss.configured_rate = Some(code);
                        error::OK
                    }
                    None => error::OUT_OF_RANGE,
                };
                lss.send(ctx, cs::CONFIGURE_BIT_TIMING, error as u32);
            }
            // Not while a store waits for the shell: its answer would fall into the silence.
            (LssState::Configuration, Request::ActivateBitTiming { delay_ms }) if !ctx.storage.saving() => {
                let delay = Duration::from_millis(delay_ms as u64);
                lss.switch = Some(Switch { due: now + delay, delay, adopted: false, activate: false });
                // The node leaves the bus until its boot-up on the new rate: no service sends.
                return LssEvent::Switching;
            }
            // A repeated request gets the one answer when the shell is done.
            (LssState::Configuration, Request::StoreConfiguration) if !lss.storing => {
                if ctx.request_store(GroupMask::LSS).is_ok() {
                    lss.storing = true;
                } else {
                    // A 1010h save is under way: this store cannot start.
                    lss.send(ctx, cs::STORE_CONFIGURATION, error::STORE_FAILED as u32);
                }
            }
            (LssState::Configuration, Request::InquireIdentity(part)) => {
                let value = part_value(&ctx.od, part);
                lss.send(ctx, cs::INQUIRE_IDENTITY + part.index(), value);
            }
            (LssState::Configuration, Request::InquireNodeId) => {
                let id = ctx.node_id;
                lss.send(ctx, cs::INQUIRE_NODE_ID, id as u32);
            }
            // Selective and Fastscan in configuration, configuration services in waiting, and the
            // refused cases above.
            _ => {}
        }
        LssEvent::None
    }

    proptest::proptest! {
        /// Random frames (mostly well-formed LSS commands, in random states) get the same
        /// answers, events, pending values and LSS state from `on_frame` as from the
        /// reference.
        #[test]
        fn on_frame_reads_requests_as_parse_does(
            frames in proptest::collection::vec(
                (proptest::sample::select(&[
                    0x04u8, 0x11, 0x13, 0x15, 0x17, 0x40, 0x41, 0x42, 0x43, 0x46, 0x47, 0x48, 0x49, 0x4A,
                    0x4B, 0x4C, 0x51, 0x5A, 0x5B, 0x5C, 0x5D, 0x5E, 0x00, 0x44, 0x4F, 0x5F, 0xFF,
                ][..]), proptest::array::uniform7(proptest::prelude::any::<u8>()), 0u8..4, 7usize..=9),
                1..60,
            ),
            unconfigured in proptest::prelude::any::<bool>(),
        ) {
            let (mut c1, mut l1) = slave();
            let (mut c2, mut l2) = slave();
            if unconfigured {
                // No node-ID, neither active nor pending: Fastscan and 4Ch answer.
                for (c, l) in [(&mut c1, &l1), (&mut c2, &l2)] {
                    c.node_id = UNCONFIGURED;
                    c.od.set(l.pending_node_id, UNCONFIGURED as u32);
                }
            }
            for (i, (cs, mut body, small, len)) in frames.into_iter().enumerate() {
                // Small values where they select something: switch mode, parts, bit numbers.
                if cs == 0x04 { body[0] = small % 3; }
                if cs == 0x51 { body[4] = [0, 31, 32, 0x80][small as usize]; body[5] %= 5; body[6] %= 5; }
                if cs == 0x13 { body[0] = small % 2; body[1] %= 10; }
                if cs == 0x15 { body[1] = 0; }
                let mut data = [cs, body[0], body[1], body[2], body[3], body[4], body[5], body[6], 0];
                if small == 3 && cs == 0x40 { data[1..5].copy_from_slice(&part_value(&c1.od, Part::Vendor).to_le_bytes()); }
                let frame = Frame::std(RX_ID, &data[..len]);
                let now = Instant::from_millis(i as u64 * 7);
                let e1 = l1.on_frame(&mut c1, &frame, now);
                let e2 = reference(&mut l2, &mut c2, &frame, now);
                proptest::prop_assert_eq!(e1, e2);
                proptest::prop_assert_eq!(l1.poll(&mut c1, now), l2.poll(&mut c2, now));
                if c1.storage.saving() {
                    proptest::prop_assert_eq!(l1.store_done(&mut c1, true), l2.store_done(&mut c2, true));
                    c1.storage.finish_save(&c1.od, c1.node_id, true);
                    c2.storage.finish_save(&c2.od, c2.node_id, true);
                }
                loop {
                    let (o1, o2) = (c1.out.pop(), c2.out.pop());
                    proptest::prop_assert_eq!(o1, o2);
                    if o1.is_none() { break; }
                }
                proptest::prop_assert_eq!(l1.state(), l2.state());
                proptest::prop_assert_eq!(l1.next_deadline(), l2.next_deadline());
                proptest::prop_assert_eq!(c1.od.get(l1.pending_node_id), c2.od.get(l2.pending_node_id));
                proptest::prop_assert_eq!(c1.od.get(l1.pending_bitrate), c2.od.get(l2.pending_bitrate));
            }
        }
    }
}
