//! CiA 306 electronic data sheets (EDS) generated from a device's dictionary declaration.
//!
//! [`generate`] turns any device table (`&'static [Entry]`) and its [`EdsInfo`] into the text
//! of an EDS file: `[FileInfo]`, `[DeviceInfo]`, `[DummyUsage]`, the object lists
//! `[MandatoryObjects]` (1000h, 1001h, 1018h), `[OptionalObjects]` (the rest of 1000h-1FFFh
//! and 6000h-FFFFh) and `[ManufacturerObjects]` (2000h-5FFFh), then one section per object
//! and, for records and arrays, one per sub-index, with ParameterName, ObjectType, DataType,
//! AccessType, DefaultValue (`$NODEID+base` for node-ID-relative defaults), PDOMapping and
//! LowLimit/HighLimit. [`table_json`] dumps the same table as JSON for the Python check that
//! reads the EDS back with python-canopen (`tests-host/py/test_eds.py`).
//!
//! The files are checked in under `eds/` at the repository root; `tests/eds.rs` fails when
//! they differ from what this module generates (regenerate with `UPDATE_EDS=1 cargo test -p
//! tests-host --test eds`). A device is added to [`devices`].

use std::fmt::Write;

use od_core::devices::wv5800m::{table_of, Model, Turns, Variant};
use od_core::node::{CanopenDevice, Device};
use od_core::od::{Access, CoreHook, DataType, Default, Entry, Hook, Kind};
use od_core::pdo::{rpdo_type_allowed, tpdo_type_allowed};
use od_core::Bitrate;

use crate::TableOnly;

/// What an EDS says beyond the dictionary itself.
#[derive(Clone, Debug)]
pub struct EdsInfo {
    /// File name, also the stem of the JSON dump (`SGH10.eds`).
    pub file_name: &'static str,
    /// One line describing the device.
    pub description: &'static str,
    /// FileVersion (a new one for each released change of the file).
    pub file_version: u8,
    /// FileRevision.
    pub file_revision: u8,
    /// Creation date as CiA 306 writes it (mm-dd-yyyy); fixed, so that the file is reproducible.
    pub creation_date: &'static str,
    /// Creation time (hh:mm(AM|PM)).
    pub creation_time: &'static str,
    /// Author.
    pub created_by: &'static str,
    /// Vendor name.
    pub vendor_name: &'static str,
    /// Order code.
    pub order_code: &'static str,
    /// Bit rates the device runs at.
    pub bitrates: Vec<Bitrate>,
    /// Does the device have an LSS slave?
    pub lss: bool,
}

/// Which product an EDS describes: what a test needs to power one on and probe it.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Part {
    /// SGH10 or SGH10L (one dictionary, D-SGH10-7).
    Sgh10,
    /// SGH50, single or either channel of the redundant version (D-SGH50-4).
    Sgh50,
    /// One of the eight WV5800M / WH5800M part numbers (D-WV-1).
    Wv5800m(Variant),
    /// The AP10T set point display.
    Ap10t,
}

/// One checked-in EDS: what it says beyond the dictionary, the dictionary, and the part.
#[derive(Clone, Debug)]
pub struct EdsDevice {
    /// File info.
    pub info: EdsInfo,
    /// The dictionary.
    pub table: &'static [Entry],
    /// The product.
    pub part: Part,
}

/// The file name of a WV5800M / WH5800M part number's EDS: the model's name, and the number of
/// revolutions unless it is the 12-bit multiturn (4096), the default build and simulator variant
/// (`WV5800M.eds`, `WV5800M-256.eds`, `WV5800M-16.eds`, `WV5800M-1.eds`, and so for WH5800M).
pub fn wv5800m_file_name(variant: Variant) -> String {
    match variant.turns {
        Turns::Multi12 => format!("{}.eds", variant.model.name()),
        t => format!("{}-{}.eds", variant.model.name(), t.revolutions()),
    }
}

/// The eight WV5800M / WH5800M part numbers.
pub fn wv5800m_variants() -> Vec<Variant> {
    let mut v = Vec::new();
    for model in [Model::Wv, Model::Wh] {
        for turns in [Turns::Multi12, Turns::Multi8, Turns::Multi4, Turns::Single] {
            v.push(Variant { model, turns });
        }
    }
    v
}

