//! The communication profile, declared once: the CiA 301 rows (1000h-1FFFh) and the SIKO 5F0Ah
//! node-ID/bit-rate object every device table holds, built at compile time from a small
//! parameter struct, and the helper that joins them with a device's own rows into its `static`
//! table.
//!
//! The manuals of the five devices print the same communication rows with a handful of
//! differences: the device type, the three strings, the identity values, which TPDOs and RPDOs
//! there are with their defaults, limits and fixed mappings, the 5F0Ah defaults and ranges, and
//! for the J1939 WV58MR the absence of every CANopen service object. A device states those in a
//! [`Profile`] (and a [`NodeIdAndBitrate`]); [`rows`] and [`node_id_and_bitrate`] write the
//! rows, and [`join`] concatenates them with the device's own rows:
//!
//! ```
//! use od_core::devices::comm::{self, CanOpen, Identity, NodeIdAndBitrate, Pdo, Profile, Serial};
//! use od_core::od::{Access, DataType, Entry};
//!
//! const PROFILE: Profile = Profile {
//!     device_type: 0x000A_0196,
//!     status_register: true,
//!     device_name: Some("SGH10"),
//!     hardware_version: Some("V100"),
//!     software_version: "V100",
//!     identity: Identity::siko(Serial::Factory(1)),
//!     heads: Access::Const,
//!     canopen: Some(CanOpen { rpdos: &[], tpdos: &[Pdo::new(0xFE, &[0x6004_0020])] }),
//! };
//! const NODE: NodeIdAndBitrate = NodeIdAndBitrate::new(1, (1, 127), 5, (1, 7));
//!
//! static TABLE: [Entry; 50] = comm::join(&[
//!     comm::rows(&PROFILE).as_slice(),
//!     &[Entry::var(0x5000, "Diagnosis CAN bus error", DataType::Unsigned32, Access::Ro, 0)],
//!     comm::node_id_and_bitrate(&NODE).as_slice(),
//!     &[Entry::var(0x6004, "Position value", DataType::Unsigned32, Access::Ro, 0).pdo()],
//! ]);
//! assert_eq!(TABLE[0].index, 0x1000);
//! ```
//!
//! Everything here is `const fn` and runs while the table's `static` is compiled: the firmware
//! keeps the same table in flash as a hand-written one, and a declaration mistake (a part out
//! of (index, sub) order, a table length that is not the declared one, a member without its
//! object, more than four PDOs of one direction) fails the build with the message of its
//! `assert!`.
//!
//! Every record and array the builder writes is laid out as the SIKO manuals print it: PDO
//! communication parameters with sub-indices 1, 2, 3 and 5 (no 4, no 6), the inhibit time
//! read-only 0, and fixed, read-only PDO mappings.

use crate::od::{Access, CoreHook, DataType, Entry, Group, Hook, Kind, MAX_ENTRIES};

/// The serial number in 1018h sub 4.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Serial {
    /// Written at the factory: kept in flash as [`Group::Factory`], never touched by a user
    /// store or restore; the value is the default until the factory writes it.
    Factory(u32),
    /// A constant (the manual calls the entry a compatibility entry, "not supported").
    Fixed(u32),
}

/// The identity object, 1018h.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Identity {
    /// Sub 1: vendor-ID.
    pub vendor_id: u32,
    /// Sub 2: product code.
    pub product_code: u32,
    /// Sub 3: revision number.
    pub revision: u32,
    /// Sub 4: serial number.
    pub serial: Serial,
}

impl Identity {
    /// SIKO's vendor-ID, assigned by CiA.
    pub const SIKO_VENDOR_ID: u32 = 0x0000_0195;

    /// SIKO's identity as the encoder manuals print it: vendor-ID 195h, product code and
    /// revision number FFFFFFFFh ("not supported"), and `serial`.
    pub const fn siko(serial: Serial) -> Identity {
        Identity { vendor_id: Identity::SIKO_VENDOR_ID, product_code: 0xFFFF_FFFF, revision: 0xFFFF_FFFF, serial }
    }
}

