//! SAE J1939 wire formats (J1939-21 data link, J1939-81 network management) and the WV58MR's
//! parameter groups (manual §5).
//!
//! - [`Identifier`]: the 29-bit identifier, priority, extended data page, data page, PDU format,
//!   PDU specific and source address. A [`Pgn`] can only hold a valid parameter group number
//!   (18 bits; a PDU1 number has a zero low byte), and an [`Identifier`] carries a destination
//!   exactly when its PGN is a PDU1 one, so an invalid combination cannot be built.
//! - [`Name`]: the 64-bit NAME of J1939-81 and its ten fields ([`NameFields`]).
//! - Payloads: [`Request`] (PGN 59904), [`Acknowledgement`] (PGN 59392), [`AddressClaimed`]
//!   (PGN 60928, also Cannot Claim from the null address), the CiA 510 parameter access the
//!   WV58MR carries CANopen expedited SDO in ([`CamRequest`] on CAM21, PGN 1536, and
//!   [`CamResponse`] on CAM11, PGN 1280), and the process data [`Epos`] (64607), [`Espd`]
//!   (64609), [`ProprietaryB`] (65450) and [`Emcy`] (64616).
//! - [`Message`]: a received frame classified by its group and parsed into a [`Payload`].
//!
//! Every `parse` takes any byte slice and returns an error rather than panicking; every `emit`
//! fills the bytes the specification leaves unused with the value it names (FFh, "not
//! available", where J1939 and the manual say so; 00h where the manual prints 00h).

use crate::frame::{CanId, Frame};

/// A wire-format error: what was wrong with the bytes.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Error {
    /// The data length does not match the format (too short, or not the fixed length).
    Length,
    /// A field holds a value the format does not allow (a reserved control byte, a PGN over
    /// 18 bits, an identifier over 29 bits, a standard identifier, a remote frame ...).
    Malformed,
}

/// A J1939 source or destination address (J1939-81).
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Debug)]
pub struct Address(pub u8);

impl Address {
    /// The global (broadcast) destination address, FFh.
    pub const GLOBAL: Address = Address(0xFF);
    /// The null address, FEh: the source of Cannot Claim and of requests from a CA without an
    /// address.
    pub const NULL: Address = Address(0xFE);

    /// An address a CA can claim and use as its source: 00h..FDh.
    pub const fn is_unicast(self) -> bool {
        self.0 < 0xFE
    }
}

/// A message priority, 0 (highest) ..= 7 (lowest): the top three identifier bits.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Debug)]
pub struct Priority(u8);

impl Priority {
    /// Priority 0, the highest.
    pub const HIGHEST: Priority = Priority(0);
    /// Priority 6, J1939's default for control messages (request, acknowledgement, address
    /// claimed) and proprietary groups.
    pub const DEFAULT: Priority = Priority(6);
    /// Priority 7, the lowest.
    pub const LOWEST: Priority = Priority(7);

    /// A priority, `None` above 7.
    pub const fn new(p: u8) -> Option<Priority> {
        if p <= 7 {
            Some(Priority(p))
        } else {
            None
        }
    }

    /// The value, 0..=7.
    pub const fn get(self) -> u8 {
        self.0
    }
}

/// A parameter group number (J1939-21): 18 bits, extended data page, data page, PDU
/// format (PF) and PDU specific (PS). A PDU1 group (PF < 240) is destination-specific and its
/// number has PS = 0; a PDU2 group (PF >= 240) is broadcast and PS is its group extension.
/// Only such numbers can be built.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Debug)]
pub struct Pgn(u32);

