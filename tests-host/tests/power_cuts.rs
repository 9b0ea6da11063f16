//! Power cuts on every path that writes the parameter flash, on every device kind: 1010h sub 1
//! to 4 (each group), LSS store configuration, and a save of the 1003h error history. The save
//! the node asks for ([`Output::Store`]) is carried out on a [`RamFlash`] that loses power at
//! each erase and half-word write in turn, and for each cut point in several ways: the
//! operation not done, torn (some bits programmed, part of the page erased), or leaving cells
//! that read back as any value (a half-written word, an interrupted page erase). After every cut
//! the next power-on must find exactly the old or exactly the new parameters, the new ones only
//! if the cut came after the last write of the commit marker began, and the save must work
//! again afterwards. The number of cut points per path is printed (`--nocapture`) and checked.

use od_core::node::{BusEvent, Output};
use od_core::od::{Group, GroupMask};
use od_core::storage::crc::Crc32;
use od_core::storage::{identity, Loaded, ParamFlash};
use od_core::{Frame, Instant};
use tests_host::encoder::download_request;
use tests_host::flash::{FlashError, RamFlash, PAGE};
use tests_host::invariants::{Kind, Subject, ENCODERS, REGION};

/// How a cut leaves the operation it interrupts.
#[derive(Clone, Copy, Debug)]
enum Tear {
    /// Not done at all.
    Clean,
    /// Torn: a write programs the bits outside the mask, an erase erases part of the page.
    Torn(u16),
    /// The touched cells read back as any value (derived from this one).
    Garbage(u16),
}

const TEARS: [Tear; 9] = [
    Tear::Clean,
    Tear::Torn(0xFFFF),
    Tear::Torn(0x00FF),
    Tear::Torn(0xFF00),
    Tear::Torn(0x5A5A),
    Tear::Garbage(0x0000),
    Tear::Garbage(0xFFFF),
    Tear::Garbage(0x3CA5),
    Tear::Garbage(0x5AC3),
];

type Snapshot = Vec<(u16, u8, u32)>;

thread_local! {
    /// Cut points after which the flash read as corrupt (reported by EMCY 6300h).
    static CORRUPT: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
}

/// The stored parameters of a node booted from `loaded`.
fn snapshot(kind: Kind, loaded: &Loaded) -> Snapshot {
    let node = kind.boot(loaded);
    let od = &node.core().od;
    od.table()
        .iter()
        .enumerate()
        .filter(|(_, e)| e.group != Group::None)
        .map(|(pos, e)| (e.index, e.sub, od.get(pos)))
        .collect()
}

/// Feeds `frame` and returns what the node asked for.
fn feed(node: &mut dyn Subject, frame: Frame) -> (Vec<Frame>, Vec<GroupMask>) {
    node.on_frame(&frame, Instant::from_millis(1));
    drain(node)
}

fn drain(node: &mut dyn Subject) -> (Vec<Frame>, Vec<GroupMask>) {
    let (mut frames, mut stores) = (Vec::new(), Vec::new());
    while let Some(o) = node.next_output() {
        match o {
            Output::Frame(f) => frames.push(f),
            Output::Store(m) => stores.push(m),
            Output::SetBitrate(_) => {}
        }
    }
    (frames, stores)
}

/// A store path: what changes before the save, and the request that asks for it.
#[derive(Clone, Copy, Debug)]
enum Path {
    /// 1010h sub 1..4.
    Save(u8),
    /// LSS configure node-ID and bit timing, then store configuration.
    Lss,
    /// EMCYs in the 1003h history, then 1010h sub 2 (the history is in the comm group).
    History,
}

impl Path {
    fn name(self) -> String {
        match self {
            Path::Save(s) => format!("1010h.{s:02}"),
            Path::Lss => "LSS store configuration".into(),
            Path::History => "1003h history (1010h.02)".into(),
        }
    }
}

const PATHS: [Path; 6] = [Path::Save(1), Path::Save(2), Path::Save(3), Path::Save(4), Path::Lss, Path::History];