fn leak(s: String) -> &'static str {
    Box::leak(s.into_boxed_str())
}

/// The devices whose EDS is checked in under `eds/`, one per part number (D-EDS-1).
pub fn devices() -> Vec<EdsDevice> {
    let sgh10 = TableOnly(od_core::devices::sgh10::TABLE);
    // The redundant version's second encoder differs only in the 5F0Ah.01 default (2): one
    // file serves both, as configurators take the node-ID from the network.
    let sgh50 = TableOnly(od_core::devices::sgh50::TABLE);
    let base =
        |file_name: &'static str, description: &'static str, order_code: &'static str, device: &TableOnly| EdsInfo {
            file_name,
            description,
            file_version: 1,
            file_revision: 1,
            creation_date: "11-24-2026",
            creation_time: "12:00PM",
            created_by: "SIKO GmbH",
            vendor_name: "SIKO GmbH",
            order_code,
            bitrates: rates(device),
            lss: device.has_lss(),
        };
    let mut v = vec![
        EdsDevice {
            info: base(
                "SGH10.eds",
                "SIKO SGH10 / SGH10L absolute wire-actuated encoder, CANopen (CiA 301, CiA 406, CiA 305)",
                "SGH10",
                &sgh10,
            ),
            table: sgh10.table(),
            part: Part::Sgh10,
        },
        EdsDevice {
            info: base(
                "SGH50.eds",
                "SIKO SGH50 absolute wire-actuated encoder, single or redundant, CANopen (CiA 301, CiA 406, CiA 305)",
                "SGH50",
                &sgh50,
            ),
            table: sgh50.table(),
            part: Part::Sgh50,
        },
    ];
    for variant in wv5800m_variants() {
        let device = TableOnly(table_of(variant));
        let range = match variant.turns {
            Turns::Single => "singleturn".to_string(),
            t => format!("{}-bit multiturn ({} revolutions)", t.revolutions().trailing_zeros(), t.revolutions()),
        };
        let name = variant.model.name();
        let file = leak(wv5800m_file_name(variant));
        let description =
            leak(format!("SIKO {name} absolute rotary encoder, {range}, CANopen (CiA 301, CiA 406, CiA 305)"));
        let order_code = leak(file.trim_end_matches(".eds").to_string());
        v.push(EdsDevice {
            info: base(file, description, order_code, &device),
            table: device.table(),
            part: Part::Wv5800m(variant),
        });
    }
    // The AP10T: its own bit-rate coding (5F0Ah.03) and no LSS.
    let ap10t = od_core::devices::ap10t::Ap10t::new();
    v.push(EdsDevice {
        info: EdsInfo {
            file_name: "AP10T.eds",
            description: "SIKO AP10T set point display, CANopen (CiA 301; CiA 406 objects, no LSS)",
            file_version: 1,
            file_revision: 0,
            creation_date: "11-25-2026",
            creation_time: "12:00PM",
            created_by: "SIKO GmbH",
            vendor_name: "SIKO GmbH",
            order_code: "AP10T",
            bitrates: rates(&ap10t),
            lss: ap10t.has_lss(),
        },
        table: ap10t.table(),
        part: Part::Ap10t,
    });
    v
}

/// The limits the EDS declares for `e` (D-EDS-2): the declared range of the entry, narrowed by
/// the value rules the core's write hooks enforce. CiA 306 has only LowLimit/HighLimit, so a
/// set with holes is declared by its smallest and largest accepted value; the holes are listed
/// in the file's `[Comments]` (see [`holes`]). Bit-pattern rules (COB-IDs) and command
/// signatures (1010h "save", 1011h "load") are not ranges and are not declared.
pub fn declared_limits(table: &[Entry], e: &Entry) -> Option<(i64, i64)> {
    match allowed_u8(table, e) {
        Some(allowed) => {
            let lo = (0..=255u8).find(|v| allowed(*v))? as i64;
            let hi = (0..=255u8).rev().find(|v| allowed(*v))? as i64;
            // The whole type without a hole is no limit; with holes (the AP10T's RPDO types:
            // 0..240, FEh, FFh) the range is declared so that its holes can be.
            if (lo, hi) == (0, 255) && (0..=255u8).all(&allowed) {
                None
            } else {
                Some((lo, hi))
            }
        }
        None => e.limits(),
    }
}

