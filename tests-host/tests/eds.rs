//! The checked-in EDS files (`eds/*.eds`) and their JSON table dumps (`eds/*.json`, read by
//! `tests-host/py/test_eds.py`) are what the generator makes of the device tables.
//! Regenerate after a table change: `UPDATE_EDS=1 cargo test -p tests-host --test eds`.

use std::path::PathBuf;

use tests_host::eds::{devices, generate, table_json};

fn eds_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..").join("eds")
}

#[test]
fn checked_in_eds_files_match_the_tables() {
    let update = std::env::var_os("UPDATE_EDS").is_some();
    let mut stale = Vec::new();
    for (info, table) in devices() {
        let stem = info.file_name.trim_end_matches(".eds");
        for (name, text) in
            [(info.file_name.to_string(), generate(&info, table)), (format!("{stem}.json"), table_json(table))]
        {
            let path = eds_dir().join(&name);
            let current = std::fs::read_to_string(&path).unwrap_or_default();
            if current != text {
                if update {
                    std::fs::write(&path, text).expect("write EDS");
                } else {
                    stale.push(name);
                }
            }
        }
    }
    assert!(
        stale.is_empty(),
        "eds/{stale:?} differ from the tables: regenerate with UPDATE_EDS=1 cargo test -p tests-host --test eds"
    );
}

#[test]
fn every_entry_has_a_section() {
    for (info, table) in devices() {
        let eds = generate(&info, table);
        for e in table {
            let section = match e.kind {
                od_core::od::Kind::Var => format!("[{:04X}]\n", e.index),
                _ => format!("[{:04X}sub{:X}]\n", e.index, e.sub),
            };
            assert!(eds.contains(&section), "{}: {section} missing", info.file_name);
        }
    }
}
