//! The WV58MR / WH58MR dictionary (manual "Absoluter redundanter Drehgeber mit SAE
//! J1939-Schnittstelle", 81/25, §6; `shared/spec/WV58MR.od.csv`): every row, with the manual's
//! types, access rights, defaults, limits and storage groups, built once per measuring range by
//! one `const fn`.
//!
//! The communication rows (1000h-1FFFh) come from [`comm`] with no CANopen block: the WV58MR
//! has no NMT, SYNC, PDO, guarding, heartbeat or SDO COB-IDs (digest §3.1). The encoder rows are
//! the CiA 406 rotary encoder's, as on the WV5800M. Where the table departs from a printed cell
//! (A4, A9, A8, A7 ...) the decision is named at the row (D-J1939-14 ff. in `docs/decisions.md`).

use crate::devices::comm::{self, Identity, NodeIdAndBitrate, Profile, Serial};
use crate::devices::wv5800m::Turns;
use crate::encoder::rotary::{self, DIRECTION_BIT, MAX_APU, PHYSICAL_STEPS, SCALING_BIT};
use crate::od::{Access::*, DataType::*, Entry, Group, Hook};

/// Device-specific write hooks of the WV58MR (`Hook::Device(n)`).
pub mod hooks {
    /// 6000h operating parameters: counting direction.
    pub const OPERATING_PARAMETERS: u8 = 1;
    /// 6001h measuring steps per revolution: rescales, sets 6002h and 650Ah.03.
    pub const APU: u8 = 2;
    /// 6002h total measuring range: only APU × revolutions.
    pub const TOTAL_RANGE: u8 = 3;
    /// 6401h/6402h work-area limits: `0 ..= 6002h − 1`.
    pub const IN_RANGE: u8 = 4;
    /// 2001h application offset: moves the position.
    pub const OFFSET: u8 = 5;
    /// 6003h calibration value: `0 ..= 6002h − 1`, and writing it calibrates (§4.2).
    pub const PRESET: u8 = 6;
    /// 2003h/2004h limit speeds.
    pub const LIMIT_SPEED: u8 = 7;
    /// 6200h cycle timer: the same value as 3000h.03 (EPOS cycle time).
    pub const CYCLE_TIMER: u8 = 8;
    /// 3000h.01-.03: cycle times of Proprietary B, ESPD, EPOS (3000h.03 is also 6200h).
    pub const PGN_CYCLE: u8 = 9;
    /// 3000h.04-.06: priorities of Proprietary B, ESPD, EPOS.
    pub const PGN_PRIORITY: u8 = 10;
    /// 3002h.01 "SAE initialisieren": the J1939 layer restarts (claims again).
    pub const SAE_INIT: u8 = 11;
    /// 3002h.02 "Gerät neu starten": the device restarts.
    pub const RESTART: u8 = 12;
}

const APP: Group = Group::App;
const MANUF: Group = Group::Manuf;
const fn dev(h: u8) -> Hook {
    Hook::Device(h)
}

/// Default J1939 address (5F0Ah.01), EFh (§5.2).
pub const DEFAULT_ADDRESS: u8 = 0xEF;
/// Lowest address 5F0Ah.01 accepts.
pub const LOWEST_ADDRESS: u8 = 0x80;
/// Highest address 5F0Ah.01 accepts.
pub const HIGHEST_ADDRESS: u8 = 0xEF;
/// Default 5F0Ah.02 bit-rate code (4 = 250 kbit/s).
pub const DEFAULT_BITRATE_CODE: u8 = 4;
/// Default cycle time of EPOS and ESPD, 3000h.02/.03 (50 ms).
pub const DEFAULT_CYCLE_MS: u16 = 50;
/// Entries in each WV58MR dictionary (95 rows in the manual's object table).
pub const ENTRIES: usize = 95;

/// NAME defaults, 3001h (§5.2 Table 7): manufacturer code 0471h, function 8Eh, industry
/// group 3, arbitrary address capable.
pub const MANUFACTURER_CODE: u16 = 0x0471;
/// NAME function, 3001h.05.
pub const FUNCTION: u8 = 0x8E;
/// NAME industry group, 3001h.09.
pub const INDUSTRY_GROUP: u8 = 3;

/// The communication profile of a WV58MR with `turns`: identity, error history and
/// store/restore only.
const fn profile(turns: Turns) -> Profile {
    Profile {
        device_type: turns.device_type(),
        status_register: false,
        device_name: None,
        hardware_version: None,
        // A7: the printed default "V001" (D-J1939-15).
        software_version: "V001",
        identity: Identity::siko(Serial::Factory(1)),
        heads: Const,
        canopen: None,
    }
}

