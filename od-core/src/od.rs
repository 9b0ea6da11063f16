//! The object dictionary: a device's entries declared once as `static` data, their values in RAM.
//!
//! Each device declares a sorted `&'static [Entry]` (see `crate::devices`). The declaration
//! carries everything the manual says of an entry: name, data type, access, PDO mapping,
//! default, limits, storage group and the hook that gives a write its side effect. From that
//! one table come the RAM values (`Od`), the SDO checks, the parameter image and the EDS file.
//!
//! Every value fits in 32 bits: the dictionaries of all five devices hold no type wider than
//! UNSIGNED32/INTEGER32, and their strings (1008h, 1009h, 100Ah) are constants read from the
//! declaration itself.
//!
//! An entry takes 14 bytes of flash: the few limits and the longer strings are codes into two
//! crate-wide lists, [`VALUES`] and [`STRINGS`] (D-ARCH-9).

use crate::abort::Abort;
use crate::lookup::Lookup;

/// CiA 301 data types used by the devices, with their CiA 301 type codes as discriminants.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
#[repr(u8)]
pub enum DataType {
    /// BOOLEAN.
    Boolean = 0x0001,
    /// INTEGER8.
    Integer8 = 0x0002,
    /// INTEGER16.
    Integer16 = 0x0003,
    /// INTEGER32.
    Integer32 = 0x0004,
    /// UNSIGNED8.
    Unsigned8 = 0x0005,
    /// UNSIGNED16.
    Unsigned16 = 0x0006,
    /// UNSIGNED32.
    Unsigned32 = 0x0007,
    /// VISIBLE_STRING (constant in every device).
    VisibleString = 0x0009,
}

impl DataType {
    /// Size in bytes of a value of this type (strings: 0, their size is their content's).
    pub const fn size(self) -> usize {
        // By type code (the discriminant): BOOLEAN 1 ... UNSIGNED32 7, VISIBLE_STRING 9.
        const SIZE: [u8; 10] = [0, 1, 1, 2, 4, 1, 2, 4, 0, 0];
        SIZE[self as usize] as usize
    }

    /// Size in bits, as a PDO mapping entry gives it.
    pub const fn bits(self) -> u8 {
        (self.size() * 8) as u8
    }

    /// The raw 32-bit slot value as an unsigned number that orders as the values of this type
    /// do: [`DataType::to_i64`] without 64-bit arithmetic (INTEGERn sign-extended with the
    /// sign bit flipped, the others their bytes).
    #[inline]
    const fn order_key(self, raw: u32) -> u32 {
        match self {
            DataType::Integer8 => (raw as u8 as i8 as i32 as u32) ^ 0x8000_0000,
            DataType::Integer16 => (raw as u16 as i16 as i32 as u32) ^ 0x8000_0000,
            DataType::Integer32 => raw ^ 0x8000_0000,
            DataType::Boolean | DataType::Unsigned8 => raw & 0xFF,
            DataType::Unsigned16 => raw & 0xFFFF,
            DataType::Unsigned32 | DataType::VisibleString => raw,
        }
    }

    /// Does the raw 32-bit slot value `value` lie within the inclusive limits `lo` and `hi`
    /// (raw patterns too), all read as numbers of this type?
    #[inline]
    const fn within(self, value: u32, lo: u32, hi: u32) -> bool {
        let v = self.order_key(value);
        v >= self.order_key(lo) && v <= self.order_key(hi)
    }

    /// True for the INTEGERn types.
    pub const fn is_signed(self) -> bool {
        matches!(self, DataType::Integer8 | DataType::Integer16 | DataType::Integer32)
    }

    /// The raw 32-bit slot value read as a number of this type (sign-extended for INTEGERn).
    pub const fn to_i64(self, raw: u32) -> i64 {
        match self {
            DataType::Integer8 => raw as u8 as i8 as i64,
            DataType::Integer16 => raw as u16 as i16 as i64,
            DataType::Integer32 => raw as i32 as i64,
            DataType::Boolean | DataType::Unsigned8 => (raw & 0xFF) as i64,
            DataType::Unsigned16 => (raw & 0xFFFF) as i64,
            DataType::Unsigned32 | DataType::VisibleString => raw as i64,
        }
    }
}

/// Access rights as the manuals print them.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Access {
    /// Read only; the device itself may change the value.
    Ro,
    /// Write only.
    Wo,
    /// Read and write.
    Rw,
    /// Constant.
    Const,
    /// No SDO access at all: the entry exists to be mapped into a PDO (the AP10T's 5F1Dh, access
    /// "no" in its manual). A read or write answers 06010000h.
    PdoOnly,
}

impl Access {
    /// May an SDO client read it?
    pub const fn readable(self) -> bool {
        !matches!(self, Access::Wo | Access::PdoOnly)
    }
    /// May an SDO client write it?
    pub const fn writable(self) -> bool {
        matches!(self, Access::Rw | Access::Wo)
    }
}

/// Which 1010h/1011h parameter group stores an entry.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Group {
    /// Not stored (live, constant, or command entries).
    None,
    /// Communication parameters, 1000h-1FFFh (1010h/1011h sub 2).
    Comm,
    /// Application (device profile) parameters, 6000h-9FFFh (sub 3).
    App,
    /// Manufacturer-specific parameters, 2000h-5FFFh (sub 4).
    Manuf,
    /// Factory data (serial number): kept in flash, never changed by a user store/restore.
    Factory,
}

impl Group {
    /// Bit of this group in a [`GroupMask`].
    pub const fn bit(self) -> u8 {
        match self {
            Group::None => 0,
            Group::Comm => 1,
            Group::App => 2,
            Group::Manuf => 4,
            Group::Factory => 8,
        }
    }
}

/// A set of parameter groups, as selected by a 1010h/1011h subindex.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct GroupMask(pub u8);