impl Pgn {
    /// Request, PGN 59904 (EA00h), PDU1.
    pub const REQUEST: Pgn = Pgn(0xEA00);
    /// Acknowledgement (ACK/NACK), PGN 59392 (E800h), PDU1.
    pub const ACKNOWLEDGEMENT: Pgn = Pgn(0xE800);
    /// Address Claimed / Cannot Claim, PGN 60928 (EE00h), PDU1.
    pub const ADDRESS_CLAIMED: Pgn = Pgn(0xEE00);
    /// CAM11, PGN 1280 (0500h): CiA 510 SDO, the WV58MR's responses (manual §5.5.1, A2).
    pub const CAM11: Pgn = Pgn(0x0500);
    /// CAM21, PGN 1536 (0600h): CiA 510 SDO, requests to the WV58MR (manual §5.5.2, A2).
    pub const CAM21: Pgn = Pgn(0x0600);
    /// EPOS position value, PGN 64607 (FC5Fh), PDU2 (manual §5.4.1).
    pub const EPOS: Pgn = Pgn(0xFC5F);
    /// ESPD speed value, PGN 64609 (FC61h), PDU2 (manual §5.4.2).
    pub const ESPD: Pgn = Pgn(0xFC61);
    /// CiA 510 emergency, PGN 64616 (FC68h), PDU2 (manual §5.6).
    pub const EMCY: Pgn = Pgn(0xFC68);
    /// Proprietary B with position and speed, PGN 65450 (FFAAh), PDU2 (manual §5.4.3).
    pub const PROPRIETARY_B: Pgn = Pgn(0xFFAA);

    /// The PGN with this number: `None` above 18 bits or for a PDU1 number with a non-zero
    /// low byte.
    pub const fn new(raw: u32) -> Option<Pgn> {
        if raw > 0x3_FFFF {
            return None;
        }
        let pf = (raw >> 8) as u8;
        if pf < 240 && raw & 0xFF != 0 {
            return None;
        }
        Some(Pgn(raw))
    }

    /// A destination-specific (PDU1) group: `None` for PF >= 240.
    pub const fn pdu1(edp: bool, dp: bool, pf: u8) -> Option<Pgn> {
        if pf >= 240 {
            return None;
        }
        Some(Pgn(((edp as u32) << 17) | ((dp as u32) << 16) | ((pf as u32) << 8)))
    }

    /// A broadcast (PDU2) group with group extension `ge`: `None` for PF < 240.
    pub const fn pdu2(edp: bool, dp: bool, pf: u8, ge: u8) -> Option<Pgn> {
        if pf < 240 {
            return None;
        }
        Some(Pgn(((edp as u32) << 17) | ((dp as u32) << 16) | ((pf as u32) << 8) | ge as u32))
    }

    /// The number, 0..=3FFFFh.
    pub const fn raw(self) -> u32 {
        self.0
    }

    /// Extended data page bit (the manual's "reserved" identifier bit 25, A20).
    pub const fn edp(self) -> bool {
        self.0 & (1 << 17) != 0
    }

    /// Data page bit.
    pub const fn dp(self) -> bool {
        self.0 & (1 << 16) != 0
    }

    /// PDU format.
    pub const fn pf(self) -> u8 {
        (self.0 >> 8) as u8
    }

    /// Destination-specific (PDU1, PF < 240): frames of this group carry a destination address.
    pub const fn is_pdu1(self) -> bool {
        self.pf() < 240
    }

    /// The group extension of a PDU2 group, `None` for a PDU1 one.
    pub const fn group_extension(self) -> Option<u8> {
        if self.is_pdu1() {
            None
        } else {
            Some(self.0 as u8)
        }
    }

    /// Parse the 3-byte little-endian form requests and acknowledgements carry.
    pub const fn from_le_bytes(b: [u8; 3]) -> Option<Pgn> {
        Pgn::new(b[0] as u32 | (b[1] as u32) << 8 | (b[2] as u32) << 16)
    }

    /// The 3-byte little-endian form.
    pub const fn to_le_bytes(self) -> [u8; 3] {
        [self.0 as u8, (self.0 >> 8) as u8, (self.0 >> 16) as u8]
    }
}

/// A 29-bit J1939 identifier (J1939-21): priority, PGN, destination (PDU1 only) and
/// source. Fields are private so that a PDU2 identifier never has a destination and a PDU1
/// one always has.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct Identifier {
    priority: Priority,
    pgn: Pgn,
    destination: Option<Address>,
    source: Address,
}

impl Identifier {
    /// A destination-specific identifier: `None` when `pgn` is a PDU2 group.
    pub const fn pdu1(priority: Priority, pgn: Pgn, destination: Address, source: Address) -> Option<Identifier> {
        if !pgn.is_pdu1() {
            return None;
        }
        Some(Identifier { priority, pgn, destination: Some(destination), source })
    }

    /// A broadcast identifier: `None` when `pgn` is a PDU1 group.
    pub const fn pdu2(priority: Priority, pgn: Pgn, source: Address) -> Option<Identifier> {
        if pgn.is_pdu1() {
            return None;
        }
        Some(Identifier { priority, pgn, destination: None, source })
    }