/// Changes parameters of every group (by SDO, LSS or EMCYs, as `path` does) on a node booted
/// from `flash`, asks for the save and returns the node (to save from) and the store's mask.
fn prepare(kind: Kind, flash: &mut ParamFlash<RamFlash>, path: Path, n: u32) -> (Box<dyn Subject>, GroupMask) {
    let mut node = kind.boot(&flash.load());
    node.poll(Instant::ZERO);
    drain(node.as_mut());
    let id = node.core().node_id as u16;
    let sdo = |node: &mut Box<dyn Subject>, index: u16, sub: u8, size: usize, value: u32| {
        feed(node.as_mut(), Frame::std(0x600 + id, &download_request(index, sub, size, value)))
    };
    let save = |node: &mut Box<dyn Subject>, sub: u8| {
        let (_, stores) = sdo(node, 0x1010, sub, 4, u32::from_le_bytes(*b"save"));
        assert_eq!(stores.len(), 1, "{kind:?} 1010h.{sub}: no store");
        stores[0]
    };
    let mask = match path {
        Path::Save(sub) => {
            // One value in each group: heartbeat (comm), cyclic timer (app), pending node-ID
            // (manufacturer).
            sdo(&mut node, 0x1017, 0, 2, 100 + n);
            sdo(&mut node, 0x6200, 0, 2, 10 + n);
            sdo(&mut node, 0x5F0A, 1, 1, 40 + n % 50);
            save(&mut node, sub)
        }
        Path::History => {
            for e in [BusEvent::ErrorPassive, BusEvent::BusOff, BusEvent::BusOffRecovered] {
                node.on_bus_event(e, Instant::from_millis(2));
            }
            node.poll(Instant::from_millis(3));
            drain(node.as_mut());
            sdo(&mut node, 0x1017, 0, 2, 300 + n);
            assert_ne!(node.core().od.value(0x1003, 1), Some(0), "{kind:?}: no history");
            save(&mut node, 2)
        }
        Path::Lss => {
            feed(node.as_mut(), Frame::std(0x7E5, &[0x04, 1, 0, 0, 0, 0, 0, 0]));
            feed(node.as_mut(), Frame::std(0x7E5, &[0x11, 60 + (n % 60) as u8, 0, 0, 0, 0, 0, 0]));
            feed(node.as_mut(), Frame::std(0x7E5, &[0x13, 0, (n % 3) as u8 + 2, 0, 0, 0, 0, 0]));
            let (_, stores) = feed(node.as_mut(), Frame::std(0x7E5, &[0x17, 0, 0, 0, 0, 0, 0, 0]));
            assert_eq!(stores, [GroupMask::LSS], "{kind:?}: LSS store");
            GroupMask::LSS
        }
    };
    (node, mask)
}

/// Sweeps every cut point of one save; returns the number of cut points tried.
fn sweep(kind: Kind, flash: &ParamFlash<RamFlash>, path: Path, n: u32) -> u64 {
    let old_loaded = flash.clone().load();
    let old = snapshot(kind, &old_loaded);
    let mut scratch = flash.clone();
    let (node, mask) = prepare(kind, &mut scratch, path, n);
    let mut probe = flash.clone();
    let start = probe.flash().ops();
    probe.save(node.core(), mask).expect("save without a cut");
    let ops = probe.flash().ops() - start;
    let new = snapshot(kind, &probe.load());
    assert_ne!(old, new, "{kind:?} {}: the save changes nothing", path.name());
    let mut tried = 0;
    for k in 0..ops {
        for tear in TEARS {
            let mut q = flash.clone();
            match tear {
                Tear::Clean => q.flash().cut_after(k, None),
                Tear::Torn(m) => q.flash().cut_after(k, Some(m)),
                Tear::Garbage(v) => q.flash().cut_garbage(k, v),
            }
            let r = q.save(node.core(), mask);
            assert!(
                matches!(r, Err(od_core::storage::SaveError::Flash(FlashError::PowerLost))),
                "{kind:?} {} cut at {k}/{ops}: {r:?}",
                path.name()
            );
            q.flash().power_on();
            let loaded = q.load();
            let after = snapshot(kind, &loaded);
            let what = format!("{kind:?} {} cut at op {k}/{ops} {tear:?}: {loaded:?}", path.name());
            if after != old {
                assert_eq!(after, new, "{what}: neither old nor new");
                // Four half-words make the commit marker, written last.
                assert!(k + 4 >= ops, "{what}: new parameters before the commit marker");
            }
            // A blank flash cut in its first save may read as corrupt (garbage where the
            // marker goes): defaults either way, reported by EMCY 6300h.
            if loaded == Loaded::Invalid {
                assert_eq!(old_loaded, Loaded::Blank, "{what}");
                let mut node = kind.boot(&loaded);
                node.poll(Instant::ZERO);
                let (frames, _) = drain(node.as_mut());
                assert!(
                    frames.iter().any(|f| f.id.raw() & 0x780 == 0x80 && f.payload()[..2] == [0x00, 0x63]),
                    "{what}: no EMCY 6300h after the boot-up: {frames:02X?}"
                );
                CORRUPT.with(|c| c.set(c.get() + 1));
            }
            q.save(node.core(), mask).expect("the save works after the cut");
            assert_eq!(snapshot(kind, &q.load()), new, "{what}: the retried save");
            tried += 1;
        }
    }
    tried
}

