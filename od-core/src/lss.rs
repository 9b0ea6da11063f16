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
//! (5F0Ah.01/.02 on the SIKO encoders); an NMT reset activates them (`node.rs`), and so does
//! switching an unconfigured node back to LSS waiting (CiA 305). Activate bit timing switches
//! to the pending bit rate after delay d1 and, after d2, restarts communication on it with a
//! boot-up (the manuals). The bit-rate code the pending entry holds is the device's
//! ([`crate::node::Device::bitrate_codes`]), not the CiA 305 table index.
//!
//! Frames are parsed into [`Request`]s and answered with [`Response`]s, the smoltcp way:
//! `parse` never panics and rejects whatever is not a well-formed 8-byte LSS frame; `emit`
//! builds the frame back. Every decision the manuals leave open is in `docs/decisions.md`,
//! section "LSS".

use crate::bitrate::Bitrate;
use crate::frame::{CanId, Frame};
use crate::nmt::NmtState;
use crate::node::{Core, Output};
use crate::od::{CoreHook, GroupMask, Od};
use crate::storage;
use crate::time::{Duration, Instant};

/// LSS master-to-slave identifier.
pub const RX_ID: u16 = 0x7E5;
/// LSS slave-to-master identifier.
pub const TX_ID: u16 = 0x7E4;

/// The node-ID of a node that has none ("not configured", CiA 305): it takes part in LSS only.
pub const UNCONFIGURED: u8 = 0xFF;

/// Command specifiers (byte 0 of every LSS frame).
pub mod cs {
    /// Switch state global.
    pub const SWITCH_STATE_GLOBAL: u8 = 0x04;
    /// Configure node-ID.
    pub const CONFIGURE_NODE_ID: u8 = 0x11;
    /// Configure bit timing parameters.
    pub const CONFIGURE_BIT_TIMING: u8 = 0x13;
    /// Activate bit timing parameters.
    pub const ACTIVATE_BIT_TIMING: u8 = 0x15;
    /// Store configuration.
    pub const STORE_CONFIGURATION: u8 = 0x17;
    /// Switch state selective, vendor-ID (41h, 42h, 43h: product code, revision, serial).
    pub const SWITCH_STATE_SELECTIVE: u8 = 0x40;
    /// Switch state selective response.
    pub const SWITCH_STATE_SELECTIVE_RESPONSE: u8 = 0x44;
    /// Identify remote slave, vendor-ID (47h..4Bh: product code, revision low/high, serial
    /// low/high).
    pub const IDENTIFY_REMOTE_SLAVE: u8 = 0x46;
    /// Identify non-configured remote slave.
    pub const IDENTIFY_NON_CONFIGURED_REMOTE_SLAVE: u8 = 0x4C;
    /// Identify slave (answer to identify remote slave and Fastscan).
    pub const IDENTIFY_SLAVE: u8 = 0x4F;
    /// Identify non-configured slave (answer to 4Ch).
    pub const IDENTIFY_NON_CONFIGURED_SLAVE: u8 = 0x50;
    /// LSS Fastscan.
    pub const FASTSCAN: u8 = 0x51;
    /// Inquire vendor-ID (5Bh, 5Ch, 5Dh: product code, revision, serial).
    pub const INQUIRE_IDENTITY: u8 = 0x5A;
    /// Inquire node-ID.
    pub const INQUIRE_NODE_ID: u8 = 0x5E;
}

/// Error codes of the configure and store answers (byte 1).
pub mod error {
    /// Success.
    pub const OK: u8 = 0x00;
    /// Configure node-ID: "no valid node-ID"; configure bit timing: "no valid baud rate".
    pub const OUT_OF_RANGE: u8 = 0x01;
    /// Store configuration: "error occurred during storing".
    pub const STORE_FAILED: u8 = 0x02;
}

/// Fastscan BitChecked value that resets the slaves' Fastscan state (and that every
/// non-configured slave in LSS waiting confirms).
pub const FASTSCAN_RESET: u8 = 0x80;

/// The LSS slave's state (CiA 305).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum LssState {
    /// LSS waiting: after start-up; only the switch and identify services.
    Waiting,
    /// LSS configuration: node-ID, bit timing, store and inquire services.
    Configuration,
}

/// A part of the LSS address: 1018h sub 1..4. Also Fastscan's LSSSub / LSSNext (0..3).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Part {
    /// Vendor-ID, 1018h.01.
    Vendor,
    /// Product code, 1018h.02.
    Product,
    /// Revision number, 1018h.03.
    Revision,
    /// Serial number, 1018h.04.
    Serial,
}

impl Part {
    /// Every part, in LSS address order.
    pub const ALL: [Part; 4] = [Part::Vendor, Part::Product, Part::Revision, Part::Serial];

