//! The parameter image on a flash that loses power: for every erase and every half-word write
//! of a save, a cut there (clean or torn) leaves the complete old or the complete new image.

use embedded_storage::nor_flash::NorFlash;
use od_core::devices::sgh10;
use od_core::od::GroupMask;
use od_core::storage::{identity, merge, Image, Loaded, ParamFlash, Record, Region, SaveError};
use od_core::{Bitrate, Node};
use proptest::prelude::*;
use tests_host::flash::{FlashError, RamFlash, PAGE};
use tests_host::TableOnly;

const PAGES: u32 = 3;
/// The ring sits behind one unrelated page, as in the firmware's flash.
const REGION: Region = Region { offset: PAGE as u32, pages: PAGES };

fn params(flash: RamFlash) -> ParamFlash<RamFlash> {
    ParamFlash::new(flash, REGION, identity(sgh10::TABLE))
}

fn blank() -> ParamFlash<RamFlash> {
    params(RamFlash::new(1 + PAGES as usize))
}

type Values = Vec<(u16, u8, u32)>;

/// A node with these values set in RAM.
fn node(values: &[(u16, u8, u32)]) -> Node<TableOnly> {
    let mut node = Node::new(TableOnly(sgh10::TABLE), 1, Bitrate::K500);
    for &(i, s, v) in values {
        assert!(node.split().1.od.set_value(i, s, v), "{i:04X}.{s}");
    }
    node
}

/// Saves `values` (all groups) and returns the image the flash then holds.
fn save(p: &mut ParamFlash<RamFlash>, values: &[(u16, u8, u32)]) -> Image {
    p.save(node(values).core(), GroupMask::ALL).unwrap();
    match p.load() {
        Loaded::Image(i) => i,
        other => panic!("after a save: {other:?}"),
    }
}

/// A distinct, valid set of values for each `n`.
fn values(n: u32) -> Values {
    vec![(0x1017, 0, 100 + n), (0x6002, 0, 5000 + n), (0x5F0A, 1, 1 + n % 127), (0x6401, 1, n % 30000)]
}

const TORN: [Option<u16>; 6] = [None, Some(0xFFFF), Some(0x00FF), Some(0xFF00), Some(0x5A5A), Some(0x0001)];

/// Cuts the power at operation `k` of a save of `new` over what `p` holds, and checks what the
/// next power-on finds: `old`, or the new image (only if the cut hit the very last write and
/// tore it into its final value). Then the same save must succeed.
fn cut_and_check(p: &ParamFlash<RamFlash>, old: &Loaded, new: &[(u16, u8, u32)], k: u64, torn: Option<u16>) {
    let mut probe = p.clone();
    let new_image = save(&mut probe, new);
    let ops = probe.flash().ops() - p.clone().flash().ops();

    let mut q = p.clone();
    q.flash().cut_after(k, torn);
    let r = q.save(node(new).core(), GroupMask::ALL);
    if k >= ops {
        assert_eq!(r, Ok(()));
        return;
    }
    assert_eq!(r, Err(SaveError::Flash(FlashError::PowerLost)), "cut at {k}");
    q.flash().power_on();
    let ops_before_load = q.flash().ops();
    let after = q.load();
    assert_eq!(q.flash().ops(), ops_before_load, "power-on never writes");
    if torn.is_none() || k + 1 < ops {
        assert_eq!(after, *old, "cut at op {k}/{ops} torn {torn:?}");
    } else {
        assert!(after == *old || after == Loaded::Image(new_image.clone()), "cut at op {k}/{ops}: {after:?}");
    }
    assert_eq!(save(&mut q, new), new_image, "the save works after the cut");
}

/// Every operation of a save of `new`, every torn variant.
fn sweep(p: &ParamFlash<RamFlash>, new: &[(u16, u8, u32)]) -> u64 {
    let old = p.clone().load();
    let mut probe = p.clone();
    let start = probe.flash().ops();
    save(&mut probe, new);
    let ops = probe.flash().ops() - start;
    for k in 0..ops {
        for torn in TORN {
            cut_and_check(p, &old, new, k, torn);
        }
    }
    ops
}

#[test]
fn first_save_on_blank_flash_survives_every_cut() {
    let ops = sweep(&blank(), &values(1));
    // 1 erase, 4 records of 4 half-words, a 12-half-word header, a 4-half-word marker.
    assert_eq!(ops, 1 + 4 * 4 + 12 + 4);
}

#[test]
fn saves_around_the_ring_survive_every_cut() {
    let mut p = blank();
    for n in 0..(2 * PAGES + 1) {
        sweep(&p, &values(n + 10));
        save(&mut p, &values(n));
    }
}

