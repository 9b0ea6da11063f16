//! The parameter image on flash: a ring of erase pages, each starting with a whole image and
//! followed by a log of the saves made since ([`super::image`] has the layout).
//!
//! A save appends to the newest page's log the records it changes (a removal for a value back
//! at its default), then the entry's commit unit, each read back before the next is written;
//! a save that changes nothing writes nothing. Only the commit unit makes the entry count, so a
//! power cut at any half-word write leaves the entries before it: the old image.
//!
//! When the entry does not fit the rest of the page (or the newest page holds a version-1
//! image, or a log a power cut left unfinished), the save starts the next page of the ring
//! with the whole new image and the next sequence number: erase the page, write the records
//! and the header, read them back, then write the page's commit marker. The page it replaces
//! is not touched, so a power cut at any erase or write leaves either the old image (newest)
//! or the new one. A page is erased only when the one before it is full (or left unusable by a
//! cut), so the pages share the wear and each erase pays for a page of saves.
//!
//! The ring is read once, at power-on ([`ParamFlash::load`], or the first save): the newest
//! page, its image with the log applied, and where the log ends are kept, so a save reads no
//! flash but its own writes. After a failed save the ring is read again at the next one.
//! Nothing is repaired at power-on: an unfinished page or entry simply does not count.
//!
//! Why not `sequential-storage`: its API is async (embedded-storage-async) while the core and
//! its shells call storage synchronously, and its map stores items one by one, whereas a 1010h
//! save must replace a group of values atomically.

use embedded_storage::nor_flash::NorFlash;

use super::image::{self, Image, Record, Slot, COMMIT, COMMIT_SIZE, HEADER_SIZE, RECORD_SIZE, UNIT};
use super::{merge_into, Loaded, Log, Parameters, Storable};
use crate::od::GroupMask;

/// Where the parameter pages are: `pages` erase pages from byte `offset` of the flash the
/// [`ParamFlash`] is given (the firmware's `memory.x` reserves them).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Region {
    /// Offset of the first page, a multiple of the erase size.
    pub offset: u32,
    /// Number of pages, at least 2.
    pub pages: u32,
}

/// Why a save failed. The image that was valid before is still the newest valid one.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum SaveError<E> {
    /// The flash reported an error.
    Flash(E),
    /// The region is unusable: fewer than 2 pages, or not page-aligned, or a flash whose write
    /// or read size does not divide 8.
    Region,
    /// The image does not fit a page.
    TooLarge,
    /// The page did not read back as written.
    Verify,
    /// Sequence numbers exhausted (2^32 pages started: beyond any flash's endurance).
    Exhausted,
}

/// The newest valid page, as read at power-on and kept up to date by every save.
#[derive(Clone, Debug)]
struct Newest {
    /// Its page in the region.
    page: u32,
    /// Its sequence number.
    sequence: u32,
    /// Offset in the page where the next log entry goes; `None` when the page takes no more
    /// entries (a version-1 image, or a log that ends in an unfinished entry).
    end: Option<u32>,
    /// The image it holds, its log applied.
    image: Image,
}

/// What the [`ParamFlash`] knows of its pages.
// Not boxed: no allocation. The image is the point of keeping it.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
enum Known {
    /// Nothing yet, or a save failed: read the ring before the next save.
    Unread,
    /// No valid image (blank, or nothing of ours). With the page holding the highest
    /// sequence number, if one checks but its log cannot be applied: the next page goes after it.
    Nothing(Option<(u32, u32)>),
    /// The newest valid page.
    Newest(Newest),
}

/// The parameter pages of one device.
#[derive(Clone, Debug)]
pub struct ParamFlash<F> {
    flash: F,
    region: Region,
    identity: u32,
    known: Known,
    /// The storable entries of the dictionary saved last.
    storable: Option<Storable>,
}

impl<F: NorFlash> ParamFlash<F> {
    /// The pages in `region` of `flash`, holding images of the device `identity`
    /// ([`super::identity`] of its dictionary).
    pub fn new(flash: F, region: Region, identity: u32) -> ParamFlash<F> {
        ParamFlash { flash, region, identity, known: Known::Unread, storable: None }
    }

    /// The flash. What is written through it behind the [`ParamFlash`]'s back is seen at the
    /// next [`ParamFlash::load`].
    pub fn flash(&mut self) -> &mut F {
        &mut self.flash
    }

    /// Gives the flash back.
    pub fn into_inner(self) -> F {
        self.flash
    }

    fn page(&self, n: u32) -> u32 {
        self.region.offset + n * F::ERASE_SIZE as u32
    }

    /// Checks one page's image; with `out`, also reads its records.
    fn decode(&mut self, n: u32, out: Option<&mut Image>) -> Result<Slot, image::DecodeError> {
        let base = self.page(n);
        let flash = &mut self.flash;
        Image::decode_slot(|at, buf| flash.read(base + at as u32, buf).is_ok(), F::ERASE_SIZE, self.identity, out)
    }