    /// 0 (vendor) ..= 3 (serial): the offset of the part's command specifiers and Fastscan's
    /// LSSSub value.
    pub const fn index(self) -> u8 {
        self as u8
    }

    /// The part at `index` (0..=3).
    pub const fn from_index(index: u8) -> Option<Part> {
        match index {
            0 => Some(Part::Vendor),
            1 => Some(Part::Product),
            2 => Some(Part::Revision),
            3 => Some(Part::Serial),
            _ => None,
        }
    }

    /// The part's value in the dictionary (1018h sub 1..4); 0 if not declared.
    pub fn value(self, od: &Od) -> u32 {
        od.value(0x1018, self.index() + 1).unwrap_or(0)
    }
}

/// A step of identify remote slave (46h..4Bh), in the order a master sends them.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum IdentifyStep {
    /// 46h: vendor-ID.
    Vendor,
    /// 47h: product code.
    Product,
    /// 48h: lowest revision number.
    RevisionLow,
    /// 49h: highest revision number.
    RevisionHigh,
    /// 4Ah: lowest serial number.
    SerialLow,
    /// 4Bh: highest serial number; matching slaves answer 4Fh.
    SerialHigh,
}

impl IdentifyStep {
    /// The step at `index` (0 = 46h ..= 5 = 4Bh).
    pub const fn from_index(index: u8) -> Option<IdentifyStep> {
        match index {
            0 => Some(IdentifyStep::Vendor),
            1 => Some(IdentifyStep::Product),
            2 => Some(IdentifyStep::RevisionLow),
            3 => Some(IdentifyStep::RevisionHigh),
            4 => Some(IdentifyStep::SerialLow),
            5 => Some(IdentifyStep::SerialHigh),
            _ => None,
        }
    }

    /// 0 (46h) ..= 5 (4Bh).
    pub const fn index(self) -> u8 {
        self as u8
    }

    /// Does the slave whose LSS address is `address` pass this step for `value`?
    fn matches(self, address: &[u32; 4], value: u32) -> bool {
        match self {
            IdentifyStep::Vendor => address[0] == value,
            IdentifyStep::Product => address[1] == value,
            IdentifyStep::RevisionLow => address[2] >= value,
            IdentifyStep::RevisionHigh => address[2] <= value,
            IdentifyStep::SerialLow => address[3] >= value,
            IdentifyStep::SerialHigh => address[3] <= value,
        }
    }
}

/// A request from the LSS master (a frame on 7E5h).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Request {
    /// 04h: switch every slave to this state.
    SwitchStateGlobal(LssState),
    /// 40h..43h: switch state selective, one part of the LSS address.
    SwitchStateSelective {
        /// Which part.
        part: Part,
        /// Its value.
        value: u32,
    },
    /// 11h: configure node-ID (pending).
    ConfigureNodeId(u8),
    /// 13h: configure bit timing (pending).
    ConfigureBitTiming {
        /// Table selector: 0 = CiA 301 table, 80h..FEh manufacturer tables.
        selector: u8,
        /// Table index.
        index: u8,
    },
    /// 15h: activate bit timing after two switch delays.
    ActivateBitTiming {
        /// Switch delay d1 = d2, in milliseconds.
        delay_ms: u16,
    },
    /// 17h: store configuration.
    StoreConfiguration,
    /// 46h..4Bh: identify remote slave, one step.
    IdentifyRemoteSlave {
        /// Which step.
        step: IdentifyStep,
        /// Its value.
        value: u32,
    },
    /// 4Ch: identify non-configured remote slave.
    IdentifyNonConfiguredRemoteSlave,
    /// 51h: LSS Fastscan.
    Fastscan {
        /// IDNumber: the bits of the LSS address part found so far.
        id: u32,
        /// BitChecked: 0..=31, the lowest bit compared, or [`FASTSCAN_RESET`].
        bit_checked: u8,
        /// LSSSub: the part compared.
        sub: Part,
        /// LSSNext: the part the next request compares.
        next: Part,
    },
    /// 5Ah..5Dh: inquire a part of the LSS address.
    InquireIdentity(Part),
    /// 5Eh: inquire the node-ID.
    InquireNodeId,
}

/// Reads the little-endian u32 in bytes 1..=4.
fn u32_at(data: &[u8; 8]) -> u32 {
    u32::from_le_bytes([data[1], data[2], data[3], data[4]])
}

/// An LSS frame: 8 data bytes on `id`, the rest reserved (00h).
fn lss_frame(id: u16, cs: u8, body: [u8; 7]) -> Frame {
    let mut data = [0u8; 8];
    data[0] = cs;
    data[1..].copy_from_slice(&body);
    Frame::std(id, &data)
}

