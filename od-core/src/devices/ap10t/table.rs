//! The AP10T's object dictionary (manual "AP10T – Set point display with CANopen interface",
//! modification status 037/22, chapter 5): every row the manual prints, with its types, access
//! rights, defaults, limits and storage groups; factory node-ID 7Dh.
//!
//! The communication rows (1000h-1FFFh, 5F0Ah) come from [`comm`]; the rest are the display's
//! own. Rows the manual calls "not used" (1400h/1401h/1800h/1801h sub 4, 1800h/1801h sub 6) and
//! the undocumented 5F1Bh sub 2 are absent: an access answers 06090011h (AP10T A26, A47).
//! 5F1Dh, the set points the TPDOs carry, has no SDO access (06010000h, AP10T A24): its rows are
//! [`Access::PdoOnly`]. The decisions are D-AP-14 … in `docs/decisions.md`, "AP10T".

use crate::bitrate::Bitrate;
use crate::devices::comm::{self, AutoId, CanOpen, Identity, NodeIdAndBitrate, Pdo, Profile, Serial};
use crate::od::{Access, Access::*, DataType::*, Entry, Group, Hook};

use super::panel::PANEL_OBJECTS;

/// Device-specific write hooks of the AP10T (`Hook::Device(n)`).
pub mod hooks {
    /// 6200h cycle timer and 1800h.05 event timer: one value in two objects.
    pub const CYCLE_TIMER: u8 = 1;
    /// 5F0Ah.02: starts the Auto-ID.
    pub const AUTO_ID: u8 = 2;
    /// A parameter of the front panel (2003h, 2004h, 2005h.01/.02, 5F0Bh, 5F11h, 5F12h, 5F1Ch):
    /// the panel takes the new value at once. The hook of the `i`th of
    /// [`PANEL_OBJECTS`](super::PANEL_OBJECTS) is `PANEL + i`, so the write finds its field
    /// without a search.
    pub const PANEL: u8 = 16;
    /// 5F09h.01 external heartbeat time: 0 or 10..65535 ms; 5F09h.02 its source.
    pub const EXTERNAL_HEARTBEAT: u8 = 4;
}

const MANUF: Group = Group::Manuf;
const APP: Group = Group::App;
const fn dev(h: u8) -> Hook {
    Hook::Device(h)
}

/// Factory node-ID (5F0Ah.01).
pub const DEFAULT_NODE_ID: u8 = 0x7D;
/// Factory 5F0Ah.03: automatic bit-rate detection.
pub const DEFAULT_BITRATE_CODE: u8 = 0;
/// 5F0Ah.03 value "Auto baud".
pub const AUTO_BAUD: u8 = 0;

/// The 5F0Ah.03 coding (manual 5F0Ah): 1 = 125 … 5 = 1000 kbit/s; 0 is automatic detection
/// and names no rate.
pub const BITRATE_CODES: &[(u32, Bitrate)] =
    &[(1, Bitrate::K125), (2, Bitrate::K250), (3, Bitrate::K500), (4, Bitrate::K800), (5, Bitrate::K1000)];

/// Entries in the AP10T dictionary: the 131 rows of the digest's table less the six "not used"
/// sub-indices and the undocumented 5F1Bh sub 2.
pub const ENTRIES: usize = 124;

/// RPDO1 maps set point 1 (5F16h sub 3, 4) and the control word, RPDO2 set point 2 (sub 1, 2)
/// and the control word (manual Table 8, 1600h/1601h).
const RPDO1_MAPPING: [u32; 3] = [0x5F16_0320, 0x5F16_0410, 0x5F0C_0010];
const RPDO2_MAPPING: [u32; 3] = [0x5F16_0120, 0x5F16_0210, 0x5F0C_0010];
/// TPDO1 carries set point 1 (5F1Dh sub 3, 4) and the status word, TPDO2 set point 2 (sub 1,
/// 2) and the status word (manual Table 9, 1A00h/1A01h).
const TPDO1_MAPPING: [u32; 3] = [0x5F1D_0320, 0x5F1D_0410, 0x5F19_0010];
const TPDO2_MAPPING: [u32; 3] = [0x5F1D_0120, 0x5F1D_0210, 0x5F19_0010];