    /// Either kind: `destination` must be `Some` exactly for a PDU1 `pgn`.
    pub const fn new(
        priority: Priority,
        pgn: Pgn,
        destination: Option<Address>,
        source: Address,
    ) -> Option<Identifier> {
        match destination {
            Some(da) => Identifier::pdu1(priority, pgn, da, source),
            None => Identifier::pdu2(priority, pgn, source),
        }
    }

    /// Parse a raw 29-bit identifier: [`Error::Malformed`] above 29 bits.
    pub const fn parse(raw: u32) -> Result<Identifier, Error> {
        if raw > 0x1FFF_FFFF {
            return Err(Error::Malformed);
        }
        let priority = Priority((raw >> 26) as u8 & 7);
        let source = Address(raw as u8);
        let ps = (raw >> 8) as u8;
        let pf = (raw >> 16) as u8;
        let edp = raw & (1 << 25) != 0;
        let dp = raw & (1 << 24) != 0;
        if pf < 240 {
            let pgn = Pgn(((edp as u32) << 17) | ((dp as u32) << 16) | ((pf as u32) << 8));
            Ok(Identifier { priority, pgn, destination: Some(Address(ps)), source })
        } else {
            let pgn = Pgn(((edp as u32) << 17) | ((dp as u32) << 16) | ((pf as u32) << 8) | ps as u32);
            Ok(Identifier { priority, pgn, destination: None, source })
        }
    }

    /// The raw 29-bit identifier.
    pub const fn emit(&self) -> u32 {
        let ps = match self.destination {
            Some(Address(da)) => da as u32,
            None => 0,
        };
        ((self.priority.0 as u32) << 26) | (self.pgn.0 << 8) | (ps << 8) | self.source.0 as u32
    }

    /// The identifier of a received frame: [`Error::Malformed`] for an 11-bit identifier or a
    /// remote frame (J1939 uses neither).
    pub fn from_frame(frame: &Frame) -> Result<Identifier, Error> {
        match frame.id {
            CanId::Ext(raw) if !frame.rtr => Identifier::parse(raw),
            _ => Err(Error::Malformed),
        }
    }

    /// A data frame with this identifier and `payload` (at most 8 bytes are used).
    pub fn frame(&self, payload: &[u8]) -> Frame {
        Frame::new(CanId::Ext(self.emit()), payload)
    }

    /// The priority.
    pub const fn priority(&self) -> Priority {
        self.priority
    }

    /// The parameter group number.
    pub const fn pgn(&self) -> Pgn {
        self.pgn
    }

    /// The destination address of a PDU1 identifier; `None` for a broadcast PDU2 one.
    pub const fn destination(&self) -> Option<Address> {
        self.destination
    }

    /// The source address.
    pub const fn source(&self) -> Address {
        self.source
    }

    /// Is the frame meant for a CA at `address`: broadcast (PDU2), to the global address, or
    /// to `address` itself?
    pub const fn is_for(&self, address: Address) -> bool {
        match self.destination {
            None => true,
            Some(da) => da.0 == Address::GLOBAL.0 || da.0 == address.0,
        }
    }
}

/// The ten fields of a NAME (J1939-81; manual Table 7, object 3001h).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub struct NameFields {
    /// Identity number, 21 bits (bits 0..=20).
    pub identity_number: u32,
    /// Manufacturer code, 11 bits (bits 21..=31).
    pub manufacturer_code: u16,
    /// ECU instance, 3 bits (bits 32..=34).
    pub ecu_instance: u8,
    /// Function instance, 5 bits (bits 35..=39).
    pub function_instance: u8,
    /// Function, 8 bits (bits 40..=47).
    pub function: u8,
    /// The reserved bit 48.
    pub reserved: bool,
    /// Vehicle system, 7 bits (bits 49..=55).
    pub vehicle_system: u8,
    /// Vehicle system instance, 4 bits (bits 56..=59).
    pub vehicle_system_instance: u8,
    /// Industry group, 3 bits (bits 60..=62).
    pub industry_group: u8,
    /// Arbitrary address capable, bit 63.
    pub arbitrary_address_capable: bool,
}