/// For the 8-bit entries whose accepted values a core hook decides (transmission types, 1003h
/// sub 0): the accepted set, within the entry's own limits.
fn allowed_u8(table: &[Entry], e: &Entry) -> Option<Box<dyn Fn(u8) -> bool>> {
    let own = e.limits();
    let within = move |v: u8| own.is_none_or(|(lo, hi)| (lo..=hi).contains(&(v as i64)));
    let rule: Box<dyn Fn(u8) -> bool> = match e.hook {
        Hook::Core(CoreHook::PdoTransmissionType) if (0x1800..=0x19FF).contains(&e.index) => {
            // D-PDO-3: a writable event timer makes the TPDO asynchronous.
            let asynchronous = table.iter().any(|x| x.index == e.index && x.sub == 5 && x.access.writable());
            Box::new(move |v| tpdo_type_allowed(asynchronous, v))
        }
        Hook::Core(CoreHook::PdoTransmissionType) => Box::new(rpdo_type_allowed),
        // D-EMCY-6: only 0 (clear the history).
        Hook::Core(CoreHook::ErrorHistory) => Box::new(|v| v == 0),
        _ => return None,
    };
    Some(Box::new(move |v| within(v) && rule(v)))
}

/// The values between an entry's declared limits that it refuses, as ranges (1801h sub 2 of the
/// SGH10: 241..=251): what LowLimit/HighLimit cannot say. Only for the 8-bit entries whose set a
/// core hook decides, and 1017h (D-HB-1: 1..9 refused).
pub fn holes(table: &[Entry], e: &Entry) -> Vec<(i64, i64)> {
    // 1017h (D-HB-1) and the AP10T's external heartbeat 5F09h.01 (D-AP-19): 1..9 ms refused.
    let external_heartbeat = (e.index, e.sub) == (0x5F09, 1)
        && e.hook == Hook::Device(od_core::devices::ap10t::table::hooks::EXTERNAL_HEARTBEAT);
    let refused: Vec<i64> = if e.hook == Hook::Core(CoreHook::HeartbeatTime) || external_heartbeat {
        (1..=9).collect()
    } else if let (Some(allowed), Some((lo, hi))) = (allowed_u8(table, e), declared_limits(table, e)) {
        (lo..=hi).filter(|v| !allowed(*v as u8)).collect()
    } else {
        Vec::new()
    };
    let mut out: Vec<(i64, i64)> = Vec::new();
    for v in refused {
        match out.last_mut() {
            Some((_, hi)) if *hi + 1 == v => *hi = v,
            _ => out.push((v, v)),
        }
    }
    out
}

/// The bit rates a device's pending bit-rate entry can select.
pub fn rates(device: &impl Device) -> Vec<Bitrate> {
    device.bitrate_codes().iter().map(|(_, b)| *b).collect()
}

/// The CiA 306 AccessType.
fn access(a: Access) -> &'static str {
    match a {
        Access::Ro => "ro",
        Access::Wo => "wo",
        Access::Rw => "rw",
        Access::Const => "const",
        // CiA 306 has no "no access": a PDO-only object is read by its TPDO, so "ro" (a
        // configurator maps it; an SDO read answers 06010000h).
        Access::PdoOnly => "ro",
    }
}

/// A number as the EDS writes it: hexadecimal, negative INTEGERs in decimal.
fn number(dtype: DataType, raw: u32) -> String {
    let v = dtype.to_i64(raw);
    if v < 0 {
        v.to_string()
    } else {
        format!("0x{v:X}")
    }
}

/// A limit (already in the type's numeric range).
fn limit(v: i64) -> String {
    if v < 0 {
        v.to_string()
    } else {
        format!("0x{v:X}")
    }
}

/// The DefaultValue of an entry.
fn default_value(e: &Entry) -> String {
    match e.default() {
        Default::Value(v) => number(e.dtype, v),
        Default::PlusNodeId(base) => format!("$NODEID+0x{base:X}"),
        Default::Str(s) => s.to_string(),
    }
}

/// The name of an object: the record/array name for a head, the entry's own for a variable.
fn object_name(e: &Entry) -> &'static str {
    e.object().unwrap_or(e.name())
}