/// Bytes 1..=7 holding `value` little-endian in bytes 1..=4.
fn u32_body(value: u32) -> [u8; 7] {
    let v = value.to_le_bytes();
    [v[0], v[1], v[2], v[3], 0, 0, 0]
}

/// The 8 data bytes of a well-formed LSS frame on `id`: data frame, DLC 8 (CiA 305; the
/// manuals: "A message consists always of 8 bytes").
fn lss_data(frame: &Frame, id: u16) -> Option<&[u8; 8]> {
    if frame.id != CanId::Std(id) || frame.rtr || frame.len != 8 {
        return None;
    }
    Some(&frame.data)
}

impl Request {
    /// Parses a frame on 7E5h. `None` for anything else: another identifier, a remote frame,
    /// a DLC other than 8, an unknown command specifier, a switch mode other than 0/1, or
    /// Fastscan fields out of range. Reserved bytes are not checked.
    pub fn parse(frame: &Frame) -> Option<Request> {
        let d = lss_data(frame, RX_ID)?;
        let value = u32_at(d);
        Some(match d[0] {
            cs::SWITCH_STATE_GLOBAL => Request::SwitchStateGlobal(match d[1] {
                0 => LssState::Waiting,
                1 => LssState::Configuration,
                _ => return None,
            }),
            c @ 0x40..=0x43 => Request::SwitchStateSelective { part: Part::from_index(c - 0x40)?, value },
            cs::CONFIGURE_NODE_ID => Request::ConfigureNodeId(d[1]),
            cs::CONFIGURE_BIT_TIMING => Request::ConfigureBitTiming { selector: d[1], index: d[2] },
            cs::ACTIVATE_BIT_TIMING => Request::ActivateBitTiming { delay_ms: u16::from_le_bytes([d[1], d[2]]) },
            cs::STORE_CONFIGURATION => Request::StoreConfiguration,
            c @ 0x46..=0x4B => Request::IdentifyRemoteSlave { step: IdentifyStep::from_index(c - 0x46)?, value },
            cs::IDENTIFY_NON_CONFIGURED_REMOTE_SLAVE => Request::IdentifyNonConfiguredRemoteSlave,
            cs::FASTSCAN => {
                let bit_checked = d[5];
                if bit_checked > 31 && bit_checked != FASTSCAN_RESET {
                    return None;
                }
                Request::Fastscan {
                    id: value,
                    bit_checked,
                    sub: Part::from_index(d[6])?,
                    next: Part::from_index(d[7])?,
                }
            }
            c @ 0x5A..=0x5D => Request::InquireIdentity(Part::from_index(c - 0x5A)?),
            cs::INQUIRE_NODE_ID => Request::InquireNodeId,
            _ => return None,
        })
    }

    /// The frame a master sends (reserved bytes 00h).
    pub fn emit(&self) -> Frame {
        let (c, body) = match *self {
            Request::SwitchStateGlobal(s) => {
                (cs::SWITCH_STATE_GLOBAL, [(s == LssState::Configuration) as u8, 0, 0, 0, 0, 0, 0])
            }
            Request::SwitchStateSelective { part, value } => {
                (cs::SWITCH_STATE_SELECTIVE + part.index(), u32_body(value))
            }
            Request::ConfigureNodeId(id) => (cs::CONFIGURE_NODE_ID, [id, 0, 0, 0, 0, 0, 0]),
            Request::ConfigureBitTiming { selector, index } => {
                (cs::CONFIGURE_BIT_TIMING, [selector, index, 0, 0, 0, 0, 0])
            }
            Request::ActivateBitTiming { delay_ms } => {
                let d = delay_ms.to_le_bytes();
                (cs::ACTIVATE_BIT_TIMING, [d[0], d[1], 0, 0, 0, 0, 0])
            }
            Request::StoreConfiguration => (cs::STORE_CONFIGURATION, [0; 7]),
            Request::IdentifyRemoteSlave { step, value } => (cs::IDENTIFY_REMOTE_SLAVE + step.index(), u32_body(value)),
            Request::IdentifyNonConfiguredRemoteSlave => (cs::IDENTIFY_NON_CONFIGURED_REMOTE_SLAVE, [0; 7]),
            Request::Fastscan { id, bit_checked, sub, next } => {
                let mut body = u32_body(id);
                body[4] = bit_checked;
                body[5] = sub.index();
                body[6] = next.index();
                (cs::FASTSCAN, body)
            }
            Request::InquireIdentity(part) => (cs::INQUIRE_IDENTITY + part.index(), [0; 7]),
            Request::InquireNodeId => (cs::INQUIRE_NODE_ID, [0; 7]),
        };
        lss_frame(RX_ID, c, body)
    }
}