impl NameFields {
    /// The identity number a factory serial number gives: its low 21 bits (D-J1939-6).
    pub const fn identity_from_serial(serial: u32) -> u32 {
        serial & 0x1F_FFFF
    }
}

/// A 64-bit J1939 NAME. Its numeric value is its priority in address arbitration: the lower
/// value wins (J1939-81; D-J1939-1 on the manual's "higher NAME", A1).
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Debug)]
pub struct Name(u64);

impl Name {
    /// The NAME with this 64-bit value.
    pub const fn from_raw(raw: u64) -> Name {
        Name(raw)
    }

    /// The 64-bit value.
    pub const fn raw(self) -> u64 {
        self.0
    }

    /// Build from fields: [`Error::Malformed`] when one does not fit its width.
    pub const fn from_fields(f: &NameFields) -> Result<Name, Error> {
        if f.identity_number > 0x1F_FFFF
            || f.manufacturer_code > 0x7FF
            || f.ecu_instance > 7
            || f.function_instance > 0x1F
            || f.vehicle_system > 0x7F
            || f.vehicle_system_instance > 0xF
            || f.industry_group > 7
        {
            return Err(Error::Malformed);
        }
        Ok(Name(
            f.identity_number as u64
                | (f.manufacturer_code as u64) << 21
                | (f.ecu_instance as u64) << 32
                | (f.function_instance as u64) << 35
                | (f.function as u64) << 40
                | (f.reserved as u64) << 48
                | (f.vehicle_system as u64) << 49
                | (f.vehicle_system_instance as u64) << 56
                | (f.industry_group as u64) << 60
                | (f.arbitrary_address_capable as u64) << 63,
        ))
    }

    /// The fields.
    pub const fn fields(self) -> NameFields {
        let n = self.0;
        NameFields {
            identity_number: (n & 0x1F_FFFF) as u32,
            manufacturer_code: ((n >> 21) & 0x7FF) as u16,
            ecu_instance: ((n >> 32) & 7) as u8,
            function_instance: ((n >> 35) & 0x1F) as u8,
            function: (n >> 40) as u8,
            reserved: (n >> 48) & 1 != 0,
            vehicle_system: ((n >> 49) & 0x7F) as u8,
            vehicle_system_instance: ((n >> 56) & 0xF) as u8,
            industry_group: ((n >> 60) & 7) as u8,
            arbitrary_address_capable: n >> 63 != 0,
        }
    }

    /// The arbitrary-address-capable bit: the CA may claim another address when it loses.
    pub const fn arbitrary_address_capable(self) -> bool {
        self.0 >> 63 != 0
    }

    /// Does this NAME win an address contest against `other`? The numerically lower one wins
    /// (J1939-81); equal NAMEs do not win (D-J1939-3).
    pub const fn wins_against(self, other: Name) -> bool {
        self.0 < other.0
    }

    /// Parse the 8 bytes of an Address Claimed payload (little-endian).
    pub const fn from_le_bytes(b: [u8; 8]) -> Name {
        Name(u64::from_le_bytes(b))
    }

    /// The 8 bytes as they go on the bus (little-endian).
    pub const fn to_le_bytes(self) -> [u8; 8] {
        self.0.to_le_bytes()
    }
}

/// Copy the first `N` bytes of `data`, or [`Error::Length`] if it has fewer.
fn take<const N: usize>(data: &[u8]) -> Result<[u8; N], Error> {
    match data.get(..N) {
        Some(s) => {
            let mut b = [0u8; N];
            b.copy_from_slice(s);
            Ok(b)
        }
        None => Err(Error::Length),
    }
}

/// Exactly `N` bytes, or [`Error::Length`].
fn exact<const N: usize>(data: &[u8]) -> Result<[u8; N], Error> {
    if data.len() != N {
        return Err(Error::Length);
    }
    take(data)
}

/// Request, PGN 59904 (J1939-21): the requested PGN in three bytes.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Request {
    /// The requested parameter group.
    pub pgn: Pgn,
}

impl Request {
    /// The payload length J1939-21 prescribes.
    pub const LEN: usize = 3;

    /// Parse: at least 3 bytes (a sender that pads to 8 is accepted, the rest is ignored),
    /// [`Error::Malformed`] for a number that is no PGN.
    pub fn parse(data: &[u8]) -> Result<Request, Error> {
        let b: [u8; 3] = take(data)?;
        match Pgn::from_le_bytes(b) {
            Some(pgn) => Ok(Request { pgn }),
            None => Err(Error::Malformed),
        }
    }