/// The communication profile as the manual prints it: device type 196h ("not an encoder"),
/// "AP10T", "V001", "V100", identity 195h / FFFFFFFFh / 0 / FFFFFFFFh (the serial number a
/// constant "compatibility entry"), read-only record heads; RPDO1/RPDO2 asynchronous (FFh),
/// TPDO1 asynchronous by the event timer (FEh, timer = 6200h), TPDO2 on every SYNC (1).
const PROFILE: Profile = Profile {
    device_type: 0x0000_0196,
    status_register: true,
    device_name: Some("AP10T"),
    hardware_version: Some("V001"),
    software_version: "V100",
    identity: Identity { revision: 0, ..Identity::siko(Serial::Fixed(0xFFFF_FFFF)) },
    heads: Ro,
    canopen: Some(CanOpen {
        rpdos: &[Pdo::new(0xFF, &RPDO1_MAPPING), Pdo::new(0xFF, &RPDO2_MAPPING)],
        // TPDO2's transmission type is checked by the PDO service (D-PDO-3: 1..240, FCh, FDh),
        // not by limits, which would refuse the manual's FDh "RTR only".
        tpdos: &[Pdo::new(0xFE, &TPDO1_MAPPING).event_timer(dev(hooks::CYCLE_TIMER)), Pdo::new(0x01, &TPDO2_MAPPING)],
    }),
};

/// 5F0Ah: node-ID 7Dh (1..127), Auto-ID node-ID (sub 2), baud rate 0 = auto (0..5).
const NODE: NodeIdAndBitrate = NodeIdAndBitrate {
    auto_id: Some(AutoId { default: DEFAULT_NODE_ID, limits: (1, 127), hook: dev(hooks::AUTO_ID) }),
    head: Ro,
    ..NodeIdAndBitrate::new(DEFAULT_NODE_ID, (1, 127), DEFAULT_BITRATE_CODE, (0, 5))
};

/// A panel parameter: UNSIGNED8, rw, stored with the manufacturer parameters.
const fn panel(index: u16, sub: u8, name: &'static str, default: u32, hi: i64) -> Entry {
    Entry::member(index, sub, name, Unsigned8, Rw, default).range(0, hi).group(MANUF).hook(dev(hooks::PANEL))
}

/// A panel variable at sub-index 0.
const fn panel_var(index: u16, name: &'static str, default: u32, lo: i64, hi: i64) -> Entry {
    Entry::var(index, name, Unsigned8, Rw, default).range(lo, hi).group(MANUF).hook(dev(hooks::PANEL))
}