/// Writes the keys of one variable (a VAR object or a sub-index).
fn variable(out: &mut String, table: &[Entry], e: &Entry) {
    let _ = writeln!(out, "ParameterName={}", e.name());
    let _ = writeln!(out, "ObjectType=0x7");
    let _ = writeln!(out, "DataType=0x{:04X}", e.dtype as u16);
    let _ = writeln!(out, "AccessType={}", access(e.access));
    let _ = writeln!(out, "DefaultValue={}", default_value(e));
    let _ = writeln!(out, "PDOMapping={}", e.pdo as u8);
    if let Some((lo, hi)) = declared_limits(table, e) {
        let _ = writeln!(out, "LowLimit={}", limit(lo));
        let _ = writeln!(out, "HighLimit={}", limit(hi));
    }
}

/// The object indices of `table` that `pick` selects, in order, each once.
fn objects(table: &[Entry], pick: impl Fn(u16) -> bool) -> Vec<u16> {
    let mut v: Vec<u16> = table.iter().map(|e| e.index).filter(|i| pick(*i)).collect();
    v.dedup();
    v
}

fn object_list(out: &mut String, section: &str, list: &[u16]) {
    let _ = writeln!(out, "[{section}]");
    let _ = writeln!(out, "SupportedObjects={}", list.len());
    for (n, index) in list.iter().enumerate() {
        let _ = writeln!(out, "{}=0x{index:04X}", n + 1);
    }
    out.push('\n');
}

/// Is the object one CiA 306 lists under [MandatoryObjects]?
fn mandatory(index: u16) -> bool {
    matches!(index, 0x1000 | 0x1001 | 0x1018)
}

/// Is the object manufacturer-specific (2000h-5FFFh)?
fn manufacturer(index: u16) -> bool {
    (0x2000..=0x5FFF).contains(&index)
}

/// The `[Comments]` lines: the values inside an entry's LowLimit..HighLimit that it refuses.
fn comments(table: &[Entry]) -> Vec<String> {
    let mut lines = Vec::new();
    for e in table {
        let holes = holes(table, e);
        if holes.is_empty() {
            continue;
        }
        let list: Vec<String> = holes
            .iter()
            .map(|&(lo, hi)| if lo == hi { limit(lo) } else { format!("{}..{}", limit(lo), limit(hi)) })
            .collect();
        lines.push(format!("{:04X}sub{:X} refuses {} (SDO abort 06090030h)", e.index, e.sub, list.join(", ")));
    }
    lines
}