    /// The 3-byte payload.
    pub const fn emit(&self) -> [u8; 3] {
        self.pgn.to_le_bytes()
    }

    /// The request frame from `source` to `destination` (the global address asks everyone),
    /// at the default priority 6.
    pub fn frame(&self, destination: Address, source: Address) -> Frame {
        let id = Identifier { priority: Priority::DEFAULT, pgn: Pgn::REQUEST, destination: Some(destination), source };
        id.frame(&self.emit())
    }
}

/// The control byte of an acknowledgement (J1939-21).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum AckControl {
    /// Positive acknowledgement, 0.
    Ack,
    /// Negative acknowledgement, 1: the PGN is not supported.
    Nack,
    /// Access denied, 2.
    AccessDenied,
    /// Cannot respond (busy), 3.
    CannotRespond,
}

/// Acknowledgement, PGN 59392 (J1939-21): control byte, group function value, two
/// reserved bytes FFh, the address acknowledged (the requester) and the PGN.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Acknowledgement {
    /// ACK, NACK, access denied or cannot respond.
    pub control: AckControl,
    /// Group function value; FFh when not applicable.
    pub group_function: u8,
    /// The address of the CA whose request is answered.
    pub address: Address,
    /// The PGN the acknowledgement is about.
    pub pgn: Pgn,
}

impl Acknowledgement {
    /// A NACK of `pgn` requested by `requester`.
    pub const fn nack(pgn: Pgn, requester: Address) -> Acknowledgement {
        Acknowledgement { control: AckControl::Nack, group_function: 0xFF, address: requester, pgn }
    }

    /// Parse 8 bytes: [`Error::Malformed`] for a reserved control value (4..=255) or a number
    /// that is no PGN; the reserved bytes are not checked.
    pub fn parse(data: &[u8]) -> Result<Acknowledgement, Error> {
        let b: [u8; 8] = exact(data)?;
        let control = match b[0] {
            0 => AckControl::Ack,
            1 => AckControl::Nack,
            2 => AckControl::AccessDenied,
            3 => AckControl::CannotRespond,
            _ => return Err(Error::Malformed),
        };
        let pgn = match Pgn::from_le_bytes([b[5], b[6], b[7]]) {
            Some(p) => p,
            None => return Err(Error::Malformed),
        };
        Ok(Acknowledgement { control, group_function: b[1], address: Address(b[4]), pgn })
    }

    /// The 8-byte payload.
    pub const fn emit(&self) -> [u8; 8] {
        let control = match self.control {
            AckControl::Ack => 0,
            AckControl::Nack => 1,
            AckControl::AccessDenied => 2,
            AckControl::CannotRespond => 3,
        };
        let p = self.pgn.to_le_bytes();
        [control, self.group_function, 0xFF, 0xFF, self.address.0, p[0], p[1], p[2]]
    }

    /// The frame from `source`, sent to the global address at priority 6 (D-J1939-5).
    pub fn frame(&self, source: Address) -> Frame {
        let id = Identifier {
            priority: Priority::DEFAULT,
            pgn: Pgn::ACKNOWLEDGEMENT,
            destination: Some(Address::GLOBAL),
            source,
        };
        id.frame(&self.emit())
    }
}

/// Address Claimed, PGN 60928 (J1939-81): the claimant's NAME. Sent from the null
/// address FEh it is Cannot Claim Address.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct AddressClaimed {
    /// The claimant's NAME.
    pub name: Name,
}

impl AddressClaimed {
    /// Parse exactly 8 bytes.
    pub fn parse(data: &[u8]) -> Result<AddressClaimed, Error> {
        Ok(AddressClaimed { name: Name::from_le_bytes(exact(data)?) })
    }

    /// The 8-byte payload.
    pub const fn emit(&self) -> [u8; 8] {
        self.name.to_le_bytes()
    }

    /// The frame claiming `address` (or, from [`Address::NULL`], saying no address could be
    /// claimed), to the global address at priority 6.
    pub fn frame(&self, address: Address) -> Frame {
        let id = Identifier {
            priority: Priority::DEFAULT,
            pgn: Pgn::ADDRESS_CLAIMED,
            destination: Some(Address::GLOBAL),
            source: address,
        };
        id.frame(&self.emit())
    }
}