/// Page erases so far, over the whole flash.
fn erases(p: &mut ParamFlash<RamFlash>) -> u32 {
    (0..=PAGES as usize).map(|page| p.flash().erase_count(page)).sum()
}

/// Saves distinct values until the next save of `next` would start a new page.
fn fill_page(p: &mut ParamFlash<RamFlash>, next: &[(u16, u8, u32)]) {
    for n in 0.. {
        let mut probe = p.clone();
        let before = erases(&mut probe);
        save(&mut probe, next);
        if erases(&mut probe) > before {
            return;
        }
        save(p, &values(n + 1000));
    }
}

#[test]
fn the_newest_image_wins_and_wear_is_spread() {
    let mut p = blank();
    let mut programmed = 0;
    for n in 0..300 {
        let ops = p.flash().ops();
        let before = erases(&mut p);
        let image = save(&mut p, &values(n));
        assert_eq!(image.get(0x6002, 0).map(|r| r.value), Some(5000 + n));
        programmed += (p.flash().ops() - ops) - u64::from(erases(&mut p) - before);
    }
    // Four changed records and a commit unit per save: 40 bytes, 24 saves after the page's own
    // image (the save that started it, 64 bytes) fill the page. A page is erased only when the
    // one before is full.
    let per_page: Vec<u32> = (1..=PAGES as usize).map(|page| p.flash().erase_count(page)).collect();
    let total: u32 = per_page.iter().sum();
    assert_eq!(total, 300u32.div_ceil(25), "{per_page:?}");
    assert!(per_page.iter().all(|&e| e + 1 >= total / PAGES), "wear spread over the ring: {per_page:?}");
    assert!(u64::from(total) * PAGE as u64 <= programmed * 2 * 105 / 100, "{total} erases for {programmed} half-words");
    assert_eq!(p.flash().erase_count(0), 0, "outside the region");
    assert!(p.flash().bytes()[..PAGE].iter().all(|&b| b == 0xFF));
}

#[test]
fn a_save_that_changes_nothing_writes_nothing() {
    let mut p = blank();
    let image = save(&mut p, &values(1));
    let ops = p.flash().ops();
    assert_eq!(save(&mut p, &values(1)), image);
    assert_eq!(p.flash().ops(), ops);
    // Not even on a flash with nothing valid: there the save writes the (empty) image, so that
    // the flash is valid again.
    let mut zero = params(RamFlash::from_bytes(vec![0; (1 + PAGES as usize) * PAGE]));
    assert_eq!(zero.load(), Loaded::Invalid);
    assert_eq!(save(&mut zero, &[]), Image::new());
}

#[test]
fn an_interrupted_save_is_retried_on_the_next_page() {
    let mut p = blank();
    save(&mut p, &values(1));
    // Op 5 is in the entry's first record: the page's log now ends in an unfinished entry.
    p.flash().cut_after(5, None);
    assert!(p.save(node(&values(2)).core(), GroupMask::ALL).is_err());
    p.flash().power_on();
    assert_eq!(save(&mut p, &values(3)), save(&mut blank(), &values(3)));
    assert_eq!((p.flash().erase_count(1), p.flash().erase_count(2)), (1, 1), "the retry starts page 2");
    // A cut in the erase of the next page: the retry erases it again.
    fill_page(&mut p, &values(4));
    p.flash().cut_after(0, Some(100));
    assert!(p.save(node(&values(4)).core(), GroupMask::ALL).is_err());
    p.flash().power_on();
    save(&mut p, &values(4));
    // (The flash counts only completed erases.)
    assert_eq!(p.flash().erase_count(3), 1, "page 3 erased by the retry");
    assert_eq!(p.load(), Loaded::Image(save(&mut blank(), &values(4))));
}

#[test]
fn a_page_not_erased_after_its_log_is_not_written_again() {
    let mut p = blank();
    let first = save(&mut blank(), &values(1));
    save(&mut p, &values(1));
    // Something programmed far behind the end of the log (not by us): the log still ends at
    // the first erased unit, but the next save goes to a new page instead of failing there.
    p.flash().bytes_mut()[2 * PAGE - 2] = 0x12;
    assert_eq!(p.load(), Loaded::Image(first));
    assert_eq!(save(&mut p, &values(2)), save(&mut blank(), &values(2)));
    assert_eq!(p.flash().erase_count(2), 1);
}