/// 5F0Ah: address 80h..EFh (default EFh), bit-rate code 3..5 (default 4).
const NODE: NodeIdAndBitrate =
    NodeIdAndBitrate::new(DEFAULT_ADDRESS, (LOWEST_ADDRESS, HIGHEST_ADDRESS), DEFAULT_BITRATE_CODE, (3, 5));

/// The dictionary of a WV58MR with `turns`.
pub const fn table(turns: Turns) -> [Entry; ENTRIES] {
    let n = turns.revolutions() as i64;
    let r = PHYSICAL_STEPS as i64 * n;
    let max_pos = MAX_APU as i64 * n - 1;
    comm::join(&[
        comm::rows(&profile(turns)).as_slice(),
        &[
            Entry::var(0x2001, "Application offset", Integer32, Rw, 0)
                .range(-r, r - 1)
                .group(MANUF)
                .hook(dev(hooks::OFFSET)),
            Entry::var(0x2003, "Limit speed low", Integer16, Rw, 0)
                .range(i16::MIN as i64, i16::MAX as i64)
                .group(MANUF)
                .hook(dev(hooks::LIMIT_SPEED)),
            Entry::var(0x2004, "Limit speed high", Integer16, Rw, 0)
                .range(i16::MIN as i64, i16::MAX as i64)
                .group(MANUF)
                .hook(dev(hooks::LIMIT_SPEED)),
            // A4: the cycle times and priorities are stored with the manufacturer group
            // (D-J1939-14), though printed "EEPROM: nein".
            Entry::record(0x3000, "SAE J1939 PGN parameters", 6, Const),
            Entry::member(0x3000, 1, "Cycle time Proprietary B PGN 65450", Unsigned16, Rw, 0)
                .range(0, 0xFFFF)
                .group(MANUF)
                .hook(dev(hooks::PGN_CYCLE)),
            Entry::member(0x3000, 2, "Cycle time speed PGN 64609", Unsigned16, Rw, DEFAULT_CYCLE_MS as u32)
                .range(0, 0xFFFF)
                .group(MANUF)
                .hook(dev(hooks::PGN_CYCLE)),
            Entry::member(0x3000, 3, "Cycle time position PGN 64607", Unsigned16, Rw, DEFAULT_CYCLE_MS as u32)
                .range(0, 0xFFFF)
                .group(MANUF)
                .hook(dev(hooks::PGN_CYCLE)),
            Entry::member(0x3000, 4, "Priority Proprietary B PGN 65450", Unsigned8, Rw, 6)
                .range(0, 7)
                .group(MANUF)
                .hook(dev(hooks::PGN_PRIORITY)),
            Entry::member(0x3000, 5, "Priority speed PGN 64609", Unsigned8, Rw, 3)
                .range(0, 7)
                .group(MANUF)
                .hook(dev(hooks::PGN_PRIORITY)),
            // A10: "64609" printed, 64607 meant.
            Entry::member(0x3000, 6, "Priority position PGN 64607", Unsigned8, Rw, 3)
                .range(0, 7)
                .group(MANUF)
                .hook(dev(hooks::PGN_PRIORITY)),
            // A9: sub 0 reads 0Ah (printed "10h"); ManufacturerCode is UNSIGNED16 (printed
            // UNSIGNED8 cannot hold 0471h); every field is factory data, read-only; the
            // identity number is the serial's low 21 bits (D-J1939-6, D-J1939-16).
            Entry::record(0x3001, "Device NAME", 10, Ro),
            Entry::member(0x3001, 1, "IdentityNumber", Unsigned32, Ro, 1),
            Entry::member(0x3001, 2, "ManufacturerCode", Unsigned16, Ro, MANUFACTURER_CODE as u32),
            Entry::member(0x3001, 3, "ECUInstance", Unsigned8, Ro, 0),
            Entry::member(0x3001, 4, "FunctionInstance", Unsigned8, Ro, 0),
            Entry::member(0x3001, 5, "Function", Unsigned8, Ro, FUNCTION as u32),
            Entry::member(0x3001, 6, "VehicleSystem", Unsigned8, Ro, 0),
            Entry::member(0x3001, 7, "Reserved", Unsigned8, Ro, 0),
            Entry::member(0x3001, 8, "VehicleSystem Instance", Unsigned8, Ro, 0),
            Entry::member(0x3001, 9, "IndustryGroup", Unsigned8, Ro, INDUSTRY_GROUP as u32),
            Entry::member(0x3001, 10, "Arbitrary Address Capable", Unsigned8, Ro, 1),
            // A22: commands, accepting 1 only, not stored.
            Entry::record(0x3002, "SAE initialisation", 2, Ro),
            Entry::member(0x3002, 1, "Initialise SAE", Unsigned8, Wo, 1).range(1, 1).hook(dev(hooks::SAE_INIT)),
            Entry::member(0x3002, 2, "Restart device", Unsigned8, Wo, 1).range(1, 1).hook(dev(hooks::RESTART)),
            Entry::var(0x5000, "Diagnosis CAN bus error", Unsigned32, Ro, 0),
        ],
        comm::node_id_and_bitrate(&NODE).as_slice(),
        &[
            Entry::var(0x6000, "Operating parameters", Unsigned16, Rw, SCALING_BIT as u32)
                .range(SCALING_BIT as i64, (SCALING_BIT | DIRECTION_BIT) as i64)
                .group(APP)
                .hook(dev(hooks::OPERATING_PARAMETERS)),
            Entry::var(0x6001, "Measuring steps per revolution", Unsigned32, Rw, PHYSICAL_STEPS)
                .range(1, MAX_APU as i64)
                .group(APP)
                .hook(dev(hooks::APU)),
            Entry::var(0x6002, "Total measuring range in measuring steps", Unsigned32, Rw, r as u32)
                .range(n, max_pos + 1)
                .group(APP)
                .hook(dev(hooks::TOTAL_RANGE)),
            Entry::var(0x6003, "Preset value", Integer32, Rw, 0).range(0, max_pos).group(APP).hook(dev(hooks::PRESET)),
            Entry::var(0x6004, "Position value", Unsigned32, Ro, 0).pdo(),
            Entry::var(0x600C, "Position raw value", Unsigned32, Ro, 0),
            Entry::array(0x6030, "Speed value", 1, Ro),
            Entry::member(0x6030, 1, "Speed value channel 1", Integer16, Ro, 0).pdo(),
            Entry::record(0x6031, "Speed parameters", 4, Ro),
            Entry::member(0x6031, 1, "Speed source selector", Unsigned8, Rw, 2).range(2, 2).group(APP),
            Entry::member(0x6031, 2, "Speed integration time", Unsigned16, Ro, 100).group(APP),
            Entry::member(0x6031, 3, "Speed multiplier", Unsigned16, Rw, 1).range(1, 1).group(APP),
            Entry::member(0x6031, 4, "Speed divisor", Unsigned16, Rw, 1).range(1, 1).group(APP),
            // A4: one value with 3000h.03, so its default is 3000h.03's 50 ms (printed 0).
            Entry::var(0x6200, "Cyclic timer", Unsigned16, Rw, DEFAULT_CYCLE_MS as u32)
                .range(0, 0xFFFF)
                .group(APP)
                .hook(dev(hooks::CYCLE_TIMER)),
        ],
        &rotary::status_rows(turns.revolutions(), dev(hooks::IN_RANGE)),
    ])
}