const ROWS_CONST: [Entry; ENTRIES] = panel_hooks(comm::join(&[
    comm::rows(&PROFILE).as_slice(),
    &[
        panel_var(0x2003, "Key actuation enable (2003h)", 1, 0, 1),
        panel_var(0x2004, "Key actuation enable (2004h)", 1, 0, 1),
        Entry::record(0x2005, "Configuration enable via keyboard", 3, Ro),
        panel(0x2005, 1, "Key enable", 1, 1),
        Entry::member(0x2005, 2, "Key enable time", Unsigned8, Rw, 5).range(1, 60).group(MANUF).hook(dev(hooks::PANEL)),
        Entry::member(0x2005, 3, "For internal use only", Unsigned32, Rw, 0).range(0, 999_999).group(MANUF),
        Entry::var(0x5000, "Diagnosis CAN bus error", Unsigned32, Ro, 0),
        Entry::record(0x5F09, "External heartbeat", 2, Ro),
        Entry::member(0x5F09, 1, "External heartbeat timer", Unsigned16, Rw, 0)
            .group(MANUF)
            .hook(dev(hooks::EXTERNAL_HEARTBEAT)),
        Entry::member(0x5F09, 2, "External heartbeat source", Unsigned8, Rw, 0)
            .range(0, 1)
            .group(MANUF)
            .hook(dev(hooks::EXTERNAL_HEARTBEAT)),
    ],
    comm::node_id_and_bitrate(&NODE).as_slice(),
    &[
        // 5F0Bh is rw but "EEPROM no": not stored (AP10T A10).
        Entry::var(0x5F0B, "Display in the 2nd row", Unsigned8, Rw, 0).range(0, 1).hook(dev(hooks::PANEL)),
        Entry::var(0x5F0C, "Control word", Unsigned16, Ro, 0).pdo(),
        panel_var(0x5F11, "Decimal places", 0, 0, 4),
        Entry::record(0x5F12, "Display orientation and LEDs", 9, Ro),
        panel(0x5F12, 1, "Display orientation", 0, 1),
        panel(0x5F12, 2, "LED1 green left", 1, 1),
        panel(0x5F12, 3, "LED2 red left", 1, 1),
        panel(0x5F12, 4, "LED3 green right", 1, 1),
        panel(0x5F12, 5, "LED4 red right", 1, 1),
        panel(0x5F12, 6, "FLASH LED", 0, 1),
        panel(0x5F12, 7, "Backlight white", 1, 1),
        panel(0x5F12, 8, "Backlight red", 1, 1),
        panel(0x5F12, 9, "FLASH backlight", 0, 1),
        Entry::record(0x5F16, "Read target value", 4, Ro),
        Entry::member(0x5F16, 1, "Set point 2 (4 LSB bytes)", Unsigned32, Ro, 0).pdo(),
        Entry::member(0x5F16, 2, "Set point 2 (2 MSB bytes)", Unsigned32, Ro, 0).pdo(),
        Entry::member(0x5F16, 3, "Set point 1 (4 LSB bytes)", Unsigned32, Ro, 0).pdo(),
        Entry::member(0x5F16, 4, "Set point 1 (2 MSB bytes)", Unsigned32, Ro, 0).pdo(),
        Entry::var(0x5F19, "Status word", Unsigned16, Ro, 0).pdo(),
        Entry::record(0x5F1B, "Sensor type", 2, Ro),
        Entry::member(0x5F1B, 1, "Read sensor type", Unsigned8, Ro, 3).group(MANUF),
        // Sub 0 carries a value, the acknowledgement key selection (AP10T A27).
        Entry::record(0x5F1C, "Acknowledgement settings", 0, Rw)
            .named("Acknowledgement key selection")
            .range(0, 2)
            .group(MANUF)
            .hook(dev(hooks::PANEL)),
        panel(0x5F1C, 1, "Flashing with unacknowledged set point", 0, 1),
        Entry::record(0x5F1D, "Dummy (read set points)", 4, Access::PdoOnly),
        Entry::member(0x5F1D, 1, "Dummy: set point 2 (4 LSB bytes)", Unsigned32, Access::PdoOnly, 0).pdo(),
        Entry::member(0x5F1D, 2, "Dummy: set point 2 (2 MSB bytes)", Unsigned32, Access::PdoOnly, 0).pdo(),
        Entry::member(0x5F1D, 3, "Dummy: set point 1 (4 LSB bytes)", Unsigned32, Access::PdoOnly, 0).pdo(),
        Entry::member(0x5F1D, 4, "Dummy: set point 1 (2 MSB bytes)", Unsigned32, Access::PdoOnly, 0).pdo(),
        Entry::var(0x6200, "Cycle timer", Unsigned16, Rw, 0).group(APP).hook(dev(hooks::CYCLE_TIMER)),
        Entry::var(0x6503, "Alarms", Unsigned16, Ro, 0),
        Entry::var(0x6504, "Supported alarms", Unsigned16, Ro, 0),
        Entry::var(0x6505, "Warnings", Unsigned16, Ro, 0),
        Entry::var(0x6506, "Supported warnings", Unsigned16, Ro, 0),
        Entry::var(0x6507, "Profile and software version", Unsigned32, Ro, 0x012D_0302),
        Entry::var(0x6508, "Operating time", Unsigned32, Ro, 0xFFFF_FFFF),
        Entry::var(0x650B, "Serial number", Unsigned32, Ro, 0xFFFF_FFFF),
    ],
]));