impl GroupMask {
    /// Communication, application and manufacturer groups (1010h/1011h sub 1).
    pub const ALL: GroupMask = GroupMask(1 | 2 | 4);
    /// Only the pending node-ID and bit rate (the entries hooked `PendingNodeId` and
    /// `PendingBitrate`): what LSS "store configuration" persists.
    pub const LSS: GroupMask = GroupMask(16);
    /// Only the pending node-ID (the entry hooked `PendingNodeId`): what the AP10T's Auto-ID
    /// and its key menu's `ID` keep.
    pub const NODE_ID: GroupMask = GroupMask(32);
    /// Only the pending bit-rate code (hooked `PendingBitrate`): what the AP10T's `KBAUD` keeps.
    pub const BITRATE: GroupMask = GroupMask(64);
    /// The groups a 1010h/1011h subindex selects (1 all, 2 comm, 3 app, 4 manufacturer).
    pub const fn from_subindex(sub: u8) -> Option<GroupMask> {
        match sub {
            1 => Some(GroupMask::ALL),
            2 => Some(GroupMask(Group::Comm.bit())),
            3 => Some(GroupMask(Group::App.bit())),
            4 => Some(GroupMask(Group::Manuf.bit())),
            _ => None,
        }
    }
    /// Does the set contain `g`?
    pub const fn contains(self, g: Group) -> bool {
        g.bit() != 0 && self.0 & g.bit() != 0
    }
}

/// A default value as the manual gives it ([`Entry::default`]); a string borrows the entry.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Default<'a> {
    /// A fixed value (the 32-bit pattern; negative INTEGERs as two's complement).
    Value(u32),
    /// A base plus the node-ID (COB-ID defaults such as 180h + node-ID).
    PlusNodeId(u32),
    /// A constant string.
    Str(&'a str),
}

/// The part of a CiA 306 object an entry is.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Kind {
    /// A plain variable (sub-index 0, ObjectType 7).
    Var,
    /// Sub-index 0 of a RECORD (ObjectType 9) or ARRAY (ObjectType 8); with the `names`
    /// feature, `Entry::object` is the object's name.
    Head {
        /// ARRAY (all members of one type) rather than RECORD.
        array: bool,
    },
    /// A member (sub-index >= 1) of a RECORD or ARRAY.
    Member,
}

/// What a write to an entry does beyond storing the value.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Hook {
    /// Nothing: the value is checked against type, access and limits and stored.
    None,
    /// A communication-profile rule the core enforces.
    Core(CoreHook),
    /// A device-specific side effect; the number is the device's own.
    Device(u8),
}

/// Write side effects owned by the core services.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum CoreHook {
    /// 1003h sub 0: only 0 may be written, and it clears the history.
    ErrorHistory,
    /// 1005h COB-ID SYNC.
    SyncCobId,
    /// 1014h COB-ID EMCY.
    EmcyCobId,
    /// 100Ch guard time / 100Dh life time factor.
    Guarding,
    /// 1017h producer heartbeat time.
    HeartbeatTime,
    /// 1010h store parameters ("save").
    Store,
    /// 1011h restore default parameters ("load").
    Restore,
    /// 14xxh/18xxh sub 1: PDO COB-ID.
    PdoCobId,
    /// 14xxh/18xxh sub 2: transmission type.
    PdoTransmissionType,
    /// 18xxh sub 5: event timer.
    PdoEventTimer,
    /// 16xxh/1Axxh: PDO mapping.
    PdoMapping,
    /// Node-ID to use after the next reset (5F0Ah.01 and alike; shared with LSS).
    PendingNodeId,
    /// Bit-rate code to use after the next reset (5F0Ah.02 and alike; shared with LSS).
    PendingBitrate,
}

/// Longest VISIBLE_STRING an entry holds. Up to four characters are kept in the entry; a
/// longer one must be one of [`STRINGS`]' runs of bytes (the longest of the five manuals, 1008h
/// "WV5800M", has 7).
pub const STRING_MAX: usize = 12;

/// The bytes of every VISIBLE_STRING longer than four characters a dictionary declares, one
/// after the other: such a string's entry keeps where its bytes start here and how many there
/// are, so that a table's entries need not have room for the longest of them
/// ([`Entry::string`] finds a declared string here; one that is not fails the declaration, at
/// compile time for a `static` table).
pub static STRINGS: [u8; 29] = *b"SGH10SGH50AP10TWV5800MWH5800M";

/// The 32-bit patterns of every default and limit of a limited entry ([`Entry::range`]) that is
/// not one the entry's one-byte codes give themselves (-32 to 127, 2^n, 2^n - 1; see `code`):
/// a limited entry keeps the three as such codes so that a table's entries need not have room
/// for twelve bytes of them. A value not found here fails the declaration, at compile time for
/// a `static` table: add it (at most 32; the last ones are what the tests' own tables declare).
pub static VALUES: [u32; 29] = [
    -67_108_864i32 as u32,
    -4_194_304i32 as u32,
    -262_144i32 as u32,
    -147_678i32 as u32,
    -73_839i32 as u32,
    -32_768i32 as u32,
    -20_478i32 as u32,
    -16_384i32 as u32,
    -10_239i32 as u32,
    239,
    253,
    254,
    10_239,
    30_717,
    65_534,
    73_839,
    100_000,
    221_517,
    999_999,
    1_048_559,
    1_048_560,
    16_776_959,
    16_776_960,
    268_431_359,
    268_431_360,
    // The tests' own tables.
    -128i32 as u32,
    -100i32 as u32,
    0xFFCC,
    240,
];

/// The one-byte code of `v`, a limited entry's default or limit: 00h-7Fh the numbers 0 to 127,
/// E0h-FFh -32 to -1, A0h-BFh 2^n, C0h-DFh 2^n - 1 (n the low five bits), 80h-9Fh the
/// [`VALUES`] at 0 to 31.
const fn code(v: u32) -> u8 {
    if v < 0x80 || v >= (-32i32) as u32 {
        return v as u8;
    }
    if v.is_power_of_two() {
        return 0xA0 | v.trailing_zeros() as u8;
    }
    if v.wrapping_add(1).is_power_of_two() {
        return 0xC0 | v.trailing_ones() as u8;
    }
    let mut i = 0;
    while i < VALUES.len() {
        if VALUES[i] == v {
            return 0x80 | i as u8;
        }
        i += 1;
    }
    panic!("a limited entry's default or limit not in od::VALUES");
}