#[test]
fn an_entry_that_cannot_be_applied_whole_is_no_image_rather_than_half_of_one() {
    use od_core::storage::image::{log_commit, log_crc, MAX_RECORDS};
    let mut p = blank();
    let mut full = Image::new();
    for i in 0..MAX_RECORDS as u16 {
        full.set(Record { index: 0x2000 + i, sub: 0, size: 4, value: i as u32 }).unwrap();
    }
    p.write(&full).unwrap();
    // An entry (not one of ours) that checks: a 97th record, then the removal of the first.
    let at = PAGE + 32 + 8 * MAX_RECORDS;
    let (add, remove) = (Record { index: 0x3000, sub: 0, size: 4, value: 1 }, Record::removal(0x2000, 0));
    let mut crc = log_crc(1);
    crc.update(&add.encode());
    crc.update(&remove.encode());
    let bytes = p.flash().bytes_mut();
    bytes[at..at + 8].copy_from_slice(&add.encode());
    bytes[at + 8..at + 16].copy_from_slice(&remove.encode());
    bytes[at + 16..at + 24].copy_from_slice(&log_commit(2, crc));
    // Removals are applied first, so it fits.
    let Loaded::Image(i) = p.load() else { panic!("no image") };
    assert_eq!((i.len(), i.get(0x3000, 0).is_some(), i.get(0x2000, 0).is_none()), (MAX_RECORDS, true, true));
    // Without the removal it cannot.
    let mut crc = log_crc(1);
    crc.update(&add.encode());
    let bytes = p.flash().bytes_mut();
    bytes[at + 8..at + 24].fill(0xFF);
    bytes[at + 8..at + 16].copy_from_slice(&log_commit(1, crc));
    assert_eq!(p.load(), Loaded::Invalid);
    // A save goes after that page, so that it is the newest.
    assert_eq!(save(&mut p, &values(1)), save(&mut blank(), &values(1)));
    assert_eq!(p.flash().erase_count(2), 1);
}

#[test]
fn a_save_that_changes_more_than_an_entry_holds_starts_a_new_page() {
    // 40 records of entries the dictionary does not declare: the next save drops them all,
    // more records than one log entry holds (32).
    let mut p = blank();
    let mut foreign = Image::new();
    for i in 0..40 {
        foreign.set(Record { index: 0x2100 + i, sub: 0, size: 4, value: 1 }).unwrap();
    }
    p.write(&foreign).unwrap();
    assert_eq!(save(&mut p, &values(1)), save(&mut blank(), &values(1)));
    assert_eq!((p.flash().erase_count(1), p.flash().erase_count(2)), (1, 1));
    // 20 (and the four values): one entry on the same page.
    let mut p = blank();
    let mut few = Image::new();
    for r in &foreign.records()[..20] {
        few.set(*r).unwrap();
    }
    p.write(&few).unwrap();
    assert_eq!(save(&mut p, &values(1)), save(&mut blank(), &values(1)));
    assert_eq!(p.flash().erase_count(2), 0);
}

#[test]
fn a_worn_flash_fails_the_save_and_keeps_the_old_image() {
    let mut p = blank();
    let old = save(&mut p, &values(1));
    p.flash().set_worn(true);
    assert_eq!(p.save(node(&values(2)).core(), GroupMask::ALL), Err(SaveError::Flash(FlashError::Worn)));
    p.flash().set_worn(false);
    assert_eq!(p.load(), Loaded::Image(old));
}

#[test]
fn blank_zeroed_corrupt_and_foreign_flash() {
    assert_eq!(blank().load(), Loaded::Blank);

    let mut zero = params(RamFlash::from_bytes(vec![0; (1 + PAGES as usize) * PAGE]));
    assert_eq!(zero.load(), Loaded::Invalid);

    let mut garbage = blank();
    garbage.flash().bytes_mut()[2 * PAGE..3 * PAGE].fill(0x42);
    assert_eq!(garbage.load(), Loaded::Invalid);

    // A valid image with one flipped bit in a record: refused.
    let mut p = blank();
    save(&mut p, &values(1));
    p.flash().bytes_mut()[PAGE + 40] ^= 0x04;
    assert_eq!(p.load(), Loaded::Invalid);

    // An image of another device.
    let mut other = ParamFlash::new(RamFlash::new(1 + PAGES as usize), REGION, identity(sgh10::TABLE) ^ 1);
    other.save(node(&values(1)).core(), GroupMask::ALL).unwrap();
    assert_eq!(params(other.flash().clone()).load(), Loaded::Invalid);

    // A flash that cannot be read is no image either.
    let mut dead = blank();
    dead.flash().cut_after(0, None);
    let _ = dead.flash().erase(0, PAGE as u32);
    assert_eq!(dead.load(), Loaded::Invalid);

    // Garbage outside the region does not matter.
    let mut outside = blank();
    outside.flash().bytes_mut()[..PAGE].fill(0);
    assert_eq!(outside.load(), Loaded::Blank);
}