#[test]
fn every_store_path_survives_a_cut_at_every_operation() {
    let mut report = Vec::new();
    for path in PATHS {
        let mut total = 0;
        for &kind in ENCODERS {
            let mut flash = ParamFlash::new(RamFlash::new(REGION.pages as usize), REGION, identity(kind.table()));
            // From a blank flash and then around the ring: each save lands on the next page.
            for n in 0..=REGION.pages {
                total += sweep(kind, &flash, path, n);
                let (node, mask) = prepare(kind, &mut flash.clone(), Path::Save(1), n + 7);
                flash.save(node.core(), mask).unwrap();
            }
        }
        report.push((path.name(), total, CORRUPT.with(|c| c.replace(0))));
    }
    for (name, total, corrupt) in &report {
        eprintln!("{name}: {total} cut points ({corrupt} read as corrupt, reported by EMCY 6300h)");
        assert!(*total > 1000, "{name}: only {total} cut points");
    }
}

/// Page erases so far.
fn erases(flash: &RamFlash) -> u32 {
    (0..flash.bytes().len() / PAGE).map(|p| flash.erase_count(p)).sum()
}

/// Rewrites the image that starts page `page` (a page with no log) as the format before the
/// log wrote it: version 1, its CRC recomputed.
fn as_version_1(flash: &mut RamFlash, page: usize) {
    let b = &mut flash.bytes_mut()[page * PAGE..(page + 1) * PAGE];
    b[12..14].copy_from_slice(&1u16.to_le_bytes());
    let records = u16::from_le_bytes([b[14], b[15]]) as usize;
    let mut crc = Crc32::new();
    crc.update(&b[8..28]);
    crc.update(&b[32..32 + 8 * records]);
    b[28..32].copy_from_slice(&crc.finish().to_le_bytes());
}

/// The paths a save takes since the log: the save that starts the next page because the
/// newest one is full, and the first save after a page of the format before the log (which
/// takes no log). The same sweep as above, from those two starting points.
#[test]
fn every_store_path_survives_a_cut_where_a_page_is_full_or_of_the_old_format() {
    let mut report = Vec::new();
    for path in PATHS {
        let mut total = 0;
        for &kind in ENCODERS {
            let blank = ParamFlash::new(RamFlash::new(REGION.pages as usize), REGION, identity(kind.table()));
            // Saves until the next one of this path would start a new page.
            let mut flash = blank.clone();
            for n in 0.. {
                let mut probe = flash.clone();
                let (node, mask) = prepare(kind, &mut probe.clone(), path, n);
                let before = erases(probe.flash());
                probe.save(node.core(), mask).unwrap();
                if n > 0 && erases(probe.flash()) > before {
                    total += sweep(kind, &flash, path, n);
                    break;
                }
                assert!(n < 200, "{kind:?} {}: no page filled", path.name());
                let (node, mask) = prepare(kind, &mut flash.clone(), Path::Save(1), n + 7);
                flash.save(node.core(), mask).unwrap();
            }
            // A version-1 page, as a board in the field holds it.
            let mut flash = blank.clone();
            let (node, mask) = prepare(kind, &mut flash.clone(), Path::Save(1), 3);
            flash.save(node.core(), mask).unwrap();
            let mut old = flash.into_inner();
            as_version_1(&mut old, 0);
            let flash = ParamFlash::new(old, REGION, identity(kind.table()));
            assert!(matches!(flash.clone().load(), Loaded::Image(_)), "{kind:?}: the version-1 page loads");
            total += sweep(kind, &flash, path, 5);
        }
        report.push((path.name(), total, CORRUPT.with(|c| c.replace(0))));
    }
    for (name, total, corrupt) in &report {
        eprintln!("{name}, full page or version 1: {total} cut points ({corrupt} read as corrupt)");
        assert!(*total > 1000, "{name}: only {total} cut points");
        assert_eq!(*corrupt, 0, "{name}: the old image is always there");
    }
}