/// The value of a [`code`] (0 for a code past the [`VALUES`], which [`code`] never gives).
#[inline]
const fn decode(c: u8) -> u32 {
    let n = c & 0x1F;
    match c >> 5 {
        4 => {
            if (n as usize) < VALUES.len() {
                VALUES[n as usize]
            } else {
                0
            }
        }
        5 => 1 << n,
        6 => (1 << n) - 1,
        _ => c as i8 as i32 as u32,
    }
}
const _: () = assert!(VALUES.len() <= 32);

// `Entry::flags`: the kind in the low two bits, then which reading of `Entry::data` applies.
const KIND: u8 = 0b11;
const VAR: u8 = 0;
const RECORD: u8 = 1;
const ARRAY: u8 = 2;
const MEMBER: u8 = 3;
/// The entry has limits: `data` holds the [`code`]s of the low limit, the high limit and the
/// default (or its base), in this order.
const LIMITED: u8 = 1 << 2;
/// The default is the default word plus the node-ID.
const PLUS_NODE_ID: u8 = 1 << 3;
/// `data` holds a VISIBLE_STRING of at most four bytes, NUL-padded.
const STRING: u8 = 1 << 4;
/// The default is the [`Od`]'s factory node-ID when it has one ([`Entry::factory_node_id`]),
/// else the default word.
const FACTORY_NODE_ID: u8 = 1 << 5;
/// `data` holds where a longer VISIBLE_STRING starts in [`STRINGS`] and its length.
const POOLED: u8 = 1 << 6;

// Every table lives in the firmware's flash, about a hundred entries per device: an entry that
// grows past 14 bytes on the 32-bit target should be a decision, not an accident. Without
// names an entry holds no pointer, so the assertion holds on the host too (`cargo test -p
// od-core`); the names (host only) add two string references.
#[cfg(not(feature = "names"))]
const _: () = assert!(core::mem::size_of::<Entry>() <= 14);

/// One (index, sub-index) of a device's dictionary, as declared.
///
/// 14 bytes in the firmware: the rare attributes are packed into one byte of flags, and four
/// bytes hold a number's default as a 32-bit pattern of its type (every value fits a 32-bit
/// slot, D-ARCH-2), or a limited entry's default and limits as one-byte codes of the
/// [`VALUES`], or a VISIBLE_STRING's bytes or where they are in [`STRINGS`].
///
/// The parameter and object names the builders take are kept only with the `names` feature
/// (the host's EDS generator and simulator views); without it, as in the firmware, they are
/// dropped and take no flash.
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct Entry {
    /// Object index.
    pub index: u16,
    /// Sub-index.
    pub sub: u8,
    /// Data type.
    pub dtype: DataType,
    /// Access rights.
    pub access: Access,
    /// May be mapped into a PDO.
    pub pdo: bool,
    /// Storage group.
    pub group: Group,
    /// Write side effect.
    pub hook: Hook,
    /// [`Entry::kind`] and the reading of `data` (`LIMITED`, `PLUS_NODE_ID`, `STRING`,
    /// `POOLED`).
    flags: u8,
    /// A number: its default (or the base of a node-ID-relative one) as a little-endian 32-bit
    /// pattern; with limits, the codes of low limit, high limit and default. A VISIBLE_STRING:
    /// up to four bytes, NUL-padded, or its start in [`STRINGS`] and its length.
    data: [u8; 4],
    /// Parameter name.
    #[cfg(feature = "names")]
    name: &'static str,
    /// A record or array head's object name ("" for the other entries).
    #[cfg(feature = "names")]
    object: &'static str,
}

impl Entry {
    const fn base(
        index: u16,
        sub: u8,
        kind: u8,
        names: (&'static str, &'static str),
        dtype: DataType,
        access: Access,
        default: u32,
    ) -> Entry {
        #[cfg(not(feature = "names"))]
        let _ = names;
        let mut e = Entry {
            index,
            sub,
            dtype,
            access,
            pdo: false,
            group: Group::None,
            hook: Hook::None,
            flags: kind,
            data: [0; 4],
            #[cfg(feature = "names")]
            name: names.0,
            #[cfg(feature = "names")]
            object: names.1,
        };
        e.data = default.to_le_bytes();
        e
    }

    /// The default word: the declared default, or the base of a node-ID-relative one.
    #[inline]
    const fn word(&self) -> u32 {
        if self.flags & LIMITED != 0 {
            decode(self.data[2])
        } else {
            u32::from_le_bytes(self.data)
        }
    }

    /// Sets the default word.
    const fn put(&mut self, v: u32) {
        if self.flags & LIMITED != 0 {
            self.data[2] = code(v);
        } else {
            self.data = v.to_le_bytes();
        }
    }

    /// The low and high limit of a limited entry as 32-bit patterns.
    #[inline]
    const fn limit_words(&self) -> (u32, u32) {
        (decode(self.data[0]), decode(self.data[1]))
    }

    const fn is_string(&self) -> bool {
        self.flags & (STRING | POOLED) != 0
    }

    /// A VISIBLE_STRING's value, its bytes; `None` for a number. What the firmware's paths
    /// read: [`Entry::default`] gives it as a `str`, at the price of a UTF-8 check that the
    /// firmware should not link.
    #[inline]
    pub const fn string_value(&self) -> Option<&[u8]> {
        if self.is_string() {
            Some(self.string_bytes())
        } else {
            None
        }
    }

    /// A VISIBLE_STRING's bytes, kept in the entry or in [`STRINGS`].
    #[inline(never)]
    const fn string_bytes(&self) -> &[u8] {
        if self.flags & POOLED != 0 {
            let (start, len) = (self.data[0] as usize, self.data[1] as usize);
            return STRINGS.split_at(start).1.split_at(len).0;
        }
        let mut n = 0;
        while n < 4 && self.data[n] != 0 {
            n += 1;
        }
        self.data.split_at(n).0
    }

    /// A plain variable at sub-index 0.
    pub const fn var(index: u16, name: &'static str, dtype: DataType, access: Access, default: u32) -> Entry {
        Entry::base(index, 0, VAR, (name, ""), dtype, access, default)
    }