/// The EDS text of the device `table` described by `info`.
///
/// Panics if the table lacks the identity (1018h.01..03) or the device name (1008h): every
/// CANopen device declares them (CiA 301 mandatory/usual objects).
pub fn generate(info: &EdsInfo, table: &[Entry]) -> String {
    let find = |index: u16, sub: u8| table.iter().find(|e| e.index == index && e.sub == sub);
    let ident = |sub: u8| find(0x1018, sub).map(|e| e.default_value(0)).expect("1018h identity declared");
    let product = match find(0x1008, 0).map(|e| e.default()) {
        Some(Default::Str(s)) => s,
        _ => panic!("1008h device name declared"),
    };
    let mut out = String::new();
    let w = &mut out;
    let _ = writeln!(w, "[FileInfo]");
    let _ = writeln!(w, "FileName={}", info.file_name);
    let _ = writeln!(w, "FileVersion={}", info.file_version);
    let _ = writeln!(w, "FileRevision={}", info.file_revision);
    let _ = writeln!(w, "EDSVersion=4.0");
    let _ = writeln!(w, "Description={}", info.description);
    let _ = writeln!(w, "CreationTime={}", info.creation_time);
    let _ = writeln!(w, "CreationDate={}", info.creation_date);
    let _ = writeln!(w, "CreatedBy={}", info.created_by);
    let _ = writeln!(w, "ModificationTime={}", info.creation_time);
    let _ = writeln!(w, "ModificationDate={}", info.creation_date);
    let _ = writeln!(w, "ModifiedBy={}", info.created_by);
    w.push('\n');
    let _ = writeln!(w, "[DeviceInfo]");
    let _ = writeln!(w, "VendorName={}", info.vendor_name);
    let _ = writeln!(w, "VendorNumber=0x{:X}", ident(1));
    let _ = writeln!(w, "ProductName={product}");
    let _ = writeln!(w, "ProductNumber=0x{:X}", ident(2));
    let _ = writeln!(w, "RevisionNumber=0x{:X}", ident(3));
    let _ = writeln!(w, "OrderCode={}", info.order_code);
    for rate in [10, 20, 50, 125, 250, 500, 800, 1000] {
        let ok = info.bitrates.iter().any(|b| b.kbit() == rate);
        let _ = writeln!(w, "BaudRate_{rate}={}", ok as u8);
    }
    let tx = objects(table, |i| (0x1800..=0x19FF).contains(&i)).len();
    let rx = objects(table, |i| (0x1400..=0x15FF).contains(&i)).len();
    let _ = writeln!(w, "SimpleBootUpMaster=0");
    let _ = writeln!(w, "SimpleBootUpSlave=1");
    // Mapping entries are read-only in every device: no granularity.
    let _ = writeln!(w, "Granularity=0");
    let _ = writeln!(w, "DynamicChannelsSupported=0");
    let _ = writeln!(w, "GroupMessaging=0");
    let _ = writeln!(w, "NrOfRXPDO={rx}");
    let _ = writeln!(w, "NrOfTXPDO={tx}");
    let _ = writeln!(w, "LSS_Supported={}", info.lss as u8);
    w.push('\n');
    let _ = writeln!(w, "[DummyUsage]");
    for n in 1..=7 {
        let _ = writeln!(w, "Dummy{n:04}=0");
    }
    w.push('\n');
    let comments = comments(table);
    if !comments.is_empty() {
        let _ = writeln!(w, "[Comments]");
        let _ = writeln!(w, "Lines={}", comments.len());
        for (n, line) in comments.iter().enumerate() {
            let _ = writeln!(w, "Line{}={line}", n + 1);
        }
        w.push('\n');
    }
    object_list(w, "MandatoryObjects", &objects(table, mandatory));
    object_list(w, "OptionalObjects", &objects(table, |i| !mandatory(i) && !manufacturer(i)));
    object_list(w, "ManufacturerObjects", &objects(table, manufacturer));
    for (pos, e) in table.iter().enumerate() {
        match e.kind() {
            Kind::Var => {
                let _ = writeln!(w, "[{:04X}]", e.index);
                variable(w, table, e);
            }
            Kind::Head { .. } => {
                let subs = table[pos..].iter().take_while(|x| x.index == e.index).count();
                let _ = writeln!(w, "[{:04X}]", e.index);
                let _ = writeln!(w, "ParameterName={}", object_name(e));
                let _ = writeln!(w, "ObjectType=0x{:X}", e.object_type());
                let _ = writeln!(w, "SubNumber={subs}");
                w.push('\n');
                let _ = writeln!(w, "[{:04X}sub0]", e.index);
                variable(w, table, e);
            }
            Kind::Member => {
                let _ = writeln!(w, "[{:04X}sub{:X}]", e.index, e.sub);
                variable(w, table, e);
            }
        }
        w.push('\n');
    }
    out
}

/// A JSON string literal.
fn json_str(s: &str) -> String {
    let mut o = String::from("\"");
    for c in s.chars() {
        match c {
            '"' => o.push_str("\\\""),
            '\\' => o.push_str("\\\\"),
            c if (c as u32) < 0x20 => {
                let _ = write!(o, "\\u{:04x}", c as u32);
            }
            c => o.push(c),
        }
    }
    o.push('"');
    o
}