    /// Reads the ring: the newest valid page with its log applied; else whether no page was
    /// ever committed (blank: erased, or a first save cut short), and the newest page whose
    /// header checks, if any.
    fn read_ring(&mut self) -> Result<Newest, (bool, Option<(u32, u32)>)> {
        let mut best: Option<(u32, Slot)> = None;
        let mut blank = true;
        for n in 0..self.region.pages {
            match self.decode(n, None) {
                Ok(slot) => {
                    blank = false;
                    if best.is_none_or(|(_, b)| slot.sequence > b.sequence) {
                        best = Some((n, slot));
                    }
                }
                Err(image::DecodeError::Uncommitted) => {}
                Err(_) => blank = false,
            }
        }
        let (page, slot) = best.ok_or((blank, None))?;
        let unusable = (false, Some((page, slot.sequence)));
        let mut image = Image::new();
        self.decode(page, Some(&mut image)).map_err(|_| unusable)?;
        let end = if slot.version == image::VERSION {
            // An entry that checks but cannot be applied whole (unreadable, or more records
            // than an image holds): no image rather than half of one.
            self.replay(page, &slot, &mut image).map_err(|()| unusable)?
        } else {
            None
        };
        Ok(Newest { page, sequence: slot.sequence, end, image })
    }

    fn read_unit(&mut self, at: u32) -> Option<[u8; UNIT]> {
        let mut unit = [0u8; UNIT];
        self.flash.read(at, &mut unit).ok().map(|()| unit)
    }

    /// Applies the committed entries of page `page`'s log to `image`; returns where the next
    /// entry goes, or `None` if the log ends in something that is not a whole entry (a save
    /// a power cut interrupted: the page takes no more). `Err` if an entry that checks could
    /// not be applied whole.
    fn replay(&mut self, page: u32, slot: &Slot, image: &mut Image) -> Result<Option<u32>, ()> {
        let base = self.page(page);
        let size = F::ERASE_SIZE as u32;
        let mut at = image::slot_size(slot.records) as u32;
        let mut start = at;
        let mut crc = image::log_crc(slot.sequence);
        while at + UNIT as u32 <= size {
            let Some(unit) = self.read_unit(base + at) else { return Ok(None) };
            if unit == [0xFF; UNIT] {
                // The log ends here if the rest of the page is erased: only then can the next
                // entry be written (a corrupt page is not written again).
                let mut rest = at + UNIT as u32;
                while rest + UNIT as u32 <= size {
                    if self.read_unit(base + rest) != Some([0xFF; UNIT]) {
                        return Ok(None);
                    }
                    rest += UNIT as u32;
                }
                break;
            }
            if !image::is_log_commit(&unit) {
                crc.update(&unit);
                at += UNIT as u32;
                continue;
            }
            let count = unit[2] as u32;
            let sum = u32::from_le_bytes([unit[4], unit[5], unit[6], unit[7]]);
            crc.update(&unit[..4]);
            if count == 0 || count * UNIT as u32 != at - start || crc.finish() != sum {
                return Ok(None);
            }
            // Removals first: the image never holds more records than before or after.
            for removals in [true, false] {
                for k in 0..count {
                    let r = Record::decode(&self.read_unit(base + start + k * UNIT as u32).ok_or(())?);
                    if r.is_removal() != removals {
                        continue;
                    }
                    if removals {
                        image.remove(r.index, r.sub);
                    } else {
                        image.set(r).map_err(|_| ())?;
                    }
                }
            }
            at += UNIT as u32;
            start = at;
            crc = image::log_crc(slot.sequence);
        }
        // Records with no commit after them: an entry a power cut interrupted.
        Ok((start == at).then_some(at))
    }

    /// Reads what the pages hold: the newest valid image; else blank if no page was ever
    /// committed (erased, or a first save cut short); else invalid. What it finds is kept for
    /// the saves that follow.
    pub fn load(&mut self) -> Loaded {
        match self.read_ring() {
            Ok(newest) => {
                let image = newest.image.clone();
                self.known = Known::Newest(newest);
                Loaded::Image(image)
            }
            Err((blank, newest)) => {
                self.known = Known::Nothing(newest);
                if blank {
                    Loaded::Blank
                } else {
                    Loaded::Invalid
                }
            }
        }
    }

    fn check_region(&self) -> Result<(), SaveError<F::Error>> {
        if self.region.pages < 2
            || !self.region.offset.is_multiple_of(F::ERASE_SIZE as u32)
            || !8usize.is_multiple_of(F::WRITE_SIZE)
            || !8usize.is_multiple_of(F::READ_SIZE)
        {
            return Err(SaveError::Region);
        }
        Ok(())
    }

    /// Reads the ring unless what it holds is known.
    fn know(&mut self) {
        if matches!(self.known, Known::Unread) {
            self.known = self.read_ring().map_or_else(|(_, newest)| Known::Nothing(newest), Known::Newest);
        }
    }