    /// A constant VISIBLE_STRING variable of at most [`STRING_MAX`] visible characters
    /// (20h-7Eh), one of [`STRINGS`] if longer than four (anything else fails the declaration,
    /// at compile time for a `static` table):
    ///
    /// ```compile_fail,E0080
    /// use od_core::od::Entry;
    /// // 13 characters: "VISIBLE_STRING longer than od::STRING_MAX".
    /// static T: [Entry; 1] = [Entry::string(0x1008, "Manufacturer device name", "WV5800M-4096T")];
    /// ```
    pub const fn string(index: u16, name: &'static str, value: &'static str) -> Entry {
        let bytes = value.as_bytes();
        assert!(bytes.len() <= STRING_MAX, "VISIBLE_STRING longer than od::STRING_MAX");
        let mut e = Entry::base(index, 0, VAR | STRING, (name, ""), DataType::VisibleString, Access::Const, 0);
        let mut i = 0;
        while i < bytes.len() {
            assert!(bytes[i] >= 0x20 && bytes[i] <= 0x7E, "VISIBLE_STRING with a character outside 20h-7Eh");
            i += 1;
        }
        if bytes.len() <= 4 {
            let mut i = 0;
            while i < bytes.len() {
                e.data[i] = bytes[i];
                i += 1;
            }
            return e;
        }
        let mut start = 0;
        while start + bytes.len() <= STRINGS.len() {
            let mut i = 0;
            while i < bytes.len() && STRINGS[start + i] == bytes[i] {
                i += 1;
            }
            if i == bytes.len() {
                e.flags = VAR | POOLED;
                e.data = [start as u8, bytes.len() as u8, 0, 0];
                return e;
            }
            start += 1;
        }
        panic!("VISIBLE_STRING longer than four characters not in od::STRINGS");
    }

    /// Sub-index 0 of a RECORD: "highest sub-index supported", UNSIGNED8, `access`.
    pub const fn record(index: u16, object: &'static str, highest: u8, access: Access) -> Entry {
        Entry::base(
            index,
            0,
            RECORD,
            ("Highest sub-index supported", object),
            DataType::Unsigned8,
            access,
            highest as u32,
        )
    }

    /// Sub-index 0 of an ARRAY.
    pub const fn array(index: u16, object: &'static str, highest: u8, access: Access) -> Entry {
        Entry::base(
            index,
            0,
            ARRAY,
            ("Highest sub-index supported", object),
            DataType::Unsigned8,
            access,
            highest as u32,
        )
    }

    /// A member of a RECORD or ARRAY.
    pub const fn member(
        index: u16,
        sub: u8,
        name: &'static str,
        dtype: DataType,
        access: Access,
        default: u32,
    ) -> Entry {
        Entry::base(index, sub, MEMBER, (name, ""), dtype, access, default)
    }

    /// Renames the entry (for a record head whose sub 0 the manual names).
    #[cfg_attr(not(feature = "names"), allow(unused_mut, unused_variables))]
    pub const fn named(mut self, name: &'static str) -> Entry {
        #[cfg(feature = "names")]
        {
            self.name = name;
        }
        self
    }

    /// The parameter name (for a record or array head, its sub 0's: [`Entry::object`] is the
    /// object's).
    #[cfg(feature = "names")]
    pub const fn name(&self) -> &'static str {
        self.name
    }

    /// The name of the record or array a head ([`Kind::Head`]) starts; `None` for the others.
    #[cfg(feature = "names")]
    pub const fn object(&self) -> Option<&'static str> {
        match self.kind() {
            Kind::Head { .. } => Some(self.object),
            _ => None,
        }
    }

    /// Variable, record/array head, or member.
    pub const fn kind(&self) -> Kind {
        match self.flags & KIND {
            VAR => Kind::Var,
            RECORD => Kind::Head { array: false },
            ARRAY => Kind::Head { array: true },
            _ => Kind::Member,
        }
    }

    /// Sets a fixed default other than the one the builder implies (1003h sub 0: the number
    /// of errors, 0 by default, though the array has room for more).
    pub const fn with_default(mut self, value: u32) -> Entry {
        assert!(!self.is_string(), "a string's default is its value");
        self.put(value);
        self.flags &= !PLUS_NODE_ID;
        self
    }

    /// Marks the entry PDO-mappable.
    pub const fn pdo(mut self) -> Entry {
        self.pdo = true;
        self
    }

    /// Sets inclusive limits, in the type's numeric range (a limit outside it fails the
    /// declaration, at compile time for a `static` table).
    pub const fn range(mut self, lo: i64, hi: i64) -> Entry {
        assert!(!self.is_string(), "a string has no limits");
        assert!(self.dtype.to_i64(lo as u32) == lo && self.dtype.to_i64(hi as u32) == hi, "limit outside the type");
        let default = self.word();
        self.data = [code(lo as u32), code(hi as u32), code(default), 0];
        self.flags |= LIMITED;
        self
    }

    /// The inclusive value limits, in the type's numeric range, if the entry has any.
    #[inline]
    pub const fn limits(&self) -> Option<(i64, i64)> {
        if self.flags & LIMITED != 0 {
            let (lo, hi) = self.limit_words();
            Some((self.dtype.to_i64(lo), self.dtype.to_i64(hi)))
        } else {
            None
        }
    }

    /// Sets the storage group.
    pub const fn group(mut self, group: Group) -> Entry {
        self.group = group;
        self
    }

    /// Sets the write hook.
    pub const fn hook(mut self, hook: Hook) -> Entry {
        self.hook = hook;
        self
    }

    /// Default is `base` plus the node-ID.
    pub const fn plus_node_id(mut self, base: u32) -> Entry {
        assert!(!self.is_string(), "a string's default is its value");
        self.put(base);
        self.flags |= PLUS_NODE_ID;
        self
    }

    /// Marks the entry whose default is the node-ID the device ships with (the pending
    /// node-ID): an [`Od`] built for a device variant with a factory node-ID of its own
    /// ([`Od::with_factory_node_id`]) takes that as the default instead of the declared one, so
    /// that variants differing only in it share one table (the SGH50's two encoders).
    pub const fn factory_node_id(mut self) -> Entry {
        assert!(!self.is_string(), "a string's default is its value");
        self.flags |= FACTORY_NODE_ID;
        self
    }

    /// The default for a node with this node-ID in a dictionary whose factory node-ID is
    /// `factory` (0: none, the declared default): [`Entry::default_value`] but for an entry
    /// marked [`Entry::factory_node_id`]. What [`Od::default_of`] answers.
    #[inline(always)]
    pub const fn default_value_in(&self, node_id: u8, factory: u8) -> u32 {
        if self.flags & FACTORY_NODE_ID != 0 && factory != 0 {
            factory as u32
        } else {
            self.default_value(node_id)
        }
    }

    /// Is the default a base plus the node-ID ([`Default::PlusNodeId`])? What the firmware's
    /// paths ask instead of matching [`Entry::default`], which checks a string as UTF-8.
    pub const fn is_node_id_relative(&self) -> bool {
        self.flags & PLUS_NODE_ID != 0
    }

    /// The factory default.
    pub const fn default(&self) -> Default<'_> {
        if self.is_node_id_relative() {
            Default::PlusNodeId(self.word())
        } else if let Some(bytes) = self.string_value() {
            // Checked visible ASCII when declared: never the empty fallback.
            match core::str::from_utf8(bytes) {
                Ok(s) => Default::Str(s),
                Err(_) => Default::Str(""),
            }
        } else {
            Default::Value(self.word())
        }
    }

    /// The default value for a node with this node-ID (strings: 0).
    pub const fn default_value(&self, node_id: u8) -> u32 {
        if self.is_node_id_relative() {
            self.word().wrapping_add(node_id as u32)
        } else if self.is_string() {
            0
        } else {
            self.word()
        }
    }

    /// Bytes the value takes on the bus.
    pub const fn size(&self) -> usize {
        match self.string_value() {
            Some(s) => s.len(),
            None => self.dtype.size(),
        }
    }

    /// The CiA 306 ObjectType of the object this entry heads or is (7 VAR, 8 ARRAY, 9 RECORD).
    pub const fn object_type(&self) -> u8 {
        match self.kind() {
            Kind::Var => 7,
            Kind::Head { array: true, .. } => 8,
            Kind::Head { array: false, .. } => 9,
            Kind::Member => 7,
        }
    }
}

