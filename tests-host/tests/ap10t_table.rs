//! The AP10T dictionary against the digest's object table (`data/AP10T.od.csv`, a copy of
//! `shared/spec/AP10T.od.csv`), row by row: every row the manual documents is declared with its
//! data type, access, PDO mapping, default, limits and storage group; the "not used" and
//! undocumented sub-indices are absent; nothing else is declared.

use od_core::devices::ap10t::table::{DEFAULT_NODE_ID, TABLE};
use od_core::od::{Access, DataType, Default, Entry, Group, Kind, Od};

const CSV: &str = include_str!("data/AP10T.od.csv");

/// One CSV record: fields split at commas outside double quotes, `""` an escaped quote.
fn fields(line: &str) -> Vec<String> {
    let mut out = vec![String::new()];
    let mut quoted = false;
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '"' if quoted && chars.peek() == Some(&'"') => {
                chars.next();
                out.last_mut().unwrap().push('"');
            }
            '"' => quoted = !quoted,
            ',' if !quoted => out.push(String::new()),
            c => out.last_mut().unwrap().push(c),
        }
    }
    out
}

struct Row {
    index: u16,
    sub: u8,
    dtype: String,
    access: String,
    pdo: bool,
    default: String,
    min: String,
    max: String,
    group: String,
}

fn rows() -> Vec<Row> {
    let mut lines = CSV.lines();
    let header = fields(lines.next().unwrap());
    assert_eq!(
        header,
        [
            "index",
            "subindex",
            "name",
            "type",
            "access",
            "pdo_mappable",
            "default",
            "min",
            "max",
            "store_group",
            "notes"
        ]
    );
    lines
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let f = fields(l);
            assert_eq!(f.len(), 11, "{l}");
            Row {
                index: u16::from_str_radix(&f[0], 16).unwrap(),
                sub: u8::from_str_radix(&f[1], 16).unwrap(),
                dtype: f[3].clone(),
                access: f[4].clone(),
                pdo: f[5] == "y",
                default: f[6].clone(),
                min: f[7].clone(),
                max: f[8].clone(),
                group: f[9].clone(),
            }
        })
        .collect()
}

fn number(s: &str) -> i64 {
    match s.strip_prefix("0x") {
        Some(h) => i64::from_str_radix(h, 16).unwrap(),
        None => s.parse().unwrap(),
    }
}

fn dtype(s: &str) -> DataType {
    match s {
        "UNSIGNED8" => DataType::Unsigned8,
        "UNSIGNED16" => DataType::Unsigned16,
        "UNSIGNED32" => DataType::Unsigned32,
        "VISIBLE_STRING" => DataType::VisibleString,
        other => panic!("type {other}"),
    }
}

fn find(index: u16, sub: u8) -> Option<&'static Entry> {
    TABLE.iter().find(|e| e.index == index && e.sub == sub)
}

/// Where the table deliberately differs from the digest's limits columns, and why.
fn limits_exception(index: u16, sub: u8) -> Option<&'static str> {
    match (index, sub) {
        // Only 0 may be written (it clears the history): the 1003h hook, not limits (D-EMCY).
        (0x1003, 0) => Some("1003h.00: write rule in the ErrorHistory hook"),
        // D-PDO-3: 1..240, FCh and FDh ("RTR only", printed in the same table) by the PDO hook.
        (0x1801, 2) => Some("1801h.02: transmission types by the PDO service"),
        _ => None,
    }
}