/// One PDO: its communication parameter record (14xxh/18xxh) and its fixed mapping
/// (16xxh/1Axxh). The PDO's number is its place in [`CanOpen::tpdos`] or [`CanOpen::rpdos`].
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Pdo {
    /// Sub 2: the default transmission type.
    pub transmission: u8,
    /// Sub 2: the limits the manual gives, if any.
    pub transmission_limits: Option<(u8, u8)>,
    /// Sub 5, the event timer: `Some(hook)` writable, stored with the communication
    /// parameters, its write side effect `hook`; `None` read-only 0.
    pub event_timer: Option<Hook>,
    /// The mapped objects (sub 1 ..), each `index << 16 | sub << 8 | bits`; read-only.
    pub mapping: &'static [u32],
}

impl Pdo {
    /// A PDO with transmission type `transmission` (no limits), a read-only event timer and
    /// the fixed `mapping`.
    pub const fn new(transmission: u8, mapping: &'static [u32]) -> Pdo {
        Pdo { transmission, transmission_limits: None, event_timer: None, mapping }
    }

    /// The transmission type is limited to `lo ..= hi`.
    pub const fn transmission_limits(mut self, lo: u8, hi: u8) -> Pdo {
        self.transmission_limits = Some((lo, hi));
        self
    }

    /// The event timer is writable, with `hook` as its write side effect.
    pub const fn event_timer(mut self, hook: Hook) -> Pdo {
        self.event_timer = Some(hook);
        self
    }
}

/// The CANopen-only communication objects: SYNC (1005h), guarding (100Ch/100Dh), EMCY (1014h),
/// heartbeat (1017h), the SDO server (1200h) and the PDOs. A J1939 device has none of them.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct CanOpen {
    /// RPDO1 .. (1400h.., 1600h..), at most four.
    pub rpdos: &'static [Pdo],
    /// TPDO1 .. (1800h.., 1A00h..), at most four.
    pub tpdos: &'static [Pdo],
}

/// What a device's communication profile (1000h-1FFFh) is made of: what [`rows`] writes.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Profile {
    /// 1000h device type.
    pub device_type: u32,
    /// Is there a 1002h manufacturer status register?
    pub status_register: bool,
    /// 1008h manufacturer device name, if the manual lists it.
    pub device_name: Option<&'static str>,
    /// 1009h manufacturer hardware version, if the manual lists it.
    pub hardware_version: Option<&'static str>,
    /// 100Ah manufacturer software version.
    pub software_version: &'static str,
    /// 1018h.
    pub identity: Identity,
    /// Access of sub 0 ("highest sub-index supported") of the records and arrays the builder
    /// writes, as the manual prints it (1003h's, the number of errors, is always rw).
    pub heads: Access,
    /// The CANopen services' objects; `None` for a J1939 device.
    pub canopen: Option<CanOpen>,
}

/// Depth of 1003h, the pre-defined error field (every manual: the eight most recent errors).
pub const ERROR_HISTORY: u8 = 8;

/// 5F0Ah, SIKO's node-ID and bit-rate object: the node-ID and bit-rate code the node takes at
/// its next reset (hooked [`CoreHook::PendingNodeId`] and [`CoreHook::PendingBitrate`], the
/// values LSS configures too), stored with the manufacturer parameters.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct NodeIdAndBitrate {
    /// Sub 1: default node-ID (J1939: source address).
    pub node_id: u8,
    /// Sub 1: its limits.
    pub node_ids: (u8, u8),
    /// Sub 2 (sub 3 with an auto-ID): default bit-rate code, in the device's own coding.
    pub bitrate: u8,
    /// Its limits.
    pub bitrates: (u8, u8),
    /// Sub 2, "node-ID for the auto-ID function" (the AP10T), if there is one: its default,
    /// limits and write side effect. The bit rate moves to sub 3.
    pub auto_id: Option<AutoId>,
    /// Access of sub 0, as the manual prints it.
    pub head: Access,
}

/// 5F0Ah sub 2 of a device with an auto-ID function ([`NodeIdAndBitrate::auto_id`]).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct AutoId {
    /// Default.
    pub default: u8,
    /// Limits.
    pub limits: (u8, u8),
    /// The write side effect (the device starts the auto-ID procedure).
    pub hook: Hook,
}

impl NodeIdAndBitrate {
    /// Node-ID `node_id` in `node_ids`, bit-rate code `bitrate` in `bitrates`, no auto-ID, a
    /// constant sub 0.
    pub const fn new(node_id: u8, node_ids: (u8, u8), bitrate: u8, bitrates: (u8, u8)) -> NodeIdAndBitrate {
        NodeIdAndBitrate { node_id, node_ids, bitrate, bitrates, auto_id: None, head: Access::Const }
    }
}