/// The entry as declared, its packed attributes decoded.
impl core::fmt::Debug for Entry {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let mut d = f.debug_struct("Entry");
        d.field("index", &self.index).field("sub", &self.sub);
        #[cfg(feature = "names")]
        d.field("name", &self.name).field("object", &self.object());
        d.field("kind", &self.kind())
            .field("dtype", &self.dtype)
            .field("access", &self.access)
            .field("pdo", &self.pdo)
            .field("default", &self.default())
            .field("limits", &self.limits())
            .field("group", &self.group)
            .field("hook", &self.hook)
            .finish()
    }
}

/// Most entries any device dictionary holds; checked when an [`Od`] is built.
pub const MAX_ENTRIES: usize = 160;
const _: () = assert!(MAX_ENTRIES <= crate::lookup::MAX_ROWS);

/// A device's dictionary: the static declarations and their current values.
#[derive(Clone)]
pub struct Od {
    table: &'static [Entry],
    lookup: Lookup,
    values: [u32; MAX_ENTRIES],
    /// The node-ID the device variant ships with, the default of an entry marked
    /// [`Entry::factory_node_id`]; 0 when the declared default is it.
    factory: u8,
}

impl Od {
    /// Builds the dictionary with every value at its default for `node_id`.
    ///
    /// Panics (at start-up, never on the bus) if the table is too large, and in debug builds
    /// if it is unsorted: declaration bugs every device test catches (the device tables'
    /// order is checked at compile time, by `devices::comm::join`).
    pub fn new(table: &'static [Entry], node_id: u8) -> Od {
        Od::with_factory_node_id(table, node_id, None)
    }

    /// [`Od::new`] for a device variant that ships with node-ID `factory` rather than the
    /// table's declared one: the default of the entry marked [`Entry::factory_node_id`] (the
    /// SGH50 redundant version's second encoder: 2). `None` keeps the declared default.
    pub fn with_factory_node_id(table: &'static [Entry], node_id: u8, factory: Option<u8>) -> Od {
        let mut od = Od::blank(table, factory);
        od.load_defaults(|_| true, node_id);
        od
    }

    /// The dictionary of `table` for the variant with factory node-ID `factory` (as
    /// [`Od::with_factory_node_id`]) with every value 0: what a power-on fills in place
    /// ([`Od::load_defaults`], then the stored values).
    pub(crate) fn blank(table: &'static [Entry], factory: Option<u8>) -> Od {
        assert!(table.len() <= MAX_ENTRIES, "dictionary larger than MAX_ENTRIES");
        // The device tables are built by `devices::comm::join`, which checks the order when
        // it is evaluated (at compile time); the unit tests' own tables are checked here, in
        // debug builds (the firmware carries no second check).
        debug_assert!(
            table.windows(2).all(|w| (w[0].index, w[0].sub) < (w[1].index, w[1].sub)),
            "dictionary not sorted by (index, sub)"
        );
        Od { table, lookup: Lookup::new(table), values: [0; MAX_ENTRIES], factory: factory.unwrap_or(0) }
    }

