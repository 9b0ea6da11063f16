//! The WV58MR dictionary against `shared/spec/WV58MR.od.csv` (checked in as
//! `tests/data/WV58MR.od.csv`), row by row: every row is declared, nothing else is, and each
//! row's type, access, default, limits and storage group are the printed ones, except the
//! departures `docs/decisions.md` names (D-J1939-14 ff.), listed here one by one.

use od_core::devices::wv5800m::Turns;
use od_core::devices::wv58mr::table_of;
use od_core::od::{Access, DataType, Default, Entry, Group, Kind};

const CSV: &str = include_str!("data/WV58MR.od.csv");

/// Splits one CSV line (quoted fields may hold commas).
fn fields(line: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut cur = String::new();
    let mut quoted = false;
    for c in line.chars() {
        match c {
            '"' => quoted = !quoted,
            ',' if !quoted => out.push(std::mem::take(&mut cur)),
            c => cur.push(c),
        }
    }
    out.push(cur);
    out
}

fn variant_index(turns: Turns) -> usize {
    match turns {
        Turns::Single => 0,
        Turns::Multi4 => 1,
        Turns::Multi8 => 2,
        Turns::Multi12 => 3,
    }
}

/// A printed number: hex `0x..`, decimal, or a per-variant list `ST:a / MT4:b / MT8:c / MT12:d`
/// (or `ST: a / MT: b`), with any trailing explanation after the list ignored.
fn number(cell: &str, turns: Turns) -> Option<i64> {
    let cell = cell.trim();
    if cell.is_empty() {
        return None;
    }
    if cell.starts_with("ST") {
        let parts: Vec<&str> = cell.split('/').map(str::trim).collect();
        let pick = if parts.len() == 2 {
            if turns == Turns::Single {
                parts[0]
            } else {
                parts[1]
            }
        } else {
            parts[variant_index(turns)]
        };
        let v = pick.split(':').nth(1)?.trim();
        let v = v.split_whitespace().next()?;
        return number(v, turns);
    }
    if let Some(h) = cell.strip_prefix("0x") {
        return i64::from_str_radix(h, 16).ok();
    }
    cell.parse().ok()
}

fn dtype(s: &str) -> DataType {
    match s {
        "UNSIGNED8" => DataType::Unsigned8,
        "UNSIGNED16" => DataType::Unsigned16,
        "UNSIGNED32" => DataType::Unsigned32,
        "INTEGER16" => DataType::Integer16,
        "INTEGER32" => DataType::Integer32,
        "VISIBLE_STRING" => DataType::VisibleString,
        other => panic!("type {other}"),
    }
}

fn access(s: &str) -> Access {
    match s {
        "ro" => Access::Ro,
        "rw" => Access::Rw,
        "wo" => Access::Wo,
        "const" => Access::Const,
        other => panic!("access {other}"),
    }
}

/// The storage group a printed store-group cell means.
fn group(s: &str) -> Option<Group> {
    Some(match s {
        "none" => Group::None,
        "01+02" => Group::Comm,
        "01+03" => Group::App,
        "01+04" => Group::Manuf,
        "factory (EEPROM ro)" => Group::Factory,
        // Read-only values in an "EEPROM: ja" group: derived or factory data, checked below.
        "01+03 (ro)" | "01+04 (ro)" => return None,
        other => panic!("group {other}"),
    })
}

/// The printed cells the table departs from, with the decision that says why.
fn departure(index: u16, sub: u8, column: &str) -> Option<&'static str> {
    Some(match (index, sub, column) {
        // 3000h.01-.06 stored with the manufacturer group, not "EEPROM: nein" (A4).
        (0x3000, 1..=6, "group") => "D-J1939-14",
        // 6200h is 3000h.03 (50 ms), not the printed 0 (A4).
        (0x6200, 0, "default") => "D-J1939-14",
        // 3001h.00 is the highest sub-index 0Ah, printed "10h" (A9a).
        (0x3001, 0, "default") => "D-J1939-16",
        // ManufacturerCode 0471h needs UNSIGNED16 (A9b).
        (0x3001, 2, "type") => "D-J1939-16",
        // 3001h.01 is the serial number (factory data), printed "Serial No." (A9c, A25).
        (0x3001, 1, "default") => "D-J1939-6",
        // 1003h.00: only 0 is accepted (it clears the history), so no 0..8 limits (D-EMCY).
        (0x1003, 0, "limits") => "D-J1939-18",
        // 650Eh: a constant, not factory-programmed.
        (0x650E, 0, "group") => "D-J1939-18",
        // 6002h: only APU × N is accepted, declared as N ..= 65535 × N (D-WV-3).
        (0x6002, 0, "limits") => "D-WV-3",
        // 6003h, 6401h, 6402h: declared up to the largest APU's range; the device checks the
        // current one (D-WV-5).
        (0x6003 | 0x6401 | 0x6402, _, "max") => "D-WV-5",
        // 650Ah.03: the "max" cell is its value at APU 65535; it follows 6001h (D-WV-3).
        (0x650A, 3, "limits") => "D-WV-3",
        // 6000h: only 0004h and 0005h (D-WV-6).
        (0x6000, 0, "limits") => "D-WV-6",
        // 3000h.01-.03, 6200h: the printed full range is declared.
        _ => return None,
    })
}