    /// Performs an [`crate::Output::Store`]: the stored image with the current values of the
    /// groups in `mask` (see [`super::merge`]) becomes the newest image. Only what changed is
    /// written, into the newest page's log while it has room.
    pub fn save(&mut self, params: &impl Parameters, mask: GroupMask) -> Result<(), SaveError<F::Error>> {
        self.check_region()?;
        self.know();
        let (mut image, mut log) = (Image::new(), Log::new());
        let old = match &self.known {
            Known::Newest(n) => n.image.records(),
            _ => &[],
        };
        let od = params.od();
        let storable = match &mut self.storable {
            Some(s) if core::ptr::eq(s.table, od.table()) => s,
            other => other.insert(Storable::of(od.table())),
        };
        let count = merge_into(old, &mut image, &mut log, od, storable, params.node_id(), mask)
            .map_err(|_| SaveError::TooLarge)?;
        let result = match &mut self.known {
            Known::Newest(_) if count == 0 => return Ok(()),
            Known::Newest(n) => match n.end.filter(|&end| end as usize + (count + 1) * UNIT <= F::ERASE_SIZE) {
                Some(end) if count == log.len() => {
                    let base = self.region.offset + n.page * F::ERASE_SIZE as u32;
                    append(&mut self.flash, base, n, end, &image, &log)
                }
                _ => {
                    let previous = Some((n.page, n.sequence));
                    self.start_page(image, previous)
                }
            },
            Known::Nothing(previous) => {
                let previous = *previous;
                self.start_page(image, previous)
            }
            Known::Unread => self.start_page(image, None),
        };
        if result.is_err() {
            self.known = Known::Unread;
        }
        result
    }

    /// Makes `image` the newest image as it is, on a page of its own (factory programming,
    /// tools, tests).
    pub fn write(&mut self, image: &Image) -> Result<(), SaveError<F::Error>> {
        self.check_region()?;
        self.know();
        let previous = match &self.known {
            Known::Newest(n) => Some((n.page, n.sequence)),
            Known::Nothing(previous) => *previous,
            Known::Unread => None,
        };
        let result = self.start_page(image.clone(), previous);
        if result.is_err() {
            self.known = Known::Unread;
        }
        result
    }

    /// Starts the page after `previous` (page 0 on a ring with no valid image) with the whole
    /// `image`.
    fn start_page(&mut self, image: Image, previous: Option<(u32, u32)>) -> Result<(), SaveError<F::Error>> {
        let page_size = F::ERASE_SIZE as u32;
        if image::slot_size(image.len()) > F::ERASE_SIZE {
            return Err(SaveError::TooLarge);
        }
        let (n, sequence) = match previous {
            Some((n, s)) => ((n + 1) % self.region.pages, s.checked_add(1).ok_or(SaveError::Exhausted)?),
            None => (0, 1),
        };
        let base = self.page(n);
        let header = image.header(self.identity, sequence);
        self.flash.erase(base, base + page_size).map_err(SaveError::Flash)?;
        // Each unit read back as it is written: a page that does not hold what was written
        // never gets its commit marker.
        for (i, r) in image.records().iter().enumerate() {
            program(&mut self.flash, base + (HEADER_SIZE + i * RECORD_SIZE) as u32, &r.encode())?;
        }
        for (i, unit) in header.chunks_exact(UNIT).enumerate() {
            let unit: &[u8; UNIT] = unit.try_into().map_err(|_| SaveError::Verify)?;
            program(&mut self.flash, base + (COMMIT_SIZE + i * UNIT) as u32, unit)?;
        }
        // The marker last, read back too: every byte of the page then is what was written.
        if let Err(e) = program(&mut self.flash, base, &COMMIT) {
            // Make sure the page never counts: programming zeros is always possible.
            let _ = self.flash.write(base, &[0; COMMIT_SIZE]);
            return Err(e);
        }
        let end = image::slot_size(image.len()) as u32;
        self.known = Known::Newest(Newest { page: n, sequence, end: Some(end), image });
        Ok(())
    }
}

/// Writes `unit` at `at` and reads it back.
fn program<F: NorFlash>(flash: &mut F, at: u32, unit: &[u8; UNIT]) -> Result<(), SaveError<F::Error>> {
    flash.write(at, unit).map_err(SaveError::Flash)?;
    let mut back = [0u8; UNIT];
    flash.read(at, &mut back).map_err(SaveError::Flash)?;
    if back != *unit {
        return Err(SaveError::Verify);
    }
    Ok(())
}

/// Appends `log`, the records that turn `n`'s image (on the page at `base`) into `image`, to
/// its log at `end`, then the entry's commit unit; `n` then holds `image`.
fn append<F: NorFlash>(
    flash: &mut F,
    base: u32,
    n: &mut Newest,
    end: u32,
    image: &Image,
    log: &Log,
) -> Result<(), SaveError<F::Error>> {
    let mut at = base + end;
    let mut crc = image::log_crc(n.sequence);
    for r in log {
        let unit = r.encode();
        program(flash, at, &unit)?;
        crc.update(&unit);
        at += UNIT as u32;
    }
    // LOG_MAX records: the count fits its byte.
    let commit = image::log_commit(log.len() as u8, crc);
    if let Err(e) = program(flash, at, &commit) {
        // Make sure the entry never counts: programming zeros is always possible.
        let _ = flash.write(at, &[0; UNIT]);
        return Err(e);
    }
    n.end = Some(at + UNIT as u32 - base);
    n.image.assign(image);
    Ok(())
}