/// Most rows one [`Rows`] holds: as many as a whole dictionary ([`MAX_ENTRIES`]).
pub const ROWS_MAX: usize = MAX_ENTRIES;

/// Rows the builder wrote, sorted by (index, sub); a part of a table for [`join`]. A
/// compile-time value only: it is as large as [`ROWS_MAX`] entries.
#[derive(Clone, Copy, Debug)]
pub struct Rows {
    buf: [Entry; ROWS_MAX],
    len: usize,
}

/// Fills the unused part of a [`Rows`]; never read.
const UNUSED: Entry = Entry::var(0, "", DataType::Unsigned8, Access::Const, 0);

impl Rows {
    const fn new() -> Rows {
        Rows { buf: [UNUSED; ROWS_MAX], len: 0 }
    }

    const fn push(&mut self, e: Entry) {
        assert!(self.len < ROWS_MAX, "more rows than comm::ROWS_MAX");
        if self.len > 0 {
            let last = &self.buf[self.len - 1];
            assert!(before(last, &e), "comm: rows out of (index, sub) order");
        }
        self.buf[self.len] = e;
        self.len += 1;
    }

    /// The rows.
    pub const fn as_slice(&self) -> &[Entry] {
        self.buf.split_at(self.len).0
    }
}

/// Does `a` come before `b` in a table sorted by (index, sub)?
const fn before(a: &Entry, b: &Entry) -> bool {
    a.index < b.index || (a.index == b.index && a.sub < b.sub)
}

/// Concatenates `parts` into one table of `N` entries, checking at compile time (for a
/// `static`) that the parts hold `N` entries together, that the result is sorted strictly by
/// (index, sub), and that each record or array member follows its object's sub 0 or another
/// member of the same object.
///
/// In a `static`, a mistake fails the build:
///
/// ```compile_fail
/// use od_core::devices::comm;
/// use od_core::od::{Access, DataType, Entry};
///
/// // 1001h before 1000h: "comm::join: entries out of (index, sub) order".
/// static TABLE: [Entry; 2] = comm::join(&[
///     &[Entry::var(0x1001, "Error register", DataType::Unsigned8, Access::Ro, 0)],
///     &[Entry::var(0x1000, "Device type", DataType::Unsigned32, Access::Ro, 0)],
/// ]);
/// ```
pub const fn join<const N: usize>(parts: &[&[Entry]]) -> [Entry; N] {
    let mut out = [UNUSED; N];
    let mut n = 0;
    let mut p = 0;
    while p < parts.len() {
        let part = parts[p];
        let mut i = 0;
        while i < part.len() {
            assert!(n < N, "comm::join: the parts hold more entries than the table's length");
            let e = part[i];
            if n > 0 {
                let last = &out[n - 1];
                assert!(before(last, &e), "comm::join: entries out of (index, sub) order");
                if matches!(e.kind(), Kind::Member) {
                    assert!(last.index == e.index, "comm::join: a member without its object's sub 0");
                }
            } else {
                assert!(!matches!(e.kind(), Kind::Member), "comm::join: a member without its object's sub 0");
            }
            out[n] = e;
            n += 1;
            i += 1;
        }
        p += 1;
    }
    assert!(n == N, "comm::join: the parts hold fewer entries than the table's length");
    out
}

const COMM: Group = Group::Comm;
const MANUF: Group = Group::Manuf;
const fn core(h: CoreHook) -> Hook {
    Hook::Core(h)
}

const ERROR_FIELDS: [&str; ERROR_HISTORY as usize] = [
    "Standard error field 1",
    "Standard error field 2",
    "Standard error field 3",
    "Standard error field 4",
    "Standard error field 5",
    "Standard error field 6",
    "Standard error field 7",
    "Standard error field 8",
];

/// Most PDOs of one direction the builder names (the CiA 301 pre-defined connection set).
pub const PDOS_MAX: usize = 4;
/// Most objects one PDO maps (eight bytes of at least 8 bits each).
pub const MAPPED_MAX: usize = 8;