/// The priority of CAM11 and CAM21 (manual §5.5.1, §5.5.2).
pub const CAM_PRIORITY: Priority = Priority(7);

/// A parameter-access request on CAM21 (PGN 1536, manual §5.5.2 and D-J1939-2 on A2): a
/// CiA 301 expedited SDO request. Byte 0 command, bytes 1-2 index (little-endian), byte 3
/// subindex, bytes 4-7 data.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum CamRequest {
    /// Read (upload request, 40h); bytes 4-7 are "don't care".
    Read {
        /// Object index.
        index: u16,
        /// Subindex.
        sub: u8,
    },
    /// Write (expedited download): 2Fh, 2Bh, 27h, 23h for 1 to 4 bytes, 22h with no size.
    Write {
        /// Object index.
        index: u16,
        /// Subindex.
        sub: u8,
        /// The value, little-endian from byte 4, bytes past `len` zero.
        value: u32,
        /// Valid bytes, 1..=4; `None` when the client did not indicate the size (22h, emitted
        /// for any other count too).
        len: Option<u8>,
    },
}

/// The (index, sub) of an 8-byte CiA 301 SDO payload.
fn multiplexer(b: &[u8; 8]) -> (u16, u8) {
    (u16::from_le_bytes([b[1], b[2]]), b[3])
}

/// `value` with the bytes past `len` cleared.
const fn truncate(value: u32, len: u8) -> u32 {
    match len {
        1 => value & 0xFF,
        2 => value & 0xFFFF,
        3 => value & 0xFF_FFFF,
        _ => value,
    }
}

impl CamRequest {
    /// Parse exactly 8 bytes: [`Error::Length`] otherwise, [`Error::Malformed`] for a command
    /// that is not an expedited read or write (segmented and block transfers; the WV58MR's
    /// objects are all 4 bytes or fewer).
    pub fn parse(data: &[u8]) -> Result<CamRequest, Error> {
        let b: [u8; 8] = exact(data)?;
        let (index, sub) = multiplexer(&b);
        let cmd = b[0];
        match cmd >> 5 {
            2 => Ok(CamRequest::Read { index, sub }),
            1 if cmd & 0x02 != 0 => {
                let len = if cmd & 0x01 != 0 { Some(4 - ((cmd >> 2) & 3)) } else { None };
                let raw = u32::from_le_bytes([b[4], b[5], b[6], b[7]]);
                Ok(CamRequest::Write { index, sub, value: truncate(raw, len.unwrap_or(4)), len })
            }
            _ => Err(Error::Malformed),
        }
    }

    /// The 8-byte payload; unused bytes are 00h.
    pub const fn emit(&self) -> [u8; 8] {
        match *self {
            CamRequest::Read { index, sub } => {
                let i = index.to_le_bytes();
                [0x40, i[0], i[1], sub, 0, 0, 0, 0]
            }
            CamRequest::Write { index, sub, value, len } => {
                let i = index.to_le_bytes();
                let (cmd, n) = match len {
                    Some(n @ 1..=4) => (0x23 | ((4 - n) << 2), n),
                    _ => (0x22, 4),
                };
                let v = truncate(value, n).to_le_bytes();
                [cmd, i[0], i[1], sub, v[0], v[1], v[2], v[3]]
            }
        }
    }

    /// The CAM21 frame from `source` to the device at `destination`.
    pub fn frame(&self, destination: Address, source: Address) -> Frame {
        let id = Identifier { priority: CAM_PRIORITY, pgn: Pgn::CAM21, destination: Some(destination), source };
        id.frame(&self.emit())
    }
}

/// A parameter-access response on CAM11 (PGN 1280, manual §5.5.1 and D-J1939-2 on A2).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum CamResponse {
    /// Read response (expedited upload): 4Fh, 4Bh, 47h, 43h for 1 to 4 valid bytes; the bytes
    /// past them are 00h (D-J1939-7, A29).
    Read {
        /// Object index.
        index: u16,
        /// Subindex.
        sub: u8,
        /// The value, little-endian from byte 4.
        value: u32,
        /// Valid bytes, 1..=4 (any other count is emitted as 4).
        len: u8,
    },
    /// Write confirmation, 60h, bytes 4-7 00h.
    Written {
        /// Object index.
        index: u16,
        /// Subindex.
        sub: u8,
    },
    /// CiA 301 abort, 80h, the abort code in bytes 4-7.
    Abort {
        /// Object index.
        index: u16,
        /// Subindex.
        sub: u8,
        /// The CiA 301 abort code.
        code: u32,
    },
}