/// Numbers the panel parameters' hooks: the `i`th of [`PANEL_OBJECTS`] gets
/// [`hooks::PANEL`]` + i` (those with another hook, 5F0Ah's, keep it).
const fn panel_hooks(mut rows: [Entry; ENTRIES]) -> [Entry; ENTRIES] {
    let mut i = 0;
    while i < PANEL_OBJECTS.len() {
        let p = crate::encoder::position(&rows, PANEL_OBJECTS[i].0, PANEL_OBJECTS[i].1) as usize;
        if matches!(rows[p].hook, Hook::Device(hooks::PANEL)) {
            rows[p].hook = Hook::Device(hooks::PANEL + i as u8);
        }
        i += 1;
    }
    rows
}

static ROWS: [Entry; ENTRIES] = ROWS_CONST;

/// The AP10T dictionary, sorted by (index, sub).
pub static TABLE: &[Entry] = &ROWS;

/// Positions in [`TABLE`] of the entries the device reads and writes itself, found when the
/// table is declared (the build fails if one is missing) instead of looked up at every use.
pub mod at {
    use super::{PANEL_OBJECTS, ROWS_CONST};
    use crate::encoder::position;

    const fn pos(index: u16, sub: u8) -> usize {
        position(&ROWS_CONST, index, sub) as usize
    }

    /// 1002h manufacturer status register.
    pub const STATUS_REGISTER: usize = pos(0x1002, 0);
    /// 1003h sub 0, the number of errors; sub n follows at `ERROR_HISTORY + n`.
    pub const ERROR_HISTORY: usize = pos(0x1003, 0);
    /// 1800h.05 TPDO1 event timer.
    pub const EVENT_TIMER: usize = pos(0x1800, 5);
    /// 5000h CAN bus error diagnosis.
    pub const CAN_DIAGNOSIS: usize = pos(0x5000, 0);
    /// 5F09h.01 external heartbeat time, .02 its source.
    pub const EXTERNAL_HEARTBEAT_TIME: usize = pos(0x5F09, 1);
    /// 5F09h.02 external heartbeat source.
    pub const EXTERNAL_HEARTBEAT_SOURCE: usize = pos(0x5F09, 2);
    /// 5F0Ah sub 1 (node-ID); sub `s` follows at `NODE_ID + s - 1`.
    pub const NODE_ID: usize = pos(0x5F0A, 1);
    /// 5F0Ch control word.
    pub const CONTROL_WORD: usize = pos(0x5F0C, 0);
    /// 5F16h sub 1 (set point 2, four bytes); subs 2..=4 follow.
    pub const RPDO_SET_POINTS: usize = pos(0x5F16, 1);
    /// 5F19h status word.
    pub const STATUS_WORD: usize = pos(0x5F19, 0);
    /// 5F1Dh sub 1 (set point 2, four bytes); subs 2..=4 follow.
    pub const TPDO_SET_POINTS: usize = pos(0x5F1D, 1);
    /// 6200h cycle timer.
    pub const CYCLE_TIMER: usize = pos(0x6200, 0);
    /// The positions of `PANEL_OBJECTS`, in its order.
    pub const PANEL: [u8; PANEL_OBJECTS.len()] = {
        let mut out = [0; PANEL_OBJECTS.len()];
        let mut i = 0;
        while i < out.len() {
            out[i] = position(&ROWS_CONST, PANEL_OBJECTS[i].0, PANEL_OBJECTS[i].1);
            i += 1;
        }
        out
    };
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::od::{CoreHook, Od};