/// The table as JSON, one object per entry: index, sub, name, data_type (CiA 301 code),
/// object (the name of the object it belongs to), access, pdo, default (number, with `node_id_base` true for `$NODEID+` defaults; or a
/// string), low/high limits (or null). What the Python check compares the EDS with.
pub fn table_json(table: &[Entry]) -> String {
    let mut out = String::from("[\n");
    let mut object = "";
    for (n, e) in table.iter().enumerate() {
        if e.kind() != Kind::Member {
            object = object_name(e);
        }
        let (default, relative) = match e.default() {
            Default::Value(v) => (e.dtype.to_i64(v).to_string(), false),
            Default::PlusNodeId(b) => (b.to_string(), true),
            Default::Str(s) => (json_str(s), false),
        };
        let (lo, hi) = match declared_limits(table, e) {
            Some((lo, hi)) => (lo.to_string(), hi.to_string()),
            None => ("null".into(), "null".into()),
        };
        let _ = write!(
            out,
            "  {{\"index\": {}, \"sub\": {}, \"name\": {}, \"object\": {}, \"data_type\": {}, \"access\": \"{}\", \
             \"pdo\": {}, \"default\": {}, \"node_id_relative\": {}, \"low\": {}, \"high\": {}}}",
            e.index,
            e.sub,
            json_str(e.name()),
            json_str(object),
            e.dtype as u16,
            access(e.access),
            e.pdo,
            default,
            relative,
            lo,
            hi
        );
        out.push_str(if n + 1 < table.len() { ",\n" } else { "\n" });
    }
    out.push_str("]\n");
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use od_core::od::{Access::*, DataType::*};

    static T: &[Entry] = &[
        Entry::var(0x1000, "Device type", Unsigned32, Const, 0x000A_0196),
        Entry::string(0x1008, "Name", "X"),
        Entry::var(0x1014, "COB-ID EMCY", Unsigned32, Rw, 0).plus_node_id(0x80),
        Entry::record(0x1018, "Identity object", 3, Const),
        Entry::member(0x1018, 1, "Vendor-ID", Unsigned32, Ro, 0x195),
        Entry::member(0x1018, 2, "Product code", Unsigned32, Ro, 7),
        Entry::member(0x1018, 3, "Revision number", Unsigned32, Ro, 8),
        Entry::var(0x5000, "M", Unsigned8, Rw, 1),
        Entry::var(0x6401, "Limit", Integer32, Rw, -5i32 as u32).range(-10, 10).pdo(),
    ];

    fn info() -> EdsInfo {
        EdsInfo {
            file_name: "X.eds",
            description: "x",
            file_version: 1,
            file_revision: 0,
            creation_date: "01-01-2026",
            creation_time: "12:00PM",
            created_by: "me",
            vendor_name: "v",
            order_code: "o",
            bitrates: vec![Bitrate::K125, Bitrate::K1000],
            lss: false,
        }
    }

    #[test]
    fn sections_and_keys() {
        let eds = generate(&info(), T);
        for needle in [
            "VendorNumber=0x195\nProductName=X\nProductNumber=0x7\nRevisionNumber=0x8\n",
            "BaudRate_10=0\n",
            "BaudRate_125=1\n",
            "BaudRate_1000=1\n",
            "LSS_Supported=0\n",
            "[MandatoryObjects]\nSupportedObjects=2\n1=0x1000\n2=0x1018\n\n",
            "[OptionalObjects]\nSupportedObjects=3\n1=0x1008\n2=0x1014\n3=0x6401\n\n",
            "[ManufacturerObjects]\nSupportedObjects=1\n1=0x5000\n\n",
            "[1014]\nParameterName=COB-ID EMCY\nObjectType=0x7\nDataType=0x0007\nAccessType=rw\nDefaultValue=$NODEID+0x80\nPDOMapping=0\n",
            "[1018]\nParameterName=Identity object\nObjectType=0x9\nSubNumber=4\n\n[1018sub0]\nParameterName=Highest sub-index supported\n",
            "[6401]\nParameterName=Limit\nObjectType=0x7\nDataType=0x0004\nAccessType=rw\nDefaultValue=-5\nPDOMapping=1\nLowLimit=-10\nHighLimit=0xA\n",
            "[1008]\nParameterName=Name\nObjectType=0x7\nDataType=0x0009\nAccessType=const\nDefaultValue=X\n",
        ] {
            assert!(eds.contains(needle), "missing {needle:?} in\n{eds}");
        }
    }

    #[test]
    fn json_dump() {
        let j = table_json(&T[..3]);
        assert!(j.contains("\"index\": 4116, \"sub\": 0, \"name\": \"COB-ID EMCY\""));
        assert!(j.contains("\"default\": 128, \"node_id_relative\": true"));
        assert!(j.contains("\"default\": \"X\""));
        assert_eq!(json_str("a\"b\\\n"), "\"a\\\"b\\\\\\u000a\"");
    }
}