#[test]
fn every_documented_row_is_declared_as_the_digest_lists_it() {
    let rows = rows();
    assert_eq!(rows.len(), 131, "the digest's count");
    let mut declared = 0;
    for r in &rows {
        let at = format!("{:04X}h.{:02X}", r.index, r.sub);
        // "(not used)" (access none, no type) and the undocumented 5F1Bh.02 (no access).
        if r.dtype.is_empty() {
            assert!(find(r.index, r.sub).is_none(), "{at} must not exist");
            assert!(r.access == "none" || r.access.is_empty(), "{at}");
            continue;
        }
        declared += 1;
        let e = find(r.index, r.sub).unwrap_or_else(|| panic!("{at} missing"));
        assert_eq!(e.dtype, dtype(&r.dtype), "{at} type");
        let access = match r.access.as_str() {
            "ro" => Access::Ro,
            "rw" => Access::Rw,
            "const" => Access::Const,
            "none" => Access::PdoOnly,
            other => panic!("{at} access {other}"),
        };
        assert_eq!(e.access, access, "{at} access");
        assert_eq!(e.pdo, r.pdo, "{at} PDO mapping");
        // Default: a number, a base + node-ID, a string; 5F0Ah.02's is not stated (D-AP-14).
        match (e.default(), r.default.as_str()) {
            (Default::Str(s), d) => assert_eq!(s, d, "{at} default"),
            (Default::PlusNodeId(base), d) => {
                let (b, node) = d.split_once('+').unwrap_or_else(|| panic!("{at} default {d}"));
                assert_eq!(node, "NodeID", "{at}");
                assert_eq!(base as i64, number(b), "{at} default base");
            }
            (Default::Value(v), "") => {
                assert_eq!((r.index, r.sub), (0x5F0A, 2), "{at}: only 5F0Ah.02 has no stated default");
                assert_eq!(v, DEFAULT_NODE_ID as u32, "{at}");
            }
            (Default::Value(v), d) => assert_eq!(e.dtype.to_i64(v), number(d), "{at} default"),
        }
        // Limits: those the digest gives; a range equal to the type's whole range is none.
        let full = match e.dtype {
            DataType::Unsigned8 => (0, 0xFF),
            DataType::Unsigned16 => (0, 0xFFFF),
            _ => (0, 0xFFFF_FFFF),
        };
        let want = if r.min.is_empty() { None } else { Some((number(&r.min), number(&r.max))) };
        let have = e.limits();
        match limits_exception(r.index, r.sub) {
            Some(_) => assert_eq!(have, None, "{at} limits"),
            None => assert_eq!(have.filter(|l| *l != full), want.filter(|l| *l != full), "{at} limits"),
        }
        let group = match r.group.as_str() {
            "none" => Group::None,
            "1;2" => Group::Comm,
            "1;3" => Group::App,
            "1;4" => Group::Manuf,
            other => panic!("{at} group {other}"),
        };
        assert_eq!(e.group, group, "{at} storage group");
    }
    // Nothing beyond the digest's rows.
    assert_eq!(TABLE.len(), declared);
    for e in TABLE {
        assert!(
            rows.iter().any(|r| r.index == e.index && r.sub == e.sub),
            "{:04X}h.{} not in the digest",
            e.index,
            e.sub
        );
    }
}

#[test]
fn records_heads_and_factory_identifiers() {
    let od = Od::new(TABLE, DEFAULT_NODE_ID);
    // Heads of the records with "highest sub-index" as the digest counts it.
    for (index, highest) in [(0x1010, 4), (0x1018, 4), (0x1200, 2), (0x1400, 5), (0x1A01, 3), (0x5F0A, 3), (0x5F12, 9)]
    {
        assert_eq!(od.value(index, 0), Some(highest), "{index:04X}h");
        assert!(matches!(od.entry(od.pos(index, 0).unwrap()).kind(), Kind::Head { .. }));
    }
    // Factory node-ID 7Dh: the Table 5 identifiers.
    for (index, sub, id) in
        [(0x1014, 0, 0x0FD), (0x1800, 1, 0x1FD), (0x1400, 1, 0x27D), (0x1801, 1, 0x2FD), (0x1401, 1, 0x37D)]
    {
        assert_eq!(od.value(index, sub), Some(id), "{index:04X}h.{sub}");
    }
    assert_eq!(od.value(0x1200, 1), Some(0x67D));
    assert_eq!(od.value(0x1200, 2), Some(0x5FD));
}