/// Names of one direction's PDO objects.
struct PdoNames {
    /// 14xxh/18xxh.
    comm: [&'static str; PDOS_MAX],
    /// Sub 1.
    cob_id: [&'static str; PDOS_MAX],
    /// 16xxh/1Axxh.
    mapping: [&'static str; PDOS_MAX],
}

const TPDO_NAMES: PdoNames = PdoNames {
    comm: [
        "TPDO1 communication parameter",
        "TPDO2 communication parameter",
        "TPDO3 communication parameter",
        "TPDO4 communication parameter",
    ],
    cob_id: ["COB-ID used by TPDO1", "COB-ID used by TPDO2", "COB-ID used by TPDO3", "COB-ID used by TPDO4"],
    mapping: [
        "TPDO1 mapping parameter",
        "TPDO2 mapping parameter",
        "TPDO3 mapping parameter",
        "TPDO4 mapping parameter",
    ],
};

const RPDO_NAMES: PdoNames = PdoNames {
    comm: [
        "RPDO1 communication parameter",
        "RPDO2 communication parameter",
        "RPDO3 communication parameter",
        "RPDO4 communication parameter",
    ],
    cob_id: ["COB-ID used by RPDO1", "COB-ID used by RPDO2", "COB-ID used by RPDO3", "COB-ID used by RPDO4"],
    mapping: [
        "RPDO1 mapping parameter",
        "RPDO2 mapping parameter",
        "RPDO3 mapping parameter",
        "RPDO4 mapping parameter",
    ],
};

const MAPPED_OBJECTS: [&str; MAPPED_MAX] = [
    "Mapped object 1",
    "Mapped object 2",
    "Mapped object 3",
    "Mapped object 4",
    "Mapped object 5",
    "Mapped object 6",
    "Mapped object 7",
    "Mapped object 8",
];

/// The communication-profile rows of `p`, 1000h-1FFFh, in (index, sub) order: for every
/// device the identity (1000h, 1008h-100Ah, 1018h), the error history (1001h-1003h) and
/// store/restore (1010h, 1011h); with [`Profile::canopen`] also SYNC, guarding, EMCY,
/// heartbeat, the SDO server and the PDOs.
pub const fn rows(p: &Profile) -> Rows {
    let mut r = Rows::new();
    r.push(Entry::var(0x1000, "Device type", DataType::Unsigned32, Access::Ro, p.device_type));
    error_history(&mut r, p);
    if p.canopen.is_some() {
        r.push(
            Entry::var(0x1005, "COB-ID SYNC message", DataType::Unsigned32, Access::Rw, 0x80)
                .group(COMM)
                .hook(core(CoreHook::SyncCobId)),
        );
    }
    strings(&mut r, p);
    if p.canopen.is_some() {
        guarding(&mut r);
    }
    store_restore(&mut r, p);
    if p.canopen.is_some() {
        emcy_and_heartbeat(&mut r);
    }
    identity(&mut r, p);
    if let Some(c) = &p.canopen {
        sdo_server(&mut r, p);
        pdos(&mut r, p, c.rpdos, 0x1400, 0x200, &RPDO_NAMES);
        pdos(&mut r, p, c.tpdos, 0x1800, 0x180, &TPDO_NAMES);
    }
    r
}

/// 1001h error register, 1002h manufacturer status register (if any), 1003h pre-defined error
/// field (sub 0, the number of errors, takes only 0, which clears the history).
const fn error_history(r: &mut Rows, p: &Profile) {
    r.push(Entry::var(0x1001, "Error register", DataType::Unsigned8, Access::Ro, 0));
    if p.status_register {
        r.push(Entry::var(0x1002, "Manufacturer status register", DataType::Unsigned32, Access::Ro, 0));
    }
    r.push(
        Entry::array(0x1003, "Pre-defined error field", ERROR_HISTORY, Access::Rw)
            .named("Number of errors")
            .with_default(0)
            .group(COMM)
            .hook(core(CoreHook::ErrorHistory)),
    );
    let mut i = 0;
    while i < ERROR_HISTORY as usize {
        r.push(Entry::member(0x1003, i as u8 + 1, ERROR_FIELDS[i], DataType::Unsigned32, Access::Ro, 0).group(COMM));
        i += 1;
    }
}

/// 1008h, 1009h, 100Ah.
const fn strings(r: &mut Rows, p: &Profile) {
    if let Some(s) = p.device_name {
        r.push(Entry::string(0x1008, "Manufacturer device name", s));
    }
    if let Some(s) = p.hardware_version {
        r.push(Entry::string(0x1009, "Manufacturer hardware version", s));
    }
    r.push(Entry::string(0x100A, "Manufacturer software version", p.software_version));
}

/// 100Ch guard time, 100Dh life time factor.
const fn guarding(r: &mut Rows) {
    r.push(
        Entry::var(0x100C, "Guard time", DataType::Unsigned16, Access::Rw, 0)
            .group(COMM)
            .hook(core(CoreHook::Guarding)),
    );
    r.push(
        Entry::var(0x100D, "Life time factor", DataType::Unsigned8, Access::Rw, 0)
            .group(COMM)
            .hook(core(CoreHook::Guarding)),
    );
}

/// 1010h store parameters, 1011h restore default parameters: subs 1 all, 2 communication,
/// 3 application, 4 manufacturer; each reads 1 (on command only) and takes its signature.
const fn store_restore(r: &mut Rows, p: &Profile) {
    const STORE: [&str; 4] = [
        "Save all parameters",
        "Save communication parameters",
        "Save application parameters",
        "Save manufacturer parameters",
    ];
    const RESTORE: [&str; 4] = [
        "Restore all default parameters",
        "Restore communication default parameters",
        "Restore application default parameters",
        "Restore manufacturer default parameters",
    ];
    let objects = [
        (0x1010, "Store parameters", STORE, CoreHook::Store),
        (0x1011, "Restore default parameters", RESTORE, CoreHook::Restore),
    ];
    let mut o = 0;
    while o < objects.len() {
        let (index, object, names, hook) = objects[o];
        r.push(Entry::array(index, object, 4, p.heads));
        let mut i = 0;
        while i < names.len() {
            r.push(Entry::member(index, i as u8 + 1, names[i], DataType::Unsigned32, Access::Rw, 1).hook(core(hook)));
            i += 1;
        }
        o += 1;
    }
}

/// 1014h COB-ID EMCY (80h + node-ID), 1017h producer heartbeat time.
const fn emcy_and_heartbeat(r: &mut Rows) {
    r.push(
        Entry::var(0x1014, "COB-ID EMCY", DataType::Unsigned32, Access::Rw, 0)
            .plus_node_id(0x80)
            .group(COMM)
            .hook(core(CoreHook::EmcyCobId)),
    );
    r.push(
        Entry::var(0x1017, "Producer heartbeat time", DataType::Unsigned16, Access::Rw, 0)
            .group(COMM)
            .hook(core(CoreHook::HeartbeatTime)),
    );
}

/// 1018h identity object.
const fn identity(r: &mut Rows, p: &Profile) {
    let id = &p.identity;
    r.push(Entry::record(0x1018, "Identity object", 4, p.heads));
    r.push(Entry::member(0x1018, 1, "Vendor-ID", DataType::Unsigned32, Access::Ro, id.vendor_id));
    r.push(Entry::member(0x1018, 2, "Product code", DataType::Unsigned32, Access::Ro, id.product_code));
    r.push(Entry::member(0x1018, 3, "Revision number", DataType::Unsigned32, Access::Ro, id.revision));
    r.push(match id.serial {
        Serial::Factory(v) => {
            Entry::member(0x1018, 4, "Serial number", DataType::Unsigned32, Access::Ro, v).group(Group::Factory)
        }
        Serial::Fixed(v) => Entry::member(0x1018, 4, "Serial number", DataType::Unsigned32, Access::Ro, v),
    });
}

/// 1200h SDO server parameter: 600h/580h + node-ID, read-only.
const fn sdo_server(r: &mut Rows, p: &Profile) {
    r.push(Entry::record(0x1200, "SDO server parameter", 2, p.heads));
    r.push(
        Entry::member(0x1200, 1, "COB-ID client to server (rx)", DataType::Unsigned32, Access::Ro, 0)
            .plus_node_id(0x600),
    );
    r.push(
        Entry::member(0x1200, 2, "COB-ID server to client (tx)", DataType::Unsigned32, Access::Ro, 0)
            .plus_node_id(0x580),
    );
}

/// The communication parameter records (`comm_base` + n) of `list`, then their mappings
/// (`comm_base` + 200h + n); PDO n's COB-ID defaults to `cob_base` + 100h × n + node-ID.
const fn pdos(r: &mut Rows, p: &Profile, list: &[Pdo], comm_base: u16, cob_base: u32, names: &PdoNames) {
    assert!(list.len() <= PDOS_MAX, "comm: more than four PDOs of one direction");
    let mut n = 0;
    while n < list.len() {
        let pdo = &list[n];
        let index = comm_base + n as u16;
        r.push(Entry::record(index, names.comm[n], 5, p.heads));
        r.push(
            Entry::member(index, 1, names.cob_id[n], DataType::Unsigned32, Access::Rw, 0)
                .plus_node_id(cob_base + 0x100 * n as u32)
                .group(COMM)
                .hook(core(CoreHook::PdoCobId)),
        );
        let mut tt =
            Entry::member(index, 2, "Transmission type", DataType::Unsigned8, Access::Rw, pdo.transmission as u32);
        if let Some((lo, hi)) = pdo.transmission_limits {
            tt = tt.range(lo as i64, hi as i64);
        }
        r.push(tt.group(COMM).hook(core(CoreHook::PdoTransmissionType)));
        r.push(Entry::member(index, 3, "Inhibit time", DataType::Unsigned16, Access::Ro, 0));
        r.push(match pdo.event_timer {
            Some(hook) => {
                Entry::member(index, 5, "Event timer", DataType::Unsigned16, Access::Rw, 0).group(COMM).hook(hook)
            }
            None => Entry::member(index, 5, "Event timer", DataType::Unsigned16, Access::Ro, 0),
        });
        n += 1;
    }
    let mut n = 0;
    while n < list.len() {
        let mapping = list[n].mapping;
        assert!(mapping.len() <= MAPPED_MAX, "comm: more than eight mapped objects");
        let index = comm_base + 0x200 + n as u16;
        r.push(Entry::record(index, names.mapping[n], mapping.len() as u8, p.heads).named("Number of mapped objects"));
        let mut i = 0;
        while i < mapping.len() {
            r.push(Entry::member(index, i as u8 + 1, MAPPED_OBJECTS[i], DataType::Unsigned32, Access::Ro, mapping[i]));
            i += 1;
        }
        n += 1;
    }
}

/// 5F0Ah: node-ID (sub 1), the auto-ID node-ID if any (sub 2), bit-rate code (the last sub).
pub const fn node_id_and_bitrate(s: &NodeIdAndBitrate) -> Rows {
    let mut r = Rows::new();
    let (object, highest) = match s.auto_id {
        None => ("Node-ID and baud rate", 2),
        Some(_) => ("Node-ID, auto-ID and baud rate", 3),
    };
    r.push(Entry::record(0x5F0A, object, highest, s.head));
    r.push(
        Entry::member(0x5F0A, 1, "Node-ID", DataType::Unsigned8, Access::Rw, s.node_id as u32)
            .range(s.node_ids.0 as i64, s.node_ids.1 as i64)
            .group(MANUF)
            .hook(core(CoreHook::PendingNodeId))
            .factory_node_id(),
    );
    if let Some(a) = s.auto_id {
        r.push(
            Entry::member(
                0x5F0A,
                2,
                "Node-ID for the auto-ID function",
                DataType::Unsigned8,
                Access::Rw,
                a.default as u32,
            )
            .range(a.limits.0 as i64, a.limits.1 as i64)
            .group(MANUF)
            .hook(a.hook),
        );
    }
    r.push(
        Entry::member(0x5F0A, highest, "Baud rate", DataType::Unsigned8, Access::Rw, s.bitrate as u32)
            .range(s.bitrates.0 as i64, s.bitrates.1 as i64)
            .group(MANUF)
            .hook(core(CoreHook::PendingBitrate)),
    );
    r
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::od::{Default, Od};

    fn ids(rows: &[Entry]) -> impl Iterator<Item = (u16, u8)> + '_ {
        rows.iter().map(|e| (e.index, e.sub))
    }

    /// The J1939 WV58MR's shape: identity, error history and store/restore only, no 1002h,
    /// 1008h or 1009h.
    const J1939: Profile = Profile {
        device_type: 0x0002_0196,
        status_register: false,
        device_name: None,
        hardware_version: None,
        software_version: "V100",
        identity: Identity::siko(Serial::Factory(1)),
        heads: Access::Const,
        canopen: None,
    };

    #[test]
    fn a_j1939_profile_has_no_canopen_object() {
        let rows = rows(&J1939);
        let objects: heapless::Vec<u16, 16> = {
            let mut v = heapless::Vec::new();
            for e in rows.as_slice().iter().filter(|e| e.sub == 0) {
                v.push(e.index).unwrap();
            }
            v
        };
        assert_eq!(objects.as_slice(), &[0x1000, 0x1001, 0x1003, 0x100A, 0x1010, 0x1011, 0x1018]);
        assert_eq!(rows.as_slice().len(), 1 + 1 + 9 + 1 + 5 + 5 + 5);
        let serial = rows.as_slice().iter().find(|e| (e.index, e.sub) == (0x1018, 4)).unwrap();
        assert_eq!((serial.default(), serial.group), (Default::Value(1), Group::Factory));
    }

    /// The AP10T's shape: two RPDOs and two TPDOs of three mapped objects, read-only heads, a
    /// constant serial number and revision 0.
    const AP10T: Profile = Profile {
        device_type: 0x0000_0196,
        status_register: true,
        device_name: Some("AP10T"),
        hardware_version: Some("V001"),
        software_version: "V100",
        identity: Identity { revision: 0, ..Identity::siko(Serial::Fixed(0xFFFF_FFFF)) },
        heads: Access::Ro,
        canopen: Some(CanOpen {
            rpdos: &[Pdo::new(0xFF, &[0x5F16_0320, 0x5F16_0410, 0x5F0C_0010]); 2],
            tpdos: &[
                Pdo::new(0xFE, &[0x5F1D_0320, 0x5F1D_0410, 0x5F19_0010]).event_timer(Hook::Device(9)),
                Pdo::new(0x01, &[0x5F1D_0120, 0x5F1D_0210, 0x5F19_0010]).transmission_limits(0x01, 0xF0),
            ],
        }),
    };

    #[test]
    fn rpdos_come_before_tpdos_with_their_cob_ids_and_mappings() {
        static TABLE: [Entry; 74] = join(&[rows(&AP10T).as_slice()]);
        let od = Od::new(&TABLE, 5);
        assert_eq!(od.value(0x1400, 1), Some(0x205));
        assert_eq!(od.value(0x1401, 1), Some(0x305));
        assert_eq!(od.value(0x1800, 1), Some(0x185));
        assert_eq!(od.value(0x1801, 1), Some(0x285));
        assert_eq!(od.value(0x1401, 2), Some(0xFF));
        assert_eq!(od.value(0x1600, 0), Some(3));
        assert_eq!(od.value(0x1A01, 1), Some(0x5F1D_0120));
        assert!(od.pos(0x1400, 4).is_none() && od.pos(0x1400, 6).is_none());
        let e = |i, s| od.entry(od.pos(i, s).unwrap());
        assert_eq!(e(0x1A00, 0).kind(), Kind::Head { array: false });
        #[cfg(feature = "names")]
        {
            assert_eq!(e(0x1600, 0).name(), "Number of mapped objects");
            assert_eq!(e(0x1A00, 0).object(), Some("TPDO1 mapping parameter"));
            assert_eq!(e(0x1401, 0).object(), Some("RPDO2 communication parameter"));
            assert_eq!(e(0x1401, 1).name(), "COB-ID used by RPDO2");
            assert_eq!(e(0x1401, 1).object(), None);
        }
        assert_eq!(e(0x1801, 2).limits(), Some((1, 0xF0)));
        assert_eq!(e(0x1800, 2).limits(), None);
        assert_eq!((e(0x1800, 5).access, e(0x1800, 5).hook), (Access::Rw, Hook::Device(9)));
        assert_eq!((e(0x1801, 5).access, e(0x1801, 5).group), (Access::Ro, Group::None));
        assert_eq!((e(0x1018, 4).default(), e(0x1018, 4).group), (Default::Value(0xFFFF_FFFF), Group::None));
        assert_eq!(od.value(0x1018, 3), Some(0));
        for i in [0x1010, 0x1011, 0x1018, 0x1200, 0x1400, 0x1601, 0x1801, 0x1A00] {
            assert_eq!(e(i, 0).access, Access::Ro, "{i:04X}h sub 0");
        }
        assert_eq!(e(0x1003, 0).access, Access::Rw);
    }

    #[test]
    fn an_auto_id_is_sub_2_and_moves_the_bit_rate_to_sub_3() {
        let s = NodeIdAndBitrate {
            auto_id: Some(AutoId { default: 1, limits: (1, 127), hook: Hook::Device(3) }),
            head: Access::Ro,
            ..NodeIdAndBitrate::new(0x7D, (1, 127), 0, (0, 5))
        };
        let r = node_id_and_bitrate(&s);
        let r = r.as_slice();
        assert!(ids(r).eq([(0x5F0A, 0), (0x5F0A, 1), (0x5F0A, 2), (0x5F0A, 3)]));
        assert_eq!((r[0].default(), r[0].access), (Default::Value(3), Access::Ro));
        assert_eq!((r[1].default(), r[1].hook), (Default::Value(0x7D), Hook::Core(CoreHook::PendingNodeId)));
        assert_eq!(r[2].hook, Hook::Device(3));
        assert_eq!((r[3].default(), r[3].limits()), (Default::Value(0), Some((0, 5))));
        assert_eq!(r[3].hook, Hook::Core(CoreHook::PendingBitrate));
        assert!(r[1..].iter().all(|e| e.group == Group::Manuf));
    }

    #[test]
    fn four_pdos_each_way_of_eight_objects_fit_and_are_named() {
        const EIGHT: [u32; MAPPED_MAX] = [0x6000_0008; MAPPED_MAX];
        const FOUR: [Pdo; PDOS_MAX] = [Pdo::new(0xFE, &EIGHT); PDOS_MAX];
        static TABLE: [Entry; 38 + 8 * (5 + 1 + 8)] =
            join(&[rows(&Profile { canopen: Some(CanOpen { rpdos: &FOUR, tpdos: &FOUR }), ..AP10T }).as_slice()]);
        let od = Od::new(&TABLE, 1);
        assert_eq!(od.value(0x1403, 1), Some(0x501));
        assert_eq!(od.value(0x1803, 1), Some(0x481));
        let e = |i, s| od.entry(od.pos(i, s).unwrap());
        assert_eq!(e(0x1603, 0).kind(), Kind::Head { array: false });
        #[cfg(feature = "names")]
        {
            assert_eq!(e(0x1A03, 8).name(), "Mapped object 8");
            assert_eq!(e(0x1603, 0).object(), Some("RPDO4 mapping parameter"));
            assert_eq!(e(0x1803, 1).name(), "COB-ID used by TPDO4");
        }
    }

    const A: Entry = Entry::var(0x1000, "A", DataType::Unsigned8, Access::Ro, 0);
    const B: Entry = Entry::record(0x1018, "B", 1, Access::Const);
    const B1: Entry = Entry::member(0x1018, 1, "B1", DataType::Unsigned8, Access::Ro, 0);
    const C1: Entry = Entry::member(0x1019, 1, "C1", DataType::Unsigned8, Access::Ro, 0);

    #[test]
    fn join_concatenates_in_order() {
        let t: [Entry; 3] = join(&[&[A], &[], &[B, B1]]);
        assert!(ids(&t).eq([(0x1000, 0), (0x1018, 0), (0x1018, 1)]));
    }

    #[test]
    #[should_panic(expected = "out of (index, sub) order")]
    fn join_rejects_parts_out_of_order() {
        let _: [Entry; 3] = join(&[&[B, B1], &[A]]);
    }

    #[test]
    #[should_panic(expected = "out of (index, sub) order")]
    fn join_rejects_a_row_declared_twice() {
        let _: [Entry; 2] = join(&[&[A], &[A]]);
    }

    #[test]
    #[should_panic(expected = "fewer entries")]
    fn join_rejects_a_table_longer_than_its_parts() {
        let _: [Entry; 4] = join(&[&[A], &[B, B1]]);
    }

    #[test]
    #[should_panic(expected = "more entries")]
    fn join_rejects_a_table_shorter_than_its_parts() {
        let _: [Entry; 2] = join(&[&[A], &[B, B1]]);
    }

    #[test]
    #[should_panic(expected = "member without its object")]
    fn join_rejects_a_member_without_its_object() {
        let _: [Entry; 4] = join(&[&[A, B, B1, C1]]);
    }

    #[test]
    #[should_panic(expected = "more than four PDOs")]
    fn more_than_four_pdos_are_refused() {
        const FIVE: [Pdo; 5] = [Pdo::new(1, &[]); 5];
        let _ = rows(&Profile { canopen: Some(CanOpen { rpdos: &[], tpdos: &FIVE }), ..J1939 });
    }
}