#[test]
fn a_corrupt_newest_image_falls_back_to_the_one_before() {
    // Two pages each with its own image: the newer one corrupt.
    let mut p = blank();
    let first = save(&mut blank(), &values(1));
    p.write(&first).unwrap();
    p.write(&save(&mut blank(), &values(2))).unwrap();
    p.flash().bytes_mut()[2 * PAGE + 33] ^= 0x80; // page 2 holds the second image
    assert_eq!(p.load(), Loaded::Image(first.clone()));
    // One page with a log: its newest entry corrupt.
    let mut p = blank();
    save(&mut p, &values(1));
    save(&mut p, &values(2));
    p.flash().bytes_mut()[PAGE + 32 + 4 * 8 + 1] ^= 0x80; // the first record of the entry
    assert_eq!(p.load(), Loaded::Image(first));
}

#[test]
fn region_misuse_is_an_error_not_a_panic() {
    let mut one = ParamFlash::new(RamFlash::new(2), Region { offset: 0, pages: 1 }, 1);
    assert_eq!(one.save(node(&[]).core(), GroupMask::ALL), Err(SaveError::Region));
    let mut odd = ParamFlash::new(RamFlash::new(3), Region { offset: 10, pages: 2 }, 1);
    assert_eq!(odd.save(node(&[]).core(), GroupMask::ALL), Err(SaveError::Region));
}

/// Two pages as the firmware before the log (format version 1, commit c6e6f60) left them on an
/// SGH10 after two saves: 1017h = 100, 1018h.04 = 12345678h, 5F0Ah.01 = 5, 6000h = 0Ch, then
/// 1017h = 250 and 6002h = 5000. Captured from that firmware's `ParamFlash::save`.
const V1_PAGE_0: [u8; 64] = [
    0xA5, 0x5A, 0xC3, 0x3C, 0x50, 0x41, 0x52, 0x4D, 0x53, 0x4B, 0x50, 0x49, 0x01, 0x00, 0x04, 0x00, 0x90, 0xFD, 0x2A,
    0x45, 0x01, 0x00, 0x00, 0x00, 0xFF, 0xFF, 0xFF, 0xFF, 0x4E, 0x26, 0x43, 0x9D, 0x17, 0x10, 0x00, 0x02, 0x64, 0x00,
    0x00, 0x00, 0x18, 0x10, 0x04, 0x04, 0x78, 0x56, 0x34, 0x12, 0x0A, 0x5F, 0x01, 0x01, 0x05, 0x00, 0x00, 0x00, 0x00,
    0x60, 0x00, 0x02, 0x0C, 0x00, 0x00, 0x00,
];
const V1_PAGE_1: [u8; 72] = [
    0xA5, 0x5A, 0xC3, 0x3C, 0x50, 0x41, 0x52, 0x4D, 0x53, 0x4B, 0x50, 0x49, 0x01, 0x00, 0x05, 0x00, 0x90, 0xFD, 0x2A,
    0x45, 0x02, 0x00, 0x00, 0x00, 0xFF, 0xFF, 0xFF, 0xFF, 0x6E, 0x45, 0x05, 0x27, 0x17, 0x10, 0x00, 0x02, 0xFA, 0x00,
    0x00, 0x00, 0x18, 0x10, 0x04, 0x04, 0x78, 0x56, 0x34, 0x12, 0x0A, 0x5F, 0x01, 0x01, 0x05, 0x00, 0x00, 0x00, 0x00,
    0x60, 0x00, 0x02, 0x0C, 0x00, 0x00, 0x00, 0x02, 0x60, 0x00, 0x04, 0x88, 0x13, 0x00, 0x00,
];

/// The ring as a board in the field holds it: the two version-1 pages and one blank.
fn version_1_flash() -> ParamFlash<RamFlash> {
    let mut bytes = vec![0xFF; (1 + PAGES as usize) * PAGE];
    bytes[PAGE..PAGE + 64].copy_from_slice(&V1_PAGE_0);
    bytes[2 * PAGE..2 * PAGE + 72].copy_from_slice(&V1_PAGE_1);
    params(RamFlash::from_bytes(bytes))
}

