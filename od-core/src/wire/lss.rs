//! LSS (CiA 305): the master's requests on 7E5h and the slave's answers on 7E4h, over their
//! 8 data bytes. The slave's behaviour is `crate::lss`.

use super::{exactly_8, u32_le};

/// The identifier of the master's messages.
pub const MASTER_ID: u16 = 0x7E5;
/// The identifier of the slave's messages.
pub const SLAVE_ID: u16 = 0x7E4;

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

    /// The part of the LSS address the step compares.
    pub const fn part(self) -> Part {
        match self {
            IdentifyStep::Vendor => Part::Vendor,
            IdentifyStep::Product => Part::Product,
            IdentifyStep::RevisionLow | IdentifyStep::RevisionHigh => Part::Revision,
            IdentifyStep::SerialLow | IdentifyStep::SerialHigh => Part::Serial,
        }
    }

    /// Does a slave whose address part [`IdentifyStep::part`] is `own` pass this step for
    /// `value`: equal vendor and product, revision and serial within the bounds?
    pub const fn passes(self, own: u32, value: u32) -> bool {
        match self {
            IdentifyStep::Vendor | IdentifyStep::Product => own == value,
            IdentifyStep::RevisionLow | IdentifyStep::SerialLow => own >= value,
            IdentifyStep::RevisionHigh | IdentifyStep::SerialHigh => own <= value,
        }
    }

    /// Does the slave whose LSS address is `address` pass this step for `value`?
    pub fn matches(self, address: &[u32; 4], value: u32) -> bool {
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
    u32_le(data, 1)
}

/// An LSS message: the command specifier, then 7 bytes (reserved ones 00h).
fn lss_bytes(cs: u8, body: [u8; 7]) -> [u8; 8] {
    [cs, body[0], body[1], body[2], body[3], body[4], body[5], body[6]]
}

/// A slave's message: command specifier `cs`, bytes 1..=4 `tail` little-endian (a value, or
/// the error code in byte 1 and the implementation-specific error in byte 2), the rest 00h:
/// the shape of every [`Response`].
#[inline]
pub const fn response(cs: u8, tail: u32) -> [u8; 8] {
    (cs as u64 | (tail as u64) << 8).to_le_bytes()
}

/// Bytes 1..=7 holding `value` little-endian in bytes 1..=4.
fn u32_body(value: u32) -> [u8; 7] {
    let v = value.to_le_bytes();
    [v[0], v[1], v[2], v[3], 0, 0, 0]
}

impl Request {
    /// Parses the data bytes of a master's message (7E5h). `None` for a length other than 8
    /// (CiA 305; the manuals: "A message consists always of 8 bytes"), an unknown command
    /// specifier, a switch mode other than 0/1, or Fastscan fields out of range. Reserved bytes
    /// are not checked.
    pub fn parse(data: &[u8]) -> Option<Request> {
        let d = exactly_8(data)?;
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

    /// The data bytes a master sends (reserved bytes 00h).
    pub fn emit(&self) -> [u8; 8] {
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
        lss_bytes(c, body)
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
    /// The data bytes the slave sends (reserved bytes 00h).
    pub fn emit(&self) -> [u8; 8] {
        let error = |error: u8, spec: u8| error as u32 | (spec as u32) << 8;
        let (c, tail) = match *self {
            Response::SwitchStateSelective => (cs::SWITCH_STATE_SELECTIVE_RESPONSE, 0),
            Response::ConfigureNodeId { error: e, spec } => (cs::CONFIGURE_NODE_ID, error(e, spec)),
            Response::ConfigureBitTiming { error: e, spec } => (cs::CONFIGURE_BIT_TIMING, error(e, spec)),
            Response::StoreConfiguration { error: e, spec } => (cs::STORE_CONFIGURATION, error(e, spec)),
            Response::IdentifySlave => (cs::IDENTIFY_SLAVE, 0),
            Response::IdentifyNonConfiguredSlave => (cs::IDENTIFY_NON_CONFIGURED_SLAVE, 0),
            Response::InquireIdentity { part, value } => (cs::INQUIRE_IDENTITY + part.index(), value),
            Response::InquireNodeId(id) => (cs::INQUIRE_NODE_ID, id as u32),
        };
        response(c, tail)
    }

    /// Parses the data bytes of a slave's message (7E4h, what a master reads); `None` for a
    /// length other than 8 or an unknown command specifier.
    pub fn parse(data: &[u8]) -> Option<Response> {
        let d = exactly_8(data)?;
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

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use proptest::prelude::*;
    // `prop_oneof!` with more than ten arms builds a Vec.
    use std::vec;

    fn frame(bytes: [u8; 8]) -> [u8; 8] {
        bytes
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
        // Short, long, empty, unknown cs, bad mode, bad Fastscan.
        assert_eq!(Request::parse(&[4, 1]), None);
        assert_eq!(Request::parse(&[4, 1, 0, 0, 0, 0, 0, 0, 0]), None);
        assert_eq!(Request::parse(&[]), None);
        assert_eq!(Response::parse(&[0x44, 0, 0, 0, 0, 0, 0]), None);
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
        let r = |resp: Response| resp.emit();
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
        /// A step judged on its own part of the address judges as on the whole address.
        #[test]
        fn a_step_passes_on_its_part_as_on_the_address(step in 0u8..6, address in any::<[u32; 4]>(), value in any::<u32>()) {
            let step = IdentifyStep::from_index(step).unwrap();
            prop_assert_eq!(step.passes(address[step.part().index() as usize], value), step.matches(&address, value));
            prop_assert_eq!(step.passes(value, value), step.matches(&[value; 4], value));
        }

        #[test]
        fn requests_round_trip(r in request()) {
            prop_assert_eq!(Request::parse(&r.emit()), Some(r));
        }

        #[test]
        fn responses_round_trip(r in response()) {
            prop_assert_eq!(Response::parse(&r.emit()), Some(r));
        }

        #[test]
        fn parse_never_panics(data in proptest::collection::vec(any::<u8>(), 0..=9)) {
            let _ = Request::parse(&data);
            let _ = Response::parse(&data);
        }
    }
}
