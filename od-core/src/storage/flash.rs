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

use super::crc::Crc32;
use super::image::{self, DecodeError, Image, Record, Slot, COMMIT, COMMIT_SIZE, HEADER_SIZE, UNIT};
use super::{merge_into, Loaded, Log, Parameters, Storable, LOG_MAX};
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

/// What a unit of erased flash reads.
const ERASED: [u8; UNIT] = [0xFF; UNIT];

/// The parameter pages of one device.
#[derive(Clone, Debug)]
pub struct ParamFlash<F> {
    flash: F,
    region: Region,
    identity: u32,
    /// The ring has been read (and no save failed since): what the fields below say is true.
    read: bool,
    /// The page with the highest sequence number among those whose header checks, and that
    /// number: the next page goes after it.
    last: Option<(u32, u32)>,
    /// The CRC each log entry of that page starts from (its sequence number digested).
    log_crc: Crc32,
    /// That page holds the newest valid image: `image`, its log applied.
    valid: bool,
    /// Offset in that page where the next log entry goes; 0 when the page takes no more
    /// entries (a version-1 image, or a log that ends in an unfinished entry).
    end: u32,
    /// The newest valid image, if `valid`.
    image: Image,
    /// The storable entries of the dictionary saved last.
    storable: Option<Storable>,
}