impl CamResponse {
    /// Parse exactly 8 bytes: [`Error::Malformed`] for any other command (including an
    /// upload response without size or a segmented one).
    pub fn parse(data: &[u8]) -> Result<CamResponse, Error> {
        let b: [u8; 8] = exact(data)?;
        let (index, sub) = multiplexer(&b);
        let raw = u32::from_le_bytes([b[4], b[5], b[6], b[7]]);
        match b[0] {
            0x60 => Ok(CamResponse::Written { index, sub }),
            0x80 => Ok(CamResponse::Abort { index, sub, code: raw }),
            cmd if cmd & 0xF3 == 0x43 => {
                let len = 4 - ((cmd >> 2) & 3);
                Ok(CamResponse::Read { index, sub, value: truncate(raw, len), len })
            }
            _ => Err(Error::Malformed),
        }
    }

    /// The 8-byte payload.
    pub const fn emit(&self) -> [u8; 8] {
        match *self {
            CamResponse::Read { index, sub, value, len } => {
                let n = if len >= 1 && len <= 4 { len } else { 4 };
                let i = index.to_le_bytes();
                let v = truncate(value, n).to_le_bytes();
                [0x43 | ((4 - n) << 2), i[0], i[1], sub, v[0], v[1], v[2], v[3]]
            }
            CamResponse::Written { index, sub } => {
                let i = index.to_le_bytes();
                [0x60, i[0], i[1], sub, 0, 0, 0, 0]
            }
            CamResponse::Abort { index, sub, code } => {
                let i = index.to_le_bytes();
                let c = code.to_le_bytes();
                [0x80, i[0], i[1], sub, c[0], c[1], c[2], c[3]]
            }
        }
    }

    /// The CAM11 frame from the device at `source` to the requester at `destination`.
    pub fn frame(&self, destination: Address, source: Address) -> Frame {
        cam11_frame(&self.emit(), destination, source)
    }
}

/// A CAM11 frame (priority 7) carrying the 8-byte SDO answer `payload` from `source` to
/// `destination`.
pub fn cam11_frame(payload: &[u8; 8], destination: Address, source: Address) -> Frame {
    let id = Identifier { priority: CAM_PRIORITY, pgn: Pgn::CAM11, destination: Some(destination), source };
    id.frame(payload)
}

/// EPOS, PGN 64607 (manual §5.4.1): the position value (6004h), bytes 4-7 FFh.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Epos {
    /// The position value.
    pub position: u32,
}

impl Epos {
    /// Parse exactly 8 bytes; the padding is not checked.
    pub fn parse(data: &[u8]) -> Result<Epos, Error> {
        let b: [u8; 8] = exact(data)?;
        Ok(Epos { position: u32::from_le_bytes([b[0], b[1], b[2], b[3]]) })
    }

    /// The 8-byte payload.
    pub const fn emit(&self) -> [u8; 8] {
        let p = self.position.to_le_bytes();
        [p[0], p[1], p[2], p[3], 0xFF, 0xFF, 0xFF, 0xFF]
    }
}

/// ESPD, PGN 64609 (manual §5.4.2): the speed value (6030h.01, increments per ms), bytes 2-7
/// FFh.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Espd {
    /// The speed value.
    pub speed: i16,
}

impl Espd {
    /// Parse exactly 8 bytes; the padding is not checked.
    pub fn parse(data: &[u8]) -> Result<Espd, Error> {
        let b: [u8; 8] = exact(data)?;
        Ok(Espd { speed: i16::from_le_bytes([b[0], b[1]]) })
    }

    /// The 8-byte payload.
    pub const fn emit(&self) -> [u8; 8] {
        let s = self.speed.to_le_bytes();
        [s[0], s[1], 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF]
    }
}

/// Proprietary B, PGN 65450 (manual §5.4.3): position (bytes 0-3), speed (bytes 4-5), bytes
/// 6-7 00h as the manual prints them.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct ProprietaryB {
    /// The position value (6004h).
    pub position: u32,
    /// The speed value (6030h.01).
    pub speed: i16,
}