/// An answer of the LSS slave (a frame on 7E4h).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Response {
    /// 44h: selected by switch state selective, now in LSS configuration.
    SwitchStateSelective,
    /// 11h: configure node-ID result.
    ConfigureNodeId {
        /// Error code ([`error`]).
        error: u8,
        /// Implementation-specific error, non-zero only with error FFh.
        spec: u8,
    },
    /// 13h: configure bit timing result.
    ConfigureBitTiming {
        /// Error code ([`error`]).
        error: u8,
        /// Implementation-specific error, non-zero only with error FFh.
        spec: u8,
    },
    /// 17h: store configuration result.
    StoreConfiguration {
        /// Error code ([`error`]).
        error: u8,
        /// Implementation-specific error, non-zero only with error FFh.
        spec: u8,
    },
    /// 4Fh: identify slave (answer to identify remote slave and to Fastscan).
    IdentifySlave,
    /// 50h: identify non-configured slave.
    IdentifyNonConfiguredSlave,
    /// 5Ah..5Dh: a part of the LSS address.
    InquireIdentity {
        /// Which part.
        part: Part,
        /// Its value.
        value: u32,
    },
    /// 5Eh: the active node-ID.
    InquireNodeId(u8),
}

impl Response {
    /// The frame the slave sends (reserved bytes 00h).
    pub fn emit(&self) -> Frame {
        let (c, body) = match *self {
            Response::SwitchStateSelective => (cs::SWITCH_STATE_SELECTIVE_RESPONSE, [0; 7]),
            Response::ConfigureNodeId { error, spec } => (cs::CONFIGURE_NODE_ID, [error, spec, 0, 0, 0, 0, 0]),
            Response::ConfigureBitTiming { error, spec } => (cs::CONFIGURE_BIT_TIMING, [error, spec, 0, 0, 0, 0, 0]),
            Response::StoreConfiguration { error, spec } => (cs::STORE_CONFIGURATION, [error, spec, 0, 0, 0, 0, 0]),
            Response::IdentifySlave => (cs::IDENTIFY_SLAVE, [0; 7]),
            Response::IdentifyNonConfiguredSlave => (cs::IDENTIFY_NON_CONFIGURED_SLAVE, [0; 7]),
            Response::InquireIdentity { part, value } => (cs::INQUIRE_IDENTITY + part.index(), u32_body(value)),
            Response::InquireNodeId(id) => (cs::INQUIRE_NODE_ID, [id, 0, 0, 0, 0, 0, 0]),
        };
        lss_frame(TX_ID, c, body)
    }

    /// Parses a frame on 7E4h (what a master reads); `None` for anything else.
    pub fn parse(frame: &Frame) -> Option<Response> {
        let d = lss_data(frame, TX_ID)?;
        Some(match d[0] {
            cs::SWITCH_STATE_SELECTIVE_RESPONSE => Response::SwitchStateSelective,
            cs::CONFIGURE_NODE_ID => Response::ConfigureNodeId { error: d[1], spec: d[2] },
            cs::CONFIGURE_BIT_TIMING => Response::ConfigureBitTiming { error: d[1], spec: d[2] },
            cs::STORE_CONFIGURATION => Response::StoreConfiguration { error: d[1], spec: d[2] },
            cs::IDENTIFY_SLAVE => Response::IdentifySlave,
            cs::IDENTIFY_NON_CONFIGURED_SLAVE => Response::IdentifyNonConfiguredSlave,
            c @ 0x5A..=0x5D => Response::InquireIdentity { part: Part::from_index(c - 0x5A)?, value: u32_at(d) },
            cs::INQUIRE_NODE_ID => Response::InquireNodeId(d[1]),
            _ => return None,
        })
    }
}

/// What the node must do after an LSS frame or tick.
#[must_use]
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum LssEvent {
    /// Nothing beyond the outputs already queued.
    None,
    /// Reset communication (NMT 82h semantics: the pending node-ID and bit rate become
    /// active, boot-up follows): an unconfigured node got a node-ID and was switched back to
    /// LSS waiting.
    ResetCommunication,
    /// An activate bit timing has run its two delays: communication restarts on the new rate
    /// (NMT INITIALISATION, then the boot-up message) with the active node-ID and every
    /// parameter kept.
    BootUp,
}