impl<F: NorFlash> ParamFlash<F> {
    /// The pages in `region` of `flash`, holding images of the device `identity`
    /// ([`super::identity`] of its dictionary).
    pub fn new(flash: F, region: Region, identity: u32) -> ParamFlash<F> {
        ParamFlash {
            flash,
            region,
            identity,
            read: false,
            last: None,
            log_crc: Crc32::new(),
            valid: false,
            end: 0,
            image: Image::new(),
            storable: None,
        }
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

    /// Checks page `n`'s image; with `records`, also reads its records into `self.image`.
    fn decode(&mut self, n: u32, records: bool) -> Result<Slot, DecodeError> {
        let base = self.page(n);
        let (flash, out) = (&mut self.flash, records.then_some(&mut self.image));
        Image::decode_slot(|at, buf| read(flash, base + at as u32, buf), F::ERASE_SIZE, self.identity, out)
    }

    /// Reads the ring: the newest page whose header checks, and its image with the log
    /// applied if that page is valid. Returns whether no page was ever committed (blank:
    /// erased, or a first save cut short).
    fn scan(&mut self) -> bool {
        let mut best: Option<(u32, Slot)> = None;
        let mut blank = true;
        for n in 0..self.region.pages {
            match self.decode(n, false) {
                Ok(slot) => {
                    blank = false;
                    if best.is_none_or(|(_, b)| slot.sequence > b.sequence) {
                        best = Some((n, slot));
                    }
                }
                Err(e) => blank &= e == DecodeError::Uncommitted,
            }
        }
        self.read = true;
        self.last = best.map(|(n, slot)| (n, slot.sequence));
        self.end = 0;
        self.valid = match best {
            Some((page, slot)) => {
                self.log_crc = image::log_crc(slot.sequence);
                let ok = self.decode(page, true).is_ok();
                // An entry that checks but cannot be applied whole (unreadable, or more
                // records than an image holds): no image rather than half of one.
                ok && (slot.version != image::VERSION || self.replay(page, &slot).is_ok())
            }
            None => false,
        };
        blank
    }

    /// Applies the committed entries of page `page`'s log to the image and notes where the
    /// next entry goes, unless the log ends in something that is not a whole entry followed
    /// by erased flash (a save a power cut interrupted, or a page written by someone else:
    /// the page takes no more). `Err` if an entry that checks could not be applied whole.
    fn replay(&mut self, page: u32, slot: &Slot) -> Result<(), ()> {
        let base = self.page(page);
        let size = F::ERASE_SIZE as u32;
        // The unit after the last one read that is not erased, the start of the entry being
        // read, and whether an erased unit was seen (all units after it must be erased too).
        let mut next = image::slot_size(slot.records) as u32;
        let (mut start, mut at, mut tail) = (next, next, false);
        let mut crc = self.log_crc;
        while at + UNIT as u32 <= size {
            let mut unit = [0u8; UNIT];
            if !read(&mut self.flash, base + at, &mut unit) {
                return Ok(());
            }
            at += UNIT as u32;
            if unit == ERASED {
                tail = true;
                continue;
            }
            if tail {
                return Ok(());
            }
            next = at;
            if !image::is_log_commit(&unit) {
                crc.update(&unit);
                continue;
            }
            let count = unit[2] as u32;
            let sum = u32::from_le_bytes([unit[4], unit[5], unit[6], unit[7]]);
            if count == 0 || (count + 1) * UNIT as u32 != at - start || crc.digest(&unit[..4]).finish() != sum {
                return Ok(());
            }
            // Removals first: the image never holds more records than before or after.
            for removals in [true, false] {
                for k in 0..count {
                    let mut unit = [0u8; UNIT];
                    if !read(&mut self.flash, base + start + k * UNIT as u32, &mut unit) {
                        return Err(());
                    }
                    let r = Record::decode(&unit);
                    if r.is_removal() == removals {
                        self.image.update(r, removals).map_err(|_| ())?;
                    }
                }
            }
            start = at;
            crc = self.log_crc;
        }
        if start == next {
            self.end = next;
        }
        Ok(())
    }

    /// Reads what the pages hold: the newest valid image; else blank if no page was ever
    /// committed (erased, or a first save cut short); else invalid. What it finds is kept for
    /// the saves that follow.
    pub fn load(&mut self) -> Loaded {
        let blank = self.scan();
        if self.valid {
            let mut image = Image::new();
            image.assign(&self.image);
            Loaded::Image(image)
        } else if blank {
            Loaded::Blank
        } else {
            Loaded::Invalid
        }
    }

    fn check_region(&mut self) -> Result<(), SaveError<F::Error>> {
        if self.region.pages < 2
            || !self.region.offset.is_multiple_of(F::ERASE_SIZE as u32)
            || !8usize.is_multiple_of(F::WRITE_SIZE)
            || !8usize.is_multiple_of(F::READ_SIZE)
        {
            return Err(SaveError::Region);
        }
        // The ring is read unless what it holds is known.
        if !self.read {
            self.scan();
        }
        Ok(())
    }

    /// Performs an [`crate::Output::Store`]: the stored image with the current values of the
    /// groups in `mask` (see [`super::merge`]) becomes the newest image. Only what changed is
    /// written, into the newest page's log while it has room.
    pub fn save(&mut self, params: &impl Parameters, mask: GroupMask) -> Result<(), SaveError<F::Error>> {
        self.check_region()?;
        let (mut image, mut log) = (Image::new(), Log::new());
        let old = if self.valid { self.image.records() } else { &[] };
        let od = params.od();
        let storable = match &mut self.storable {
            Some(s) if core::ptr::eq(s.table, od.table()) => s,
            other => other.insert(Storable::of(od.table())),
        };
        merge_into(old, &mut image, &mut log, od, storable, params.node_id(), mask).map_err(|_| SaveError::TooLarge)?;
        if self.valid && log.is_empty() {
            return Ok(());
        }
        let result = if self.valid
            && self.end != 0
            && log.len() <= LOG_MAX
            && self.end as usize + (log.len() + 1) * UNIT <= F::ERASE_SIZE
        {
            self.append(&log, &image)
        } else {
            self.start_page(&image)
        };
        self.read &= result.is_ok();
        result
    }

    /// Makes `image` the newest image as it is, on a page of its own (factory programming,
    /// tools, tests).
    pub fn write(&mut self, image: &Image) -> Result<(), SaveError<F::Error>> {
        self.check_region()?;
        let result = self.start_page(image);
        self.read &= result.is_ok();
        result
    }

    /// Starts the page after the last one (page 0 on a ring with no valid header) with the
    /// whole `image`.
    fn start_page(&mut self, image: &Image) -> Result<(), SaveError<F::Error>> {
        let len = image::slot_size(image.len());
        if len > F::ERASE_SIZE {
            return Err(SaveError::TooLarge);
        }
        let (n, sequence) = match self.last {
            Some((n, s)) => ((n + 1) % self.region.pages, s.checked_add(1).ok_or(SaveError::Exhausted)?),
            None => (0, 1),
        };
        let base = self.page(n);
        self.flash.erase(base, base + F::ERASE_SIZE as u32).map_err(SaveError::Flash)?;
        // Each unit read back as it is written: a page that does not hold what was written
        // never gets its commit marker. The header's CRC covers its first 20 bytes and the records.
        let mut header = image::head(image.len(), self.identity, sequence);
        let mut crc = Crc32::new();
        crc.update(&header[..20]);
        let crc = self.program_records(base + HEADER_SIZE as u32, image.records(), crc)?;
        header[20..].copy_from_slice(&crc.finish().to_le_bytes());
        let mut at = base + COMMIT_SIZE as u32;
        for unit in header.as_chunks::<UNIT>().0 {
            self.program(at, unit)?;
            at += UNIT as u32;
        }
        // The marker last, read back too: every byte of the page then is what was written.
        self.commit(base, &COMMIT)?;
        self.last = Some((n, sequence));
        self.log_crc = image::log_crc(sequence);
        self.valid = true;
        self.end = len as u32;
        self.image.assign(image);
        Ok(())
    }

    /// Appends `log`, the records that turn the newest image into `image`, to the newest
    /// page's log, then the entry's commit unit; `image` is then the newest image.
    fn append(&mut self, log: &Log, image: &Image) -> Result<(), SaveError<F::Error>> {
        let (page, _) = self.last.unwrap_or_default();
        let base = self.page(page);
        let at = base + self.end;
        let crc = self.program_records(at, log, self.log_crc)?;
        let at = at + (log.len() * UNIT) as u32;
        // LOG_MAX records: the count fits its byte.
        self.commit(at, &image::log_commit(log.len() as u8, crc))?;
        self.end = at + UNIT as u32 - base;
        self.image.assign(image);
        Ok(())
    }

    /// Programs `records` from `at` on, one unit each; returns `crc` having digested them.
    fn program_records(
        &mut self,
        mut at: u32,
        records: &[Record],
        mut crc: Crc32,
    ) -> Result<Crc32, SaveError<F::Error>> {
        for r in records {
            let unit = r.encode();
            self.program(at, &unit)?;
            crc.update(&unit);
            at += UNIT as u32;
        }
        Ok(crc)
    }

    /// Writes `unit` at `at` and reads it back.
    fn program(&mut self, at: u32, unit: &[u8; UNIT]) -> Result<(), SaveError<F::Error>> {
        self.flash.write(at, unit).map_err(SaveError::Flash)?;
        let mut back = [0u8; UNIT];
        self.flash.read(at, &mut back).map_err(SaveError::Flash)?;
        if back != *unit {
            return Err(SaveError::Verify);
        }
        Ok(())
    }

    /// [`ParamFlash::program`] of a commit unit: if it fails, zeros make sure it never counts
    /// (programming zeros is always possible).
    fn commit(&mut self, at: u32, unit: &[u8; UNIT]) -> Result<(), SaveError<F::Error>> {
        let result = self.program(at, unit);
        if result.is_err() {
            let _ = self.flash.write(at, &[0; UNIT]);
        }
        result
    }
}

/// Reads `buf` from `at`; false if the flash could not. (One routine for every read of a
/// page, the buffer the caller's.)
#[inline(never)]
fn read<F: NorFlash>(flash: &mut F, at: u32, buf: &mut [u8]) -> bool {
    flash.read(at, buf).is_ok()
}