/// Where the encoder's objects sit in every WV58MR table (the four share one layout; a test
/// checks them).
pub static ENCODER_ENTRIES: crate::devices::wv5800m::Entries = crate::devices::wv5800m::Entries::of(&MT12);

/// Where the WV58MR's own objects sit in every WV58MR table ([`Entries::of`]).
pub static ENTRIES_OF_MR: Entries = Entries::of(&MT12);

/// The positions of the WV58MR's own objects its device code reads and writes.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Entries {
    /// 1018h.04 serial number.
    pub serial: u8,
    /// 3000h.03 cycle time of the position PGN (one value with 6200h).
    pub position_cycle: u8,
    /// 3001h.01 the NAME's identity number.
    pub identity: u8,
}

impl Entries {
    /// The positions in `table` (a `const`: the build fails if one is not declared).
    pub const fn of(table: &[Entry]) -> Entries {
        use crate::encoder::position;
        Entries {
            serial: position(table, 0x1018, 4),
            position_cycle: position(table, 0x3000, 3),
            identity: position(table, 0x3001, 1),
        }
    }
}

static ST: [Entry; ENTRIES] = table(Turns::Single);
static MT4: [Entry; ENTRIES] = table(Turns::Multi4);
static MT8: [Entry; ENTRIES] = table(Turns::Multi8);
static MT12: [Entry; ENTRIES] = table(Turns::Multi12);

/// The dictionary of a WV58MR with `turns`, sorted by (index, sub). WV58MR and WH58MR share
/// it (the manual names no difference, and the device has no 1008h).
#[inline]
pub const fn table_of(turns: Turns) -> &'static [Entry] {
    match turns {
        Turns::Single => &ST,
        Turns::Multi4 => &MT4,
        Turns::Multi8 => &MT8,
        Turns::Multi12 => &MT12,
    }
}
