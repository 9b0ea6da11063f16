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
use od_core::{CanId, Context, Frame, Instant};
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
    let mut scratch = flash.clone();
    let (node, mask) = prepare(kind, &mut scratch, path, n);
    let what = format!("{kind:?} {}", path.name());
    sweep_save(&what, flash, node.core(), mask, &|l| snapshot(kind, l), &|l| reports_corrupt(kind, l))
}

/// Does a CANopen node booted from `loaded` report the corrupt image by EMCY 6300h after its
/// boot-up? (An AP10T detecting the bit rate first hears a frame.)
fn reports_corrupt(kind: Kind, loaded: &Loaded) -> bool {
    let mut node = kind.boot(loaded);
    node.poll(Instant::ZERO);
    if node.listen_only() {
        node.on_frame(&Frame::std(0, &[0x80, 0x7E]), Instant::from_millis(1));
        node.poll(Instant::from_millis(2));
    }
    let (frames, _) = drain(node.as_mut());
    frames.iter().any(|f| f.id.raw() & 0x780 == 0x80 && f.payload()[..2] == [0x00, 0x63])
}

/// Sweeps every cut point of the save of `mask` from `params` over `flash`: after each cut the
/// power-on (`snapshot`) finds the old or the new parameters, a corrupt image is reported
/// (`reports_corrupt`), and the save works again. Returns the number of cut points tried.
fn sweep_save(
    what: &str,
    flash: &ParamFlash<RamFlash>,
    params: &Context,
    mask: GroupMask,
    snapshot: &dyn Fn(&Loaded) -> Snapshot,
    reports_corrupt: &dyn Fn(&Loaded) -> bool,
) -> u64 {
    let old_loaded = flash.clone().load();
    let old = snapshot(&old_loaded);
    let mut probe = flash.clone();
    let start = probe.flash().ops();
    probe.save(params, mask).expect("save without a cut");
    let ops = probe.flash().ops() - start;
    let new = snapshot(&probe.load());
    assert_ne!(old, new, "{what}: the save changes nothing");
    let mut tried = 0;
    for k in 0..ops {
        for tear in TEARS {
            let mut q = flash.clone();
            match tear {
                Tear::Clean => q.flash().cut_after(k, None),
                Tear::Torn(m) => q.flash().cut_after(k, Some(m)),
                Tear::Garbage(v) => q.flash().cut_garbage(k, v),
            }
            let r = q.save(params, mask);
            assert!(
                matches!(r, Err(od_core::storage::SaveError::Flash(FlashError::PowerLost))),
                "{what} cut at {k}/{ops}: {r:?}"
            );
            q.flash().power_on();
            let loaded = q.load();
            let after = snapshot(&loaded);
            let what = format!("{what} cut at op {k}/{ops} {tear:?}: {loaded:?}");
            if after != old {
                assert_eq!(after, new, "{what}: neither old nor new");
                // Four half-words make the commit marker, written last.
                assert!(k + 4 >= ops, "{what}: new parameters before the commit marker");
            }
            // A blank flash cut in its first save may read as corrupt (garbage where the
            // marker goes): defaults either way, reported by EMCY 6300h.
            if loaded == Loaded::Invalid {
                assert_eq!(old_loaded, Loaded::Blank, "{what}");
                assert!(reports_corrupt(&loaded), "{what}: no EMCY 6300h after the boot-up");
                CORRUPT.with(|c| c.set(c.get() + 1));
            }
            q.save(params, mask).expect("the save works after the cut");
            assert_eq!(snapshot(&q.load()), new, "{what}: the retried save");
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

/// The AP10T's own store paths: the Auto-ID key (manual 4.6.2, D-AP-18: the node-ID alone), the
/// key menu's ID (D-AP-9: the node-ID alone) and its CODE 011102 (Table 3, D-AP-16: factory
/// settings but the bus parameters, every group stored at the reset that follows).
#[derive(Clone, Copy, Debug)]
enum PanelPath {
    AutoId,
    MenuId,
    MenuCode,
}

/// The AP10T's keys as its `Subject` takes them (`KeyedAp10t`): front, left, star, up.
const FRONT: u32 = 0;
const LEFT: u32 = 1;
const STAR: u32 = 2;
const UP: u32 = 3;

/// An AP10T booted from `flash`, its bit rate detected and booted up (node 7Dh on a blank
/// flash).
fn ap10t_booted(flash: &mut ParamFlash<RamFlash>) -> Box<dyn Subject> {
    let mut node = Kind::Ap10t.boot(&flash.load());
    node.poll(Instant::ZERO);
    if node.listen_only() {
        node.on_frame(&Frame::std(0, &[0x80, 0x7E]), Instant::from_millis(1));
    }
    node.poll(Instant::from_millis(2));
    drain(node.as_mut());
    node
}

/// Presses and releases `keys` in turn; returns the stores the node asked for.
fn keys(node: &mut dyn Subject, keys: &[u32]) -> Vec<GroupMask> {
    let mut stores = Vec::new();
    for (k, &key) in keys.iter().enumerate() {
        let now = Instant::from_millis(2000 + k as u64);
        node.sample(Ok(key), now);
        node.sample(Ok(key | 4), now);
        node.poll(now);
        stores.extend(drain(node).1);
    }
    stores
}

/// Prepares an AP10T on `flash` for the store of `path`; returns it and the store's mask.
fn ap10t_prepare(flash: &mut ParamFlash<RamFlash>, path: PanelPath, n: u32) -> (Box<dyn Subject>, GroupMask) {
    let mut node = ap10t_booted(flash);
    assert_eq!(node.core().node_id, 0x7D, "the ring keeps the factory node-ID");
    let stores = match path {
        PanelPath::AutoId => {
            let (frames, stores) = feed(node.as_mut(), Frame::std(0x67D, &download_request(0x5F0A, 2, 1, 1 + n % 100)));
            assert!(frames.is_empty() && stores.is_empty(), "the Auto-ID answers at the key: {frames:02X?}");
            keys(node.as_mut(), &[STAR])
        }
        PanelPath::MenuId => {
            // ID 125 -> 7, 8 or 9: units up 2..4 times, tens 2 -> 0, hundreds 1 -> 0.
            let mut k = vec![LEFT, LEFT, STAR];
            k.extend(std::iter::repeat_n(UP, 2 + n as usize % 3));
            k.push(LEFT);
            k.extend(std::iter::repeat_n(UP, 8));
            k.push(LEFT);
            k.extend(std::iter::repeat_n(UP, 9));
            k.extend([STAR, FRONT]);
            keys(node.as_mut(), &k)
        }
        PanelPath::MenuCode => {
            // A bus parameter changed and not saved: CODE 011102 keeps it and stores it.
            feed(node.as_mut(), Frame::std(0x67D, &download_request(0x1017, 0, 2, 1000 + n)));
            let mut k = vec![LEFT, LEFT, UP, UP, STAR];
            for (i, digit) in [2usize, 0, 1, 1, 1, 0].into_iter().enumerate() {
                k.extend(std::iter::repeat_n(UP, digit));
                if i < 5 {
                    k.push(LEFT);
                }
            }
            k.push(STAR);
            keys(node.as_mut(), &k)
        }
    };
    assert_eq!(stores.len(), 1, "{path:?}: stores {stores:?}");
    (node, stores[0])
}

/// Moves the AP10T's ring on by one 1010h.01 save (5F11h changed, the node-ID kept at 7Dh).
fn ap10t_ring_step(flash: &mut ParamFlash<RamFlash>, n: u32) {
    let mut node = ap10t_booted(flash);
    feed(node.as_mut(), Frame::std(0x67D, &download_request(0x5F11, 0, 1, 1 + n % 3)));
    let (_, stores) =
        feed(node.as_mut(), Frame::std(0x67D, &download_request(0x1010, 1, 4, u32::from_le_bytes(*b"save"))));
    flash.save(node.core(), stores[0]).unwrap();
}

#[test]
fn the_ap10t_key_stores_survive_a_cut_at_every_operation() {
    let kind = Kind::Ap10t;
    for path in [PanelPath::AutoId, PanelPath::MenuId, PanelPath::MenuCode] {
        let mut total = 0;
        let mut flash = ParamFlash::new(RamFlash::new(REGION.pages as usize), REGION, identity(kind.table()));
        for n in 0..=REGION.pages {
            let (node, mask) = ap10t_prepare(&mut flash.clone(), path, n);
            let what = format!("AP10T {path:?} (store {mask:?})");
            total +=
                sweep_save(&what, &flash, node.core(), mask, &|l| snapshot(kind, l), &|l| reports_corrupt(kind, l));
            ap10t_ring_step(&mut flash, n);
        }
        let corrupt = CORRUPT.with(|c| c.replace(0));
        eprintln!("AP10T {path:?}: {total} cut points ({corrupt} read as corrupt, reported by EMCY 6300h)");
        // The log-structured store appends a save in a few dozen operations (D-STO-11).
        assert!(total > 300, "{path:?}: only {total} cut points");
    }
}

mod wv58mr {
    use super::*;
    use od_core::devices::wv5800m::Turns;
    use od_core::devices::wv58mr::Wv58mr;
    use od_core::j1939::node::J1939Node;

    type Wv58 = J1939Node<Wv58mr>;

    fn boot(loaded: &Loaded) -> Wv58 {
        J1939Node::boot(Wv58mr::new(Turns::Multi12), loaded)
    }

    /// The stored parameters after power-on (the 1003h log left out: a corrupt image enters
    /// 6300h there at once).
    pub fn snapshot(loaded: &Loaded) -> Snapshot {
        let node = boot(loaded);
        let od = &node.context().od;
        od.table()
            .iter()
            .enumerate()
            .filter(|(_, e)| e.group != Group::None && e.index != 0x1003)
            .map(|(pos, e)| (e.index, e.sub, od.get(pos)))
            .collect()
    }

    /// Runs `node` to `until` ms, polling at its deadlines; returns the frames it sent.
    fn run(node: &mut Wv58, from: u64, until: u64) -> Vec<Frame> {
        let mut frames = Vec::new();
        let mut now = Instant::from_millis(from);
        loop {
            node.poll(now);
            while let Some(o) = node.next_output() {
                if let Output::Frame(f) = o {
                    frames.push(f);
                }
            }
            match node.next_deadline() {
                Some(t) if t <= Instant::from_millis(until) => now = t.max(now),
                _ => return frames,
            }
        }
    }

    /// The WV58MR reports a corrupt image by EMCY 6300h (PGN 64616) once its claim stood.
    pub fn reports_corrupt(loaded: &Loaded) -> bool {
        let mut node = boot(loaded);
        run(&mut node, 0, 500).iter().any(|f| f.id.raw() >> 8 & 0x3FFFF == 0xFC68 && f.payload()[..2] == [0x00, 0x63])
    }

    /// A WV58MR from `flash`, claimed, with parameters of the application and manufacturer
    /// groups changed by CAM21, asked to save 1010h.`sub`; returns it and the store's mask.
    pub fn prepare(flash: &ParamFlash<RamFlash>, sub: u8, n: u32) -> (Wv58, GroupMask) {
        let mut node = boot(&flash.clone().load());
        run(&mut node, 0, 500);
        let sa = node.source_address().expect("claimed").0 as u32;
        let mut stores = Vec::new();
        let mut cam = |node: &mut Wv58, index: u16, s: u8, size: usize, value: u32| {
            let f = Frame::new(CanId::Ext(0x1C06_0000 | sa << 8), &download_request(index, s, size, value));
            node.on_frame(&f, Instant::from_millis(600));
            while let Some(o) = node.next_output() {
                if let Output::Store(m) = o {
                    stores.push(m);
                }
            }
        };
        cam(&mut node, 0x6401, 1, 4, 1000 + 10 * n); // application: work area 1's low limit
        cam(&mut node, 0x3000, 1, 2, 100 + n); // manufacturer: Proprietary B's cycle time
        cam(&mut node, 0x3000, 4, 1, n % 8); // manufacturer: its priority
        cam(&mut node, 0x1010, sub, 4, u32::from_le_bytes(*b"save"));
        assert_eq!(stores.len(), 1, "WV58MR 1010h.{sub}: stores {stores:?}");
        (node, stores[0])
    }
}

#[test]
fn the_wv58mr_save_survives_a_cut_at_every_operation() {
    use od_core::devices::wv5800m::Turns;
    let table = od_core::devices::wv58mr::table_of(Turns::Multi12);
    for sub in [1u8, 3, 4] {
        let mut total = 0;
        let mut flash = ParamFlash::new(RamFlash::new(REGION.pages as usize), REGION, identity(table));
        for n in 0..=REGION.pages {
            let (node, mask) = wv58mr::prepare(&flash, sub, n);
            let what = format!("WV58MR 1010h.{sub:02}");
            total += sweep_save(&what, &flash, node.context(), mask, &wv58mr::snapshot, &wv58mr::reports_corrupt);
            let (node, mask) = wv58mr::prepare(&flash, 1, n + 7);
            flash.save(node.context(), mask).unwrap();
        }
        let corrupt = CORRUPT.with(|c| c.replace(0));
        eprintln!("WV58MR 1010h.{sub:02}: {total} cut points ({corrupt} read as corrupt, reported by EMCY 6300h)");
        // The log-structured store appends a save in a few dozen operations (D-STO-11).
        assert!(total > 300, "1010h.{sub}: only {total} cut points");
    }
}