    /// The declarations.
    pub fn table(&self) -> &'static [Entry] {
        self.table
    }

    /// The declaration at position `pos`.
    #[inline]
    pub fn entry(&self, pos: usize) -> &'static Entry {
        &self.table[pos]
    }

    /// Position of (index, sub), or the abort code an SDO client gets for it:
    /// 06020000h when no entry has that index, 06090011h when the index exists but not the sub.
    #[inline]
    pub fn find(&self, index: u16, sub: u8) -> Result<usize, Abort> {
        self.lookup.find(self.table, index, sub)
    }

    /// Position of (index, sub), if declared.
    pub fn pos(&self, index: u16, sub: u8) -> Option<usize> {
        self.find(index, sub).ok()
    }

    /// Position of the entry whose write hook is `hook` (the pending node-ID, the pending
    /// bit rate ...), if the dictionary declares one; the first one if several.
    pub fn find_hook(&self, hook: CoreHook) -> Option<usize> {
        self.table.iter().position(|e| e.hook == Hook::Core(hook))
    }

    /// Raw value at `pos`.
    #[inline]
    pub fn get(&self, pos: usize) -> u32 {
        self.values[pos]
    }

    /// Sets the raw value at `pos`, with no checks (the device's own updates).
    #[inline]
    pub fn set(&mut self, pos: usize, value: u32) {
        self.values[pos] = value;
    }

    /// Raw value of (index, sub), if declared.
    pub fn value(&self, index: u16, sub: u8) -> Option<u32> {
        self.pos(index, sub).map(|p| self.values[p])
    }

    /// Sets (index, sub) with no checks; false if it is not declared.
    pub fn set_value(&mut self, index: u16, sub: u8, value: u32) -> bool {
        match self.pos(index, sub) {
            Some(p) => {
                self.values[p] = value;
                true
            }
            None => false,
        }
    }

    /// The default of `e`, one of this dictionary's entries, for a node with this node-ID: the
    /// declared one ([`Entry::default_value`]), or this dictionary's factory node-ID for the
    /// entry marked [`Entry::factory_node_id`].
    #[inline(never)]
    pub fn default_of(&self, e: &Entry, node_id: u8) -> u32 {
        e.default_value_in(node_id, self.factory)
    }

    /// The node-ID the device variant ships with if it is not the table's declared one
    /// ([`Od::with_factory_node_id`]).
    pub fn factory_node_id(&self) -> Option<u8> {
        (self.factory != 0).then_some(self.factory)
    }

    /// Resets every entry `select` picks to its default for `node_id`.
    pub fn load_defaults(&mut self, select: impl Fn(&Entry) -> bool, node_id: u8) {
        for (pos, e) in self.table.iter().enumerate() {
            if select(e) {
                self.values[pos] = e.default_value_in(node_id, self.factory);
            }
        }
    }

    /// Writes the value at `pos` as it goes on the bus (little-endian, or the string's bytes)
    /// into `buf`; returns the number of bytes. `buf` must hold [`Entry::size`] bytes.
    pub fn encode(&self, pos: usize, buf: &mut [u8]) -> usize {
        let e = &self.table[pos];
        match e.string_value() {
            Some(s) => {
                let n = s.len().min(buf.len());
                buf[..n].copy_from_slice(&s[..n]);
                n
            }
            _ => {
                let n = e.dtype.size().min(buf.len());
                buf[..n].copy_from_slice(&self.values[pos].to_le_bytes()[..n]);
                n
            }
        }
    }

    /// Checks that `pos` may be read by an SDO client.
    #[inline]
    pub fn check_read(&self, pos: usize) -> Result<(), Abort> {
        match self.table[pos].access {
            Access::PdoOnly => Err(Abort::UNSUPPORTED_ACCESS),
            a if a.readable() => Ok(()),
            _ => Err(Abort::WRITE_ONLY),
        }
    }

    /// Decodes `data` written by an SDO client to `pos` and checks access, length and
    /// limits; returns the raw value to store. Nothing is changed.
    pub fn check_write(&self, pos: usize, data: &[u8]) -> Result<u32, Abort> {
        self.check_value(pos, value_of(data), data.len())
    }

    /// [`Od::check_write`] of `len` bytes whose first four (at most) are `value`
    /// ([`value_of`]).
    #[inline(always)]
    pub fn check_value(&self, pos: usize, value: u32, len: usize) -> Result<u32, Abort> {
        let e = &self.table[pos];
        if e.access == Access::PdoOnly {
            return Err(Abort::UNSUPPORTED_ACCESS);
        }
        if !e.access.writable() {
            return Err(Abort::READ_ONLY);
        }
        let size = e.dtype.size();
        if len > size {
            return Err(Abort::LENGTH_HIGH);
        }
        if len < size {
            return Err(Abort::LENGTH_LOW);
        }
        if e.flags & LIMITED != 0 {
            let (lo, hi) = e.limit_words();
            if !e.dtype.within(value, lo, hi) {
                return Err(Abort::INVALID_VALUE);
            }
        }
        if e.dtype == DataType::Boolean && value > 1 {
            return Err(Abort::INVALID_VALUE);
        }
        Ok(value)
    }
}