/// An activate bit timing under way: the rate switches at `adopt_at`, the boot-up goes out
/// at `boot_at`; the node sends nothing meanwhile.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
struct Switch {
    adopt_at: Instant,
    boot_at: Instant,
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

/// The pending node-ID (what the next reset activates).
fn pending_node_id(core: &Core) -> u8 {
    core.od.get(core.lss.pending_node_id) as u8
}

/// Does the node have no valid node-ID, neither active nor pending (CiA 305
/// "non-configured")? Only such a node takes part in Fastscan and answers 4Ch.
fn non_configured(core: &Core) -> bool {
    !core.configured() && !(1..=127).contains(&pending_node_id(core))
}

/// The LSS address: 1018h sub 1..4.
fn address(od: &Od) -> [u32; 4] {
    Part::ALL.map(|p| p.value(od))
}

fn send(core: &mut Core, response: Response) {
    core.out.send(response.emit());
}

/// Switch state global. True when the node must now activate its pending node-ID: CiA 305
/// has a node without a node-ID that got one activate it on its own when switched back to
/// waiting (no NMT command can reach it); a configured node waits for NMT reset communication.
fn switch_global(core: &mut Core, to: LssState) -> bool {
    let was = core.lss.state;
    match to {
        LssState::Configuration => {
            core.lss.state = LssState::Configuration;
            false
        }
        LssState::Waiting => {
            core.lss.enter_waiting();
            was == LssState::Configuration && !core.configured() && (1..=127).contains(&pending_node_id(core))
        }
    }
}

/// Handles a frame on 7E5h. Requests the LSS state does not allow, and malformed frames, are
/// ignored without an answer (the manuals' Table 10; CiA 305 has no error answer for them).
/// During an activate bit timing only switch state global, which has no answer, is handled.
pub fn on_frame(core: &mut Core, frame: &Frame, now: Instant) -> LssEvent {
    if !core.lss.enabled {
        return LssEvent::None;
    }
    let Some(request) = Request::parse(frame) else {
        return LssEvent::None;
    };
    if let Request::SwitchStateGlobal(to) = request {
        let activate = switch_global(core, to);
        return match core.lss.switch.as_mut() {
            // During a bit-rate switch the activation waits for its end.
            Some(s) => {
                s.activate |= activate;
                LssEvent::None
            }
            None if activate => LssEvent::ResetCommunication,
            None => LssEvent::None,
        };
    }
    if core.lss.switching() {
        return LssEvent::None;
    }
    match (core.lss.state, request) {
        (LssState::Waiting, Request::SwitchStateSelective { part, value }) => switch_selective(core, part, value),
        (_, Request::IdentifyRemoteSlave { step, value }) => identify(core, step, value),
        (_, Request::IdentifyNonConfiguredRemoteSlave) if non_configured(core) => {
            send(core, Response::IdentifyNonConfiguredSlave)
        }
        (LssState::Waiting, Request::Fastscan { id, bit_checked, sub, next }) => {
            fastscan(core, id, bit_checked, sub, next)
        }
        (LssState::Configuration, Request::ConfigureNodeId(id)) => {
            // 1..127, or FFh to make the node unconfigured (CiA 305).
            let error = if (1..=127).contains(&id) || id == UNCONFIGURED {
                let pos = core.lss.pending_node_id;
                core.od.set(pos, id as u32);
                error::OK
            } else {
                error::OUT_OF_RANGE
            };
            send(core, Response::ConfigureNodeId { error, spec: 0 });
        }
        (LssState::Configuration, Request::ConfigureBitTiming { selector, index }) => {
            // Only the CiA table (selector 0), and only the rates the device codes: index 5
            // (100 kbit/s, "reserved"), 8 (10 kbit/s) and 9 (automatic) have no code.
            let code = match selector {
                0 => Bitrate::from_cia_index(index).and_then(|rate| code_of(core.lss.codes, rate)),
                _ => None,
            };
            let error = match code {
                Some(code) => {
                    let pos = core.lss.pending_bitrate;
                    core.od.set(pos, code);
                    error::OK
                }
                None => error::OUT_OF_RANGE,
            };
            send(core, Response::ConfigureBitTiming { error, spec: 0 });
        }
        // Not while a store waits for the shell: its answer would fall into the silence.
        (LssState::Configuration, Request::ActivateBitTiming { delay_ms }) if !core.storage.saving() => {
            let delay = Duration::from_millis(delay_ms as u64);
            core.lss.switch =
                Some(Switch { adopt_at: now + delay, boot_at: now + delay.times(2), adopted: false, activate: false });
            // The node leaves the bus until its boot-up on the new rate: no service sends.
            core.nmt = NmtState::Initialising;
        }
        // A repeated request gets the one answer when the shell is done.
        (LssState::Configuration, Request::StoreConfiguration) if !core.lss.storing => {
            if storage::request(core, GroupMask::LSS).is_ok() {
                core.lss.storing = true;
            } else {
                // A 1010h save is under way: this store cannot start.
                send(core, Response::StoreConfiguration { error: error::STORE_FAILED, spec: 0 });
            }
        }
        (LssState::Configuration, Request::InquireIdentity(part)) => {
            let value = part.value(&core.od);
            send(core, Response::InquireIdentity { part, value });
        }
        (LssState::Configuration, Request::InquireNodeId) => {
            let id = core.node_id;
            send(core, Response::InquireNodeId(id));
        }
        // Selective and Fastscan in configuration, configuration services in waiting, and the
        // refused cases above.
        _ => {}
    }
    LssEvent::None
}

/// Switch state selective: the four parts must come in order and all match (CiA 305).
fn switch_selective(core: &mut Core, part: Part, value: u32) {
    let lss = &mut core.lss;
    let expected = if part == Part::Vendor { 0 } else { lss.selective };
    if part.index() != expected || part.value(&core.od) != value {
        lss.selective = 0;
        return;
    }
    if part == Part::Serial {
        lss.selective = 0;
        lss.state = LssState::Configuration;
        send(core, Response::SwitchStateSelective);
    } else {
        lss.selective = expected + 1;
    }
}

/// Identify remote slave: vendor and product equal, revision and serial within the bounds,
/// six steps in order; a slave that passed all answers 4Fh (CiA 305).
fn identify(core: &mut Core, step: IdentifyStep, value: u32) {
    let expected = if step == IdentifyStep::Vendor { 0 } else { core.lss.identify };
    if step.index() != expected || !step.matches(&address(&core.od), value) {
        core.lss.identify = 0;
        return;
    }
    if step == IdentifyStep::SerialHigh {
        core.lss.identify = 0;
        send(core, Response::IdentifySlave);
    } else {
        core.lss.identify = expected + 1;
    }
}

/// LSS Fastscan (CiA 305): only non-configured slaves in LSS waiting take part. BitChecked
/// 80h resets LSSPos and is confirmed by every such slave. Otherwise a slave whose LSSPos is
/// LSSSub and whose address part equals IDNumber in bits 31..BitChecked confirms and moves
/// LSSPos to LSSNext; after the last bit (BitChecked 0) of the last part (LSSNext < LSSSub)
/// it enters LSS configuration.
fn fastscan(core: &mut Core, id: u32, bit_checked: u8, sub: Part, next: Part) {
    if !non_configured(core) {
        return;
    }
    if bit_checked == FASTSCAN_RESET {
        core.lss.fastscan_pos = Part::Vendor;
    } else {
        // `parse` guarantees bit_checked <= 31.
        let mask = u32::MAX << bit_checked;
        if core.lss.fastscan_pos != sub || (sub.value(&core.od) ^ id) & mask != 0 {
            return;
        }
        core.lss.fastscan_pos = next;
        if bit_checked == 0 && next.index() < sub.index() {
            core.lss.state = LssState::Configuration;
        }
    }
    send(core, Response::IdentifySlave);
}

/// Runs the activate bit timing delays: after d1 the node switches to the pending rate
/// ([`Output::SetBitrate`]); after d2 it asks for its boot-up on the new rate
/// ([`LssEvent::BootUp`], or [`LssEvent::ResetCommunication`] for an unconfigured node
/// switched to LSS waiting meanwhile).
pub fn poll(core: &mut Core, now: Instant) -> LssEvent {
    let Some(switch) = core.lss.switch.as_mut() else {
        return LssEvent::None;
    };
    if !switch.adopted && now >= switch.adopt_at {
        switch.adopted = true;
        let code = core.od.get(core.lss.pending_bitrate);
        if let Some(rate) = rate_of(core.lss.codes, code) {
            core.bitrate = rate;
            core.out.push(Output::SetBitrate(rate));
        }
    }
    match core.lss.switch {
        Some(s) if s.adopted && now >= s.boot_at => {
            core.lss.switch = None;
            if s.activate {
                LssEvent::ResetCommunication
            } else {
                LssEvent::BootUp
            }
        }
        _ => LssEvent::None,
    }
}

/// When the next LSS delay ends.
pub fn next_deadline(core: &Core) -> Option<Instant> {
    core.lss.switch.map(|s| if s.adopted { s.boot_at } else { s.adopt_at })
}

/// After an NMT reset (or the one LSS asked for): the slave starts again in LSS waiting
/// (CiA 305, and the manuals: "After starting, the device will be in the LSS waiting state").
/// A store under way still gets its answer.
pub fn reset(core: &mut Core) {
    core.lss.enter_waiting();
    core.lss.switch = None;
}

/// The shell finished a store. Returns false if LSS did not ask for it (the SDO server did);
/// otherwise answers store configuration: 00h on success, 02h "error occurred during storing".
pub fn store_done(core: &mut Core, ok: bool) -> bool {
    if !core.lss.storing {
        return false;
    }
    core.lss.storing = false;
    let error = if ok { error::OK } else { error::STORE_FAILED };
    send(core, Response::StoreConfiguration { error, spec: 0 });
    true
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use proptest::prelude::*;
    // `prop_oneof!` with more than ten arms builds a Vec.
    use std::vec;

    fn frame(bytes: [u8; 8]) -> Frame {
        Frame::std(RX_ID, &bytes)
    }

    #[test]
    fn parses_the_manual_requests() {
        assert_eq!(
            Request::parse(&frame([4, 1, 0, 0, 0, 0, 0, 0])),
            Some(Request::SwitchStateGlobal(LssState::Configuration))
        );
        assert_eq!(
            Request::parse(&frame([4, 0, 0, 0, 0, 0, 0, 0])),
            Some(Request::SwitchStateGlobal(LssState::Waiting))
        );
        assert_eq!(
            Request::parse(&frame([0x40, 0x95, 0x01, 0, 0, 0, 0, 0])),
            Some(Request::SwitchStateSelective { part: Part::Vendor, value: 0x195 })
        );
        assert_eq!(
            Request::parse(&frame([0x43, 0x78, 0x56, 0x34, 0x12, 0, 0, 0])),
            Some(Request::SwitchStateSelective { part: Part::Serial, value: 0x1234_5678 })
        );
        assert_eq!(Request::parse(&frame([0x11, 5, 0, 0, 0, 0, 0, 0])), Some(Request::ConfigureNodeId(5)));
        assert_eq!(
            Request::parse(&frame([0x13, 0, 3, 0, 0, 0, 0, 0])),
            Some(Request::ConfigureBitTiming { selector: 0, index: 3 })
        );
        assert_eq!(
            Request::parse(&frame([0x15, 0xE8, 0x03, 0, 0, 0, 0, 0])),
            Some(Request::ActivateBitTiming { delay_ms: 1000 })
        );
        assert_eq!(Request::parse(&frame([0x17, 0, 0, 0, 0, 0, 0, 0])), Some(Request::StoreConfiguration));
        assert_eq!(Request::parse(&frame([0x5C, 0, 0, 0, 0, 0, 0, 0])), Some(Request::InquireIdentity(Part::Revision)));
        assert_eq!(Request::parse(&frame([0x5E, 0, 0, 0, 0, 0, 0, 0])), Some(Request::InquireNodeId));
        assert_eq!(
            Request::parse(&frame([0x51, 0, 0, 0, 0x80, 0x1F, 2, 3])),
            Some(Request::Fastscan { id: 0x8000_0000, bit_checked: 31, sub: Part::Revision, next: Part::Serial })
        );
    }

    #[test]
    fn rejects_malformed_requests() {
        // Short frame, remote frame, wrong identifier, unknown cs, bad mode, bad Fastscan.
        assert_eq!(Request::parse(&Frame::std(RX_ID, &[4, 1])), None);
        assert_eq!(Request::parse(&Frame::remote(CanId::Std(RX_ID), 8)), None);
        assert_eq!(Request::parse(&Frame::std(TX_ID, &[4, 1, 0, 0, 0, 0, 0, 0])), None);
        assert_eq!(Request::parse(&Frame::new(CanId::Ext(RX_ID as u32), &[4, 1, 0, 0, 0, 0, 0, 0])), None);
        for c in [0x00, 0x05, 0x12, 0x44, 0x45, 0x4D, 0x4F, 0x50, 0x59, 0x5F, 0xFF] {
            assert_eq!(Request::parse(&frame([c, 0, 0, 0, 0, 0, 0, 0])), None, "cs {c:02X}");
        }
        assert_eq!(Request::parse(&frame([4, 2, 0, 0, 0, 0, 0, 0])), None);
        assert_eq!(Request::parse(&frame([0x51, 0, 0, 0, 0, 32, 0, 0])), None);
        assert_eq!(Request::parse(&frame([0x51, 0, 0, 0, 0, 0x81, 0, 0])), None);
        assert_eq!(Request::parse(&frame([0x51, 0, 0, 0, 0, 0, 4, 0])), None);
        assert_eq!(Request::parse(&frame([0x51, 0, 0, 0, 0, 0, 0, 4])), None);
    }

    #[test]
    fn emits_the_manual_responses() {
        let r = |resp: Response| resp.emit().data;
        assert_eq!(r(Response::SwitchStateSelective), [0x44, 0, 0, 0, 0, 0, 0, 0]);
        assert_eq!(r(Response::ConfigureNodeId { error: 1, spec: 0 }), [0x11, 1, 0, 0, 0, 0, 0, 0]);
        assert_eq!(r(Response::StoreConfiguration { error: 2, spec: 0 }), [0x17, 2, 0, 0, 0, 0, 0, 0]);
        assert_eq!(
            r(Response::InquireIdentity { part: Part::Revision, value: 0xFFFF_FFFF }),
            [0x5C, 0xFF, 0xFF, 0xFF, 0xFF, 0, 0, 0]
        );
        assert_eq!(r(Response::InquireNodeId(1)), [0x5E, 1, 0, 0, 0, 0, 0, 0]);
        assert_eq!(r(Response::IdentifySlave), [0x4F, 0, 0, 0, 0, 0, 0, 0]);
        assert_eq!(r(Response::IdentifyNonConfiguredSlave), [0x50, 0, 0, 0, 0, 0, 0, 0]);
        let f = Response::IdentifySlave.emit();
        assert_eq!((f.id, f.len, f.rtr), (CanId::Std(TX_ID), 8, false));
    }

    #[test]
    fn identify_steps_check_equality_and_bounds() {
        let a = [0x195, 7, 10, 1000];
        assert!(IdentifyStep::Vendor.matches(&a, 0x195) && !IdentifyStep::Vendor.matches(&a, 0x196));
        assert!(IdentifyStep::Product.matches(&a, 7) && !IdentifyStep::Product.matches(&a, 8));
        assert!(IdentifyStep::RevisionLow.matches(&a, 10) && !IdentifyStep::RevisionLow.matches(&a, 11));
        assert!(IdentifyStep::RevisionHigh.matches(&a, 10) && !IdentifyStep::RevisionHigh.matches(&a, 9));
        assert!(IdentifyStep::SerialLow.matches(&a, 0) && !IdentifyStep::SerialLow.matches(&a, 1001));
        assert!(IdentifyStep::SerialHigh.matches(&a, u32::MAX) && !IdentifyStep::SerialHigh.matches(&a, 999));
    }

    fn part() -> impl Strategy<Value = Part> {
        (0u8..4).prop_map(|i| Part::from_index(i).unwrap())
    }

    fn request() -> impl Strategy<Value = Request> {
        prop_oneof![
            any::<bool>().prop_map(|c| Request::SwitchStateGlobal(if c {
                LssState::Configuration
            } else {
                LssState::Waiting
            })),
            (part(), any::<u32>()).prop_map(|(part, value)| Request::SwitchStateSelective { part, value }),
            any::<u8>().prop_map(Request::ConfigureNodeId),
            (any::<u8>(), any::<u8>()).prop_map(|(selector, index)| Request::ConfigureBitTiming { selector, index }),
            any::<u16>().prop_map(|delay_ms| Request::ActivateBitTiming { delay_ms }),
            Just(Request::StoreConfiguration),
            (0u8..6, any::<u32>()).prop_map(|(s, value)| Request::IdentifyRemoteSlave {
                step: IdentifyStep::from_index(s).unwrap(),
                value
            }),
            Just(Request::IdentifyNonConfiguredRemoteSlave),
            (any::<u32>(), prop_oneof![0u8..32, Just(FASTSCAN_RESET)], part(), part())
                .prop_map(|(id, bit_checked, sub, next)| Request::Fastscan { id, bit_checked, sub, next }),
            part().prop_map(Request::InquireIdentity),
            Just(Request::InquireNodeId),
        ]
    }

    fn response() -> impl Strategy<Value = Response> {
        prop_oneof![
            Just(Response::SwitchStateSelective),
            (any::<u8>(), any::<u8>()).prop_map(|(error, spec)| Response::ConfigureNodeId { error, spec }),
            (any::<u8>(), any::<u8>()).prop_map(|(error, spec)| Response::ConfigureBitTiming { error, spec }),
            (any::<u8>(), any::<u8>()).prop_map(|(error, spec)| Response::StoreConfiguration { error, spec }),
            Just(Response::IdentifySlave),
            Just(Response::IdentifyNonConfiguredSlave),
            (part(), any::<u32>()).prop_map(|(part, value)| Response::InquireIdentity { part, value }),
            any::<u8>().prop_map(Response::InquireNodeId),
        ]
    }

    proptest! {
        #[test]
        fn requests_round_trip(r in request()) {
            let f = r.emit();
            prop_assert_eq!((f.id, f.len, f.rtr), (CanId::Std(RX_ID), 8, false));
            prop_assert_eq!(Request::parse(&f), Some(r));
        }

        #[test]
        fn responses_round_trip(r in response()) {
            prop_assert_eq!(Response::parse(&r.emit()), Some(r));
        }

        #[test]
        fn parse_never_panics(len in 0u8..=8, rtr: bool, data: [u8; 8]) {
            let mut f = Frame::std(RX_ID, &data[..len as usize]);
            f.rtr = rtr;
            let _ = Request::parse(&f);
            f.id = CanId::Std(TX_ID);
            let _ = Response::parse(&f);
        }
    }
}