impl ProprietaryB {
    /// Parse exactly 8 bytes; bytes 6-7 are not checked.
    pub fn parse(data: &[u8]) -> Result<ProprietaryB, Error> {
        let b: [u8; 8] = exact(data)?;
        Ok(ProprietaryB {
            position: u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
            speed: i16::from_le_bytes([b[4], b[5]]),
        })
    }

    /// The 8-byte payload.
    pub const fn emit(&self) -> [u8; 8] {
        let p = self.position.to_le_bytes();
        let s = self.speed.to_le_bytes();
        [p[0], p[1], p[2], p[3], s[0], s[1], 0x00, 0x00]
    }
}

/// Emergency, PGN 64616 (manual §5.6, CiA 510): error code, error register (1001h), bytes 3-7
/// FFh.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Emcy {
    /// The emergency error code; 0000h when a cause has cleared.
    pub code: u16,
    /// The error register 1001h.
    pub register: u8,
}

impl Emcy {
    /// Parse exactly 8 bytes; the padding is not checked.
    pub fn parse(data: &[u8]) -> Result<Emcy, Error> {
        let b: [u8; 8] = exact(data)?;
        Ok(Emcy { code: u16::from_le_bytes([b[0], b[1]]), register: b[2] })
    }

    /// The 8-byte payload.
    pub const fn emit(&self) -> [u8; 8] {
        let c = self.code.to_le_bytes();
        [c[0], c[1], self.register, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF]
    }
}

/// A received J1939 frame, classified by its group and parsed: what a node dispatches on and
/// what a bus trace shows.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Payload {
    /// Request, PGN 59904.
    Request(Request),
    /// Acknowledgement, PGN 59392.
    Acknowledgement(Acknowledgement),
    /// Address Claimed, PGN 60928, from a unicast address.
    AddressClaimed(AddressClaimed),
    /// Cannot Claim: PGN 60928 from the null address.
    CannotClaim(AddressClaimed),
    /// A parameter-access request, CAM21.
    Cam21(CamRequest),
    /// A parameter-access response, CAM11.
    Cam11(CamResponse),
    /// Position, EPOS.
    Epos(Epos),
    /// Speed, ESPD.
    Espd(Espd),
    /// Position and speed, Proprietary B.
    ProprietaryB(ProprietaryB),
    /// Emergency.
    Emcy(Emcy),
    /// Any other group: not parsed further.
    Other,
}

/// A received J1939 frame: its identifier and its parsed payload.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Message {
    /// The identifier.
    pub id: Identifier,
    /// The payload.
    pub payload: Payload,
}

impl Message {
    /// Classify and parse `frame`: [`Error::Malformed`] for a frame that is not J1939 (11-bit
    /// identifier, remote frame), and the payload's error for a known group whose bytes do not
    /// fit its format. Groups this module does not know are [`Payload::Other`].
    pub fn parse(frame: &Frame) -> Result<Message, Error> {
        let id = Identifier::from_frame(frame)?;
        let data = frame.payload();
        let payload = match id.pgn() {
            Pgn::REQUEST => Payload::Request(Request::parse(data)?),
            Pgn::ACKNOWLEDGEMENT => Payload::Acknowledgement(Acknowledgement::parse(data)?),
            Pgn::ADDRESS_CLAIMED if id.source() == Address::NULL => Payload::CannotClaim(AddressClaimed::parse(data)?),
            Pgn::ADDRESS_CLAIMED => Payload::AddressClaimed(AddressClaimed::parse(data)?),
            Pgn::CAM21 => Payload::Cam21(CamRequest::parse(data)?),
            Pgn::CAM11 => Payload::Cam11(CamResponse::parse(data)?),
            Pgn::EPOS => Payload::Epos(Epos::parse(data)?),
            Pgn::ESPD => Payload::Espd(Espd::parse(data)?),
            Pgn::PROPRIETARY_B => Payload::ProprietaryB(ProprietaryB::parse(data)?),
            Pgn::EMCY => Payload::Emcy(Emcy::parse(data)?),
            _ => Payload::Other,
        };
        Ok(Message { id, payload })
    }
}

#[cfg(test)]
mod tests;
