//! The parameter pages the Renode bench loads into each board's flash (`renode/images`): the
//! same factory programming the simulator gives a blank flash, so the Renode bench's nodes have
//! the simulator bench's node-IDs (the AP10T's node-ID only: its serial number is a constant;
//! the WV58MR pair's serial numbers only: both keep the default address EFh and claiming
//! separates them, as in the simulator's bench). A test fails when a checked-in image differs from what the
//! dictionaries and the storage format give now; `UPDATE_RENODE=1 cargo test -p tests-host
//! --test renode_images` rewrites them.

use std::path::PathBuf;

use od_core::devices::{ap10t, sgh10, sgh50, wv5800m, wv58mr};
use od_core::storage::{identity, Loaded, ParamFlash};
use tests_host::flash::RamFlash;
use tests_host::sim::devices::{factory_pages, REGION};

/// An image: (file, dictionary, node-ID or J1939 address, serial number); None leaves the entry
/// at its default (not in the image).
type Spec = (&'static str, &'static [od_core::od::Entry], Option<u8>, Option<u32>);

fn images() -> Vec<Spec> {
    let wv = wv5800m::table_of(wv5800m::Variant { model: wv5800m::Model::Wv, turns: wv5800m::Turns::Multi12 });
    let mr = wv58mr::table_of(wv5800m::Turns::Multi12);
    vec![
        ("sgh10-node10.bin", sgh10::TABLE, Some(10), Some(1_000_010)),
        ("sgh50-node20.bin", sgh50::TABLE, Some(20), Some(1_000_020)),
        ("sgh50-node21.bin", sgh50::TABLE, Some(21), Some(1_000_021)),
        ("wv5800m-node30.bin", wv, Some(30), Some(1_000_030)),
        ("ap10t-node40.bin", ap10t::table::TABLE, Some(40), None),
        ("wv58mr-serial1000050.bin", mr, None, Some(1_000_050)),
        ("wv58mr-serial1000051.bin", mr, None, Some(1_000_051)),
    ]
}

fn dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../renode/images")
}

#[test]
fn checked_in_images_are_current() {
    let update = std::env::var_os("UPDATE_RENODE").is_some();
    for (file, table, node, serial) in images() {
        let pages = factory_pages(table, node, serial).unwrap();
        assert_eq!(pages.len(), 4096, "the four pages memory.x reserves");
        let path = dir().join(file);
        if update {
            std::fs::write(&path, &pages).unwrap();
        }
        let stored = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert!(stored == pages, "{file} is stale: UPDATE_RENODE=1 cargo test -p tests-host --test renode_images");
    }
}

#[test]
fn images_hold_node_id_and_serial() {
    for (file, table, node, serial) in images() {
        let pages = std::fs::read(dir().join(file)).unwrap();
        let mut p = ParamFlash::new(RamFlash::from_bytes(pages), REGION, identity(table));
        let Loaded::Image(image) = p.load() else { panic!("{file}: no valid image") };
        assert_eq!(image.get(0x5F0A, 1).map(|r| r.value), node.map(u32::from), "{file}");
        assert_eq!(image.get(0x1018, 4).map(|r| r.value), serial, "{file}");
    }
}

/// The one-bus bench loads each image at the parameter pages (every other file and peripheral
/// the Renode files name: `renode_files.rs`).
#[test]
fn bus_loads_every_image_at_the_parameter_pages() {
    let bus = std::fs::read_to_string(dir().join("../bus.resc")).unwrap();
    for (file, ..) in images() {
        assert!(bus.contains(&format!("$ORIGIN/images/{file} 0x0801F000")), "{file} is loaded at the parameter pages");
    }
}