    #[test]
    fn the_positions_the_device_uses() {
        let od = Od::new(TABLE, DEFAULT_NODE_ID);
        let pos = |i, s| od.pos(i, s).unwrap();
        for sub in 0..=8u8 {
            assert_eq!(pos(0x1003, sub), at::ERROR_HISTORY + sub as usize);
        }
        for sub in 1..=4u8 {
            assert_eq!(pos(0x5F16, sub), at::RPDO_SET_POINTS + sub as usize - 1);
            assert_eq!(pos(0x5F1D, sub), at::TPDO_SET_POINTS + sub as usize - 1);
        }
        for sub in 1..=3u8 {
            assert_eq!(pos(0x5F0A, sub), at::NODE_ID + sub as usize - 1);
        }
        assert_eq!(pos(0x5F09, 2), at::EXTERNAL_HEARTBEAT_TIME + 1);
        assert_eq!(
            [at::STATUS_REGISTER, at::EVENT_TIMER, at::CAN_DIAGNOSIS, at::EXTERNAL_HEARTBEAT_SOURCE],
            [pos(0x1002, 0), pos(0x1800, 5), pos(0x5000, 0), pos(0x5F09, 2)]
        );
        assert_eq!(
            [at::CONTROL_WORD, at::STATUS_WORD, at::CYCLE_TIMER],
            [pos(0x5F0C, 0), pos(0x5F19, 0), pos(0x6200, 0)]
        );
        for (i, &(index, sub)) in PANEL_OBJECTS.iter().enumerate() {
            assert_eq!(at::PANEL[i] as usize, pos(index, sub));
        }
    }

    #[test]
    fn panel_hooks_number_the_panel_parameters() {
        // Every panel parameter but 5F0Ah's two (the node's own rows) names its place in
        // PANEL_OBJECTS; no other row has a hook in that range.
        for (i, &(index, sub)) in PANEL_OBJECTS.iter().enumerate() {
            let e = &TABLE[at::PANEL[i] as usize];
            let want = if index == 0x5F0A { e.hook } else { Hook::Device(hooks::PANEL + i as u8) };
            assert_eq!(e.hook, want, "{index:04X}h.{sub}");
        }
        let numbered = TABLE.iter().filter(|e| matches!(e.hook, Hook::Device(h) if h >= hooks::PANEL)).count();
        assert_eq!(numbered, PANEL_OBJECTS.len() - 2);
    }

    #[test]
    fn the_table_builds_with_factory_values() {
        assert_eq!(TABLE.len(), ENTRIES);
        let od = Od::new(TABLE, DEFAULT_NODE_ID);
        assert_eq!(od.value(0x1014, 0), Some(0xFD));
        assert_eq!(od.value(0x1400, 1), Some(0x27D));
        assert_eq!(od.value(0x1401, 1), Some(0x37D));
        assert_eq!(od.value(0x1800, 1), Some(0x1FD));
        assert_eq!(od.value(0x1801, 1), Some(0x2FD));
        assert_eq!(od.value(0x1200, 1), Some(0x67D));
        assert_eq!(od.value(0x5F0A, 1), Some(0x7D));
        assert_eq!(od.value(0x5F0A, 3), Some(0));
        assert_eq!(od.value(0x5F1C, 0), Some(0));
        let e = |i, s| od.entry(od.pos(i, s).unwrap());
        assert_eq!(e(0x5F0A, 1).hook, Hook::Core(CoreHook::PendingNodeId));
        assert_eq!(e(0x5F0A, 3).hook, Hook::Core(CoreHook::PendingBitrate));
        assert_eq!(e(0x5F0A, 2).hook, Hook::Device(hooks::AUTO_ID));
        assert!(od.pos(0x5F1B, 2).is_none() && od.pos(0x1800, 4).is_none() && od.pos(0x1801, 6).is_none());
        // The stored parameters fit the image.
        let stored = TABLE.iter().filter(|e| e.group != Group::None).count();
        assert_eq!(stored, 47);
    }
}