/// The first four bytes of `data` (all of them if fewer) as a little-endian number, the
/// missing high bytes zero: the raw value a write of `data` carries.
#[inline]
pub fn value_of(data: &[u8]) -> u32 {
    let mut v = 0;
    for (i, b) in data.iter().take(4).enumerate() {
        v |= (*b as u32) << (8 * i);
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    static T: &[Entry] = &[
        Entry::var(0x1000, "Device type", DataType::Unsigned32, Access::Const, 0x000A_0196),
        Entry::string(0x1008, "Name", "SGH10"),
        Entry::var(0x1017, "Heartbeat", DataType::Unsigned16, Access::Rw, 0),
        Entry::record(0x1018, "Identity", 1, Access::Const),
        Entry::member(0x1018, 1, "Vendor", DataType::Unsigned32, Access::Ro, 0x195),
        Entry::member(0x1018, 3, "Revision", DataType::Unsigned32, Access::Ro, 7),
        Entry::var(0x6401, "Limit", DataType::Integer32, Access::Rw, -5i32 as u32).range(-10, 10),
        Entry::var(0x6402, "Cmd", DataType::Unsigned8, Access::Wo, 0),
        Entry::var(0x6403, "Mapped only", DataType::Unsigned32, Access::PdoOnly, 0).pdo(),
    ];

    #[test]
    fn find_distinguishes_missing_object_and_subindex() {
        let od = Od::new(T, 1);
        assert_eq!(od.find(0x1018, 1), Ok(4));
        assert_eq!(od.find(0x1018, 2), Err(Abort::NO_SUBINDEX));
        assert_eq!(od.find(0x1018, 9), Err(Abort::NO_SUBINDEX));
        assert_eq!(od.find(0x1017, 1), Err(Abort::NO_SUBINDEX));
        assert_eq!(od.find(0x1019, 0), Err(Abort::NO_OBJECT));
        assert_eq!(od.find(0x0FFF, 0), Err(Abort::NO_OBJECT));
        assert_eq!(od.find(0xFFFF, 0xFF), Err(Abort::NO_OBJECT));
    }

    #[test]
    fn encode_strings_and_numbers() {
        let od = Od::new(T, 1);
        let mut b = [0u8; 8];
        assert_eq!(od.encode(1, &mut b), 5);
        assert_eq!(&b[..5], b"SGH10");
        assert_eq!(od.encode(0, &mut b), 4);
        assert_eq!(&b[..4], &[0x96, 0x01, 0x0A, 0x00]);
    }

    #[test]
    fn write_checks_access_length_and_limits() {
        let od = Od::new(T, 1);
        assert_eq!(od.check_write(0, &[0; 4]), Err(Abort::READ_ONLY));
        assert_eq!(od.check_write(2, &[1, 0, 0]), Err(Abort::LENGTH_HIGH));
        assert_eq!(od.check_write(2, &[1]), Err(Abort::LENGTH_LOW));
        assert_eq!(od.check_write(2, &[100, 0]), Ok(100));
        assert_eq!(od.check_write(6, &(-11i32).to_le_bytes()), Err(Abort::INVALID_VALUE));
        assert_eq!(od.check_write(6, &11i32.to_le_bytes()), Err(Abort::INVALID_VALUE));
        assert_eq!(od.check_write(6, &(-10i32).to_le_bytes()), Ok(-10i32 as u32));
        assert_eq!(od.check_read(7), Err(Abort::WRITE_ONLY));
        assert_eq!(od.check_read(8), Err(Abort::UNSUPPORTED_ACCESS));
        assert_eq!(od.check_write(8, &[0; 4]), Err(Abort::UNSUPPORTED_ACCESS));
        assert_eq!(od.get(6), -5i32 as u32);
    }

    #[test]
    fn strings_live_in_the_entry_or_in_the_pool() {
        let e = Entry::string(0x1008, "Name", "WH5800M");
        assert_eq!(e.default(), Default::Str("WH5800M"));
        assert_eq!((e.size(), e.default_value(5), e.limits()), (7, 0, None));
        assert_eq!(e.string_value(), Some(&b"WH5800M"[..]));
        let short = Entry::string(0x1009, "Short", "V1.0");
        assert_eq!((short.default(), short.size()), (Default::Str("V1.0"), 4));
        assert_eq!(short.string_value(), Some(&b"V1.0"[..]));
        let empty = Entry::string(0x1009, "Empty", "");
        assert_eq!((empty.default(), empty.size()), (Default::Str(""), 0));
        let od = Od::new(T, 1);
        let mut b = [0xAAu8; 8];
        assert_eq!(od.encode(1, &mut b[..3]), 3, "cut to the buffer");
        assert_eq!(&b[..4], b"SGH\xAA");
        assert_eq!(od.entry(1).size(), 5);
    }

    #[test]
    #[should_panic(expected = "longer than od::STRING_MAX")]
    fn a_string_longer_than_an_entry_is_refused() {
        let _ = Entry::string(0x1008, "Name", "ABCDEFGHIJKLM");
    }

    #[test]
    #[should_panic(expected = "not in od::STRINGS")]
    fn a_longer_string_must_be_in_the_pool() {
        let _ = Entry::string(0x1008, "Name", "ABCDEFGHIJKL");
    }

    #[test]
    #[should_panic(expected = "not in od::VALUES")]
    fn a_limit_must_be_small_or_in_the_pool() {
        let _ = Entry::var(0x2000, "X", DataType::Integer32, Access::Rw, 0).range(-1000, 1000);
    }

    #[test]
    #[should_panic(expected = "not in od::VALUES")]
    fn a_limited_entrys_default_must_be_small_or_in_the_pool() {
        let _ = Entry::var(0x2000, "X", DataType::Unsigned32, Access::Rw, 1000).range(0, 65535);
    }

    #[test]
    fn codes_round_trip() {
        for v in VALUES
            .iter()
            .copied()
            .chain((-32..=127).map(|v: i32| v as u32))
            .chain((0..32).map(|n| 1 << n))
            .chain((1..32).map(|n| (1 << n) - 1))
        {
            assert_eq!(decode(code(v)), v, "{v:#X}");
        }
        let mut seen: heapless::Vec<u32, 32> = heapless::Vec::new();
        for v in VALUES {
            assert!(!seen.contains(&v) && code(v) & 0xE0 == 0x80, "{v:#X}: twice or coded otherwise");
            seen.push(v).unwrap();
        }
        // The builders keep a default set before or after the limits.
        let e = Entry::var(0x2000, "X", DataType::Integer32, Access::Rw, 7).range(-10239, 10239);
        assert_eq!((e.default_value(0), e.limits()), (7, Some((-10239, 10239))));
        let e = e.with_default(100_000);
        assert_eq!((e.default(), e.limits()), (Default::Value(100_000), Some((-10239, 10239))));
        let e = e.plus_node_id(0x100).range(-1, 1);
        assert_eq!((e.default(), e.default_value(2), e.limits()), (Default::PlusNodeId(0x100), 0x102, Some((-1, 1))));
    }

    #[test]
    #[should_panic(expected = "outside 20h-7Eh")]
    fn a_string_must_be_visible() {
        let _ = Entry::string(0x1008, "Name", "AB\0C");
    }

    #[test]
    #[should_panic(expected = "a string has no limits")]
    fn a_string_has_no_limits() {
        let _ = Entry::string(0x1008, "Name", "AB").range(0, 1);
    }

    #[test]
    fn defaults_limits_and_kinds_round_trip() {
        let e = Entry::member(0x1800, 1, "COB-ID", DataType::Unsigned32, Access::Rw, 0).plus_node_id(0x180);
        assert_eq!((e.default(), e.default_value(0x7F), e.size()), (Default::PlusNodeId(0x180), 0x1FF, 4));
        let mut shown: heapless::String<256> = heapless::String::new();
        core::fmt::Write::write_fmt(&mut shown, format_args!("{e:?}")).unwrap();
        assert!(shown.contains("kind: Member") && shown.contains("default: PlusNodeId(384)"), "{shown}");
        let e = e.with_default(0x8000_0000);
        assert_eq!((e.default(), e.default_value(0x7F)), (Default::Value(0x8000_0000), 0x8000_0000));
        let e = Entry::var(0x2000, "I8", DataType::Integer8, Access::Rw, -3i8 as u8 as u32).range(-128, 127);
        assert_eq!((e.limits(), e.dtype.to_i64(e.default_value(1))), (Some((-128, 127)), -3));
        let e = Entry::var(0x2001, "I16", DataType::Integer16, Access::Rw, 0).range(-32768, -1);
        assert_eq!(e.limits(), Some((-32768, -1)));
        let e = Entry::var(0x2002, "U32", DataType::Unsigned32, Access::Rw, u32::MAX).range(0, u32::MAX as i64);
        assert_eq!((e.limits(), e.default_value(0)), (Some((0, u32::MAX as i64)), u32::MAX));
        let e = e.pdo().group(Group::Manuf).hook(Hook::Device(200));
        assert_eq!(
            (e.pdo, e.group, e.hook, e.limits()),
            (true, Group::Manuf, Hook::Device(200), Some((0, 0xFFFF_FFFF)))
        );
        let kinds = [
            (Entry::var(0x1000, "V", DataType::Unsigned8, Access::Ro, 0), Kind::Var, 7),
            (Entry::record(0x1018, "R", 4, Access::Const), Kind::Head { array: false }, 9),
            (Entry::array(0x1010, "A", 4, Access::Const), Kind::Head { array: true }, 8),
            (Entry::member(0x1018, 1, "M", DataType::Unsigned8, Access::Ro, 0), Kind::Member, 7),
        ];
        for (e, kind, object_type) in kinds {
            assert_eq!((e.kind(), e.object_type(), e.limits()), (kind, object_type, None), "{e:?}");
        }
        assert_eq!(Entry::record(0x1018, "R", 4, Access::Const).default(), Default::Value(4));
    }

    #[test]
    fn a_factory_node_id_replaces_the_marked_default_only() {
        static F: &[Entry] = &[
            Entry::member(0x1800, 1, "COB-ID", DataType::Unsigned32, Access::Rw, 0).plus_node_id(0x180),
            Entry::var(0x5F0A, "Node-ID", DataType::Unsigned8, Access::Rw, 1).range(1, 127).factory_node_id(),
        ];
        let declared = Od::new(F, 1);
        assert_eq!((declared.get(0), declared.get(1), declared.factory_node_id()), (0x181, 1, None));
        let second = Od::with_factory_node_id(F, 2, Some(2));
        assert_eq!((second.get(0), second.get(1), second.factory_node_id()), (0x182, 2, Some(2)));
        assert_eq!((second.default_of(&F[0], 9), second.default_of(&F[1], 9)), (0x189, 2));
        assert_eq!((F[1].default(), F[1].default_value(9), F[1].limits()), (Default::Value(1), 1, Some((1, 127))));
    }

    mod limits {
        extern crate std;
        use super::*;
        use proptest::prelude::*;
        use std::boxed::Box;

        proptest! {
            /// The limit check (32-bit order keys) refuses exactly the values outside the
            /// limits read as numbers of the type, for every numeric type and any limits.
            #[test]
            fn limits_compare_as_numbers(t in 0usize..7, a in any::<u32>(), b in any::<u32>(), v in any::<u32>()) {
                use DataType::*;
                let dtype = [Boolean, Integer8, Integer16, Integer32, Unsigned8, Unsigned16, Unsigned32][t];
                let bytes = dtype.size();
                let cut = |x: u32| if bytes == 4 { x } else { x & ((1 << (8 * bytes)) - 1) };
                let (a, b, v) = (cut(a), cut(b), cut(v));
                let (lo, hi) = if dtype.to_i64(a) <= dtype.to_i64(b) { (a, b) } else { (b, a) };
                let n = dtype.to_i64(v);
                prop_assert_eq!(dtype.within(v, lo, hi), dtype.to_i64(lo) <= n && n <= dtype.to_i64(hi));
            }

            /// A declared entry's limits, any that an entry can hold ([`code`]), refuse
            /// exactly the values outside them read as numbers of the type.
            #[test]
            fn declared_limits_compare_as_numbers(t in 0usize..7, a in any::<u8>(), b in any::<u8>(), v in any::<u32>()) {
                use DataType::*;
                let dtype = [Boolean, Integer8, Integer16, Integer32, Unsigned8, Unsigned16, Unsigned32][t];
                let bytes = dtype.size();
                let cut = |x: u32| if bytes == 4 { x } else { x & ((1 << (8 * bytes)) - 1) };
                let number = |x: u32| if dtype.is_signed() { x as i32 as i64 } else { x as i64 };
                let valid = |c: u8| c & 0xE0 != 0x80 || ((c & 0x1F) as usize) < VALUES.len();
                prop_assume!(valid(a) && valid(b));
                let (a, b) = (number(decode(a)), number(decode(b)));
                prop_assume!(dtype.to_i64(a as u32) == a && dtype.to_i64(b as u32) == b);
                let v = cut(v);
                let (lo, hi) = (a.min(b), a.max(b));
                let table: &'static [Entry] =
                    Box::leak(Box::new([Entry::var(0x2000, "X", dtype, Access::Rw, 0).range(lo, hi)]));
                let od = Od::new(table, 1);
                let n = dtype.to_i64(v);
                let expected = if n < lo || n > hi || (dtype == Boolean && v > 1) {
                    Err(Abort::INVALID_VALUE)
                } else {
                    Ok(v)
                };
                prop_assert_eq!(od.check_write(0, &v.to_le_bytes()[..bytes]), expected);
            }
        }
    }

    #[cfg(feature = "names")]
    #[test]
    fn names_are_kept_with_the_feature() {
        let head = Entry::record(0x1018, "Identity", 4, Access::Const);
        assert_eq!((head.name(), head.object()), ("Highest sub-index supported", Some("Identity")));
        let head = head.named("Number of entries");
        assert_eq!((head.name(), head.object()), ("Number of entries", Some("Identity")));
        assert_eq!((T[4].name(), T[4].object()), ("Vendor", None));
    }
}