fn check(turns: Turns) {
    let table = table_of(turns);
    let n = [1i64, 16, 256, 4096][variant_index(turns)];
    let mut rows = CSV.lines().skip(1).filter(|l| !l.trim().is_empty()).map(fields).peekable();
    let mut seen = 0;
    for (k, row) in rows.by_ref().enumerate() {
        let index = u16::from_str_radix(&row[0], 16).unwrap();
        let sub = u8::from_str_radix(&row[1], 16).unwrap();
        let e: &Entry = &table[k];
        let at = format!("{turns:?} {index:04X}h.{sub:02X}");
        assert_eq!((e.index, e.sub), (index, sub), "{at}: row order");
        seen += 1;
        // Type.
        let t = dtype(&row[3]);
        if departure(index, sub, "type").is_none() {
            assert_eq!(e.dtype, t, "{at}: type");
        } else {
            assert_ne!(e.dtype, t, "{at}: a listed departure that is none");
        }
        // Access.
        assert_eq!(e.access, access(&row[4]), "{at}: access");
        // Mappable into the process-data groups.
        assert_eq!(e.pdo, row[5] == "y", "{at}: PGN-mapped");
        // Default.
        let printed = &row[6];
        match e.default() {
            Default::Str(s) => assert_eq!(s, printed, "{at}: default"),
            Default::Value(v) => {
                let v = e.dtype.to_i64(v);
                match (number(printed, turns), departure(index, sub, "default")) {
                    (Some(p), None) => assert_eq!(v, p, "{at}: default"),
                    (Some(p), Some(_)) => assert_ne!(v, p, "{at}: a listed departure that is none"),
                    (None, Some(_)) => {}
                    (None, None) => panic!("{at}: unprintable default {printed:?}"),
                }
            }
            Default::PlusNodeId(_) => panic!("{at}: no node-ID defaults on J1939"),
        }
        // Limits.
        let (lo, hi) = (number(&row[7], turns), number(&row[8], turns));
        let declared = e.limits();
        if departure(index, sub, "limits").is_none() {
            if let Some(lo) = lo {
                assert_eq!(declared.map(|l| l.0), Some(lo), "{at}: min");
            }
            if let Some(hi) = hi {
                if departure(index, sub, "max").is_some() {
                    assert_eq!(declared.map(|l| l.1), Some(65535 * n - 1), "{at}: max at the largest APU");
                } else {
                    assert_eq!(declared.map(|l| l.1), Some(hi), "{at}: max");
                }
            }
            if lo.is_none() && hi.is_none() && e.access == Access::Rw && !matches!(e.kind(), Kind::Head { .. }) {
                // A writable entry without printed limits takes its type's range (or a
                // documented rule).
                assert!(declared.is_none() || matches!(index, 0x6000 | 0x6002 | 0x1003), "{at}: limits {declared:?}");
            }
        }
        // Storage group.
        match group(&row[9]) {
            Some(g) if departure(index, sub, "group").is_none() => assert_eq!(e.group, g, "{at}: group"),
            Some(g) => assert_ne!(e.group, g, "{at}: a listed departure that is none"),
            // Read-only "EEPROM: ja" values: derived (650Ah.03) or factory (3001h) and not
            // stored by a user save.
            None => assert_eq!(e.group, Group::None, "{at}: group"),
        }
    }
    assert!(rows.peek().is_none());
    assert_eq!(seen, table.len(), "{turns:?}: rows in the table but not in the CSV");
}

#[test]
fn every_row_of_the_manual_with_its_cells() {
    for turns in [Turns::Single, Turns::Multi4, Turns::Multi8, Turns::Multi12] {
        check(turns);
    }
}

#[test]
fn departures_name_a_decision_that_exists() {
    let decisions = include_str!("../../docs/decisions.md");
    for id in ["D-J1939-14", "D-J1939-16", "D-J1939-6", "D-J1939-18", "D-WV-3", "D-WV-5", "D-WV-6"] {
        assert!(decisions.contains(&format!("- {id} (")), "{id} is not in docs/decisions.md");
    }
}