#[test]
fn an_image_of_the_format_before_the_log_still_loads() {
    let mut p = version_1_flash();
    let rec = |index, sub, size, value| Record { index, sub, size, value };
    let expected: Image = {
        let mut i = Image::new();
        for r in [rec(0x1017, 0, 2, 250), rec(0x1018, 4, 4, 0x1234_5678), rec(0x5F0A, 1, 1, 5), rec(0x6000, 0, 2, 0x0C)]
            .into_iter()
            .chain([rec(0x6002, 0, 4, 5000)])
        {
            i.set(r).unwrap();
        }
        i
    };
    assert_eq!(p.load(), Loaded::Image(expected.clone()));
    // The node boots from it.
    let node = Node::boot(TableOnly(sgh10::TABLE), &p.load());
    assert_eq!((node.core().node_id, node.core().od.value(0x6002, 0)), (5, Some(5000)));
    // A save that changes nothing leaves it as it is; the first that changes something starts
    // a page of the current format (version 1 pages take no log), and the factory record stays.
    let mut same = p.clone();
    let ops = same.flash().ops();
    same.save(node.core(), GroupMask::ALL).unwrap();
    assert_eq!(same.flash().ops(), ops);
    let mut node = node;
    node.split().1.od.set_value(0x1017, 0, 300);
    p.save(node.core(), GroupMask::ALL).unwrap();
    assert_eq!(p.flash().erase_count(3), 1);
    assert_eq!(&p.flash().bytes()[2 * PAGE..2 * PAGE + 72], &V1_PAGE_1, "the old page is not touched");
    let mut now = expected;
    now.set(rec(0x1017, 0, 2, 300)).unwrap();
    assert_eq!(params(p.flash().clone()).load(), Loaded::Image(now));
}

#[test]
fn the_first_save_after_a_version_1_image_survives_every_cut() {
    // 1 erase, 5 records, the header and the marker: the whole image on a new page.
    let ops = sweep(&version_1_flash(), &values(1));
    assert_eq!(ops, 1 + 5 * 4 + 12 + 4);
}

#[test]
fn a_save_that_starts_a_new_page_survives_every_cut() {
    let mut p = blank();
    fill_page(&mut p, &values(1));
    let ops = sweep(&p, &values(1));
    assert_eq!(ops, 1 + 4 * 4 + 12 + 4);
    // Going round the ring: the page it erases held an older image.
    for n in 0..2 * PAGES {
        fill_page(&mut p, &values(n));
        sweep(&p, &values(n));
        save(&mut p, &values(n));
    }
}

#[test]
fn a_log_entry_with_removals_survives_every_cut() {
    let mut p = blank();
    save(&mut p, &values(1));
    // 1017h and 6401h.01 back at their defaults: two removals, one changed record.
    let ops = sweep(&p, &[(0x1017, 0, 0), (0x6002, 0, 7000), (0x5F0A, 1, 2), (0x6401, 1, -20478i32 as u32)]);
    assert_eq!(ops, 3 * 4 + 4);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// Random values, a random history of saves, a random cut point and tear.
    #[test]
    fn random_values_random_cuts(
        history in proptest::collection::vec((any::<u16>(), any::<u32>(), 1u8..=127, -20478i32..=30717), 0..7),
        new in (any::<u16>(), any::<u32>(), 1u8..=127, -20478i32..=30717),
        k in 0u64..40,
        torn in proptest::option::of(any::<u16>()),
    ) {
        let as_values = |(a, b, c, d): (u16, u32, u8, i32)| -> Values {
            vec![(0x1017, 0, a as u32), (0x6002, 0, b), (0x5F0A, 1, c as u32), (0x6401, 1, d as u32)]
        };
        let mut p = blank();
        for h in &history {
            save(&mut p, &as_values(*h));
        }
        let old = p.clone().load();
        cut_and_check(&p, &old, &as_values(new), k, torn);
    }

    /// Long random histories of saves of any group, values often back at their defaults:
    /// after each, a power-on (the ring read afresh) finds exactly the merged image.
    #[test]
    fn what_a_power_on_finds_is_what_was_saved(
        history in proptest::collection::vec(
            (0usize..4, prop_oneof![Just(0u16), any::<u16>()], prop_oneof![Just(10239u32), any::<u32>()], 1u8..=127),
            1..120,
        ),
    ) {
        let mut p = blank();
        let mut expected = Image::new();
        for (sub, heartbeat, resolution, id) in history {
            let mask = GroupMask::from_subindex(sub as u8 + 1).unwrap();
            let node = node(&[(0x1017, 0, heartbeat as u32), (0x6002, 0, resolution), (0x5F0A, 1, id as u32)]);
            p.save(node.core(), mask).unwrap();
            merge(&mut expected, &node.core().od, 1, mask).unwrap();
            prop_assert_eq!(params(p.flash().clone()).load(), Loaded::Image(expected.clone()));
        }
    }
}
