//! The parameter image on flash: a ring of erase pages, one image per page.
//!
//! A save goes to the page after the one holding the newest valid image, with the next
//! sequence number: erase the page, write the records and the header, read them back, then
//! write the commit marker and check the whole page. Only the commit marker makes the page
//! count, and the page it replaces is not touched, so a power cut at any erase or word write
//! leaves either the old image (newest) or the new one. Nothing is repaired at power-on: an
//! unfinished page is simply not valid, and is erased when the ring comes round to it. Each
//! save erases one page, so `pages` pages share the wear.
//!
//! Why not `sequential-storage`: its API is async (embedded-storage-async) while the core and
//! its shells call storage synchronously, and its map stores items one by one, whereas a 1010h
//! save must replace a whole group atomically; storing the image as a single item would keep
//! only its page rotation, which is the few dozen lines below.

use embedded_storage::nor_flash::NorFlash;

use super::image::{self, Image, COMMIT, COMMIT_SIZE, HEADER_SIZE, RECORD_SIZE};
use super::{merge, Loaded, Parameters};
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
    /// Sequence numbers exhausted (2^32 saves: beyond any flash's endurance).
    Exhausted,
}

/// The parameter pages of one device.
#[derive(Clone, Debug)]
pub struct ParamFlash<F> {
    flash: F,
    region: Region,
    identity: u32,
}

/// Where the newest valid image is: (page, sequence number).
type Newest = Option<(u32, u32)>;

impl<F: NorFlash> ParamFlash<F> {
    /// The pages in `region` of `flash`, holding images of the device `identity`
    /// ([`super::identity`] of its dictionary).
    pub fn new(flash: F, region: Region, identity: u32) -> ParamFlash<F> {
        ParamFlash { flash, region, identity }
    }

    /// The flash.
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

    /// Checks one page; with `out`, also reads its records.
    fn decode(&mut self, n: u32, out: Option<&mut Image>) -> Result<u32, image::DecodeError> {
        let base = self.page(n);
        let flash = &mut self.flash;
        Image::decode_with(|at, buf| flash.read(base + at as u32, buf).is_ok(), F::ERASE_SIZE, self.identity, out)
    }

    fn newest(&mut self) -> Newest {
        let mut best: Newest = None;
        for n in 0..self.region.pages {
            if let Ok(seq) = self.decode(n, None) {
                if best.is_none_or(|(_, s)| seq > s) {
                    best = Some((n, seq));
                }
            }
        }
        best
    }

    /// Reads what the pages hold: the newest valid image; else blank if no page was ever
    /// committed (erased, or a first save cut short); else invalid.
    pub fn load(&mut self) -> Loaded {
        if let Some((n, _)) = self.newest() {
            let mut image = Image::new();
            if self.decode(n, Some(&mut image)).is_ok() {
                return Loaded::Image(image);
            }
            return Loaded::Invalid;
        }
        if (0..self.region.pages).all(|n| self.decode(n, None) == Err(image::DecodeError::Uncommitted)) {
            Loaded::Blank
        } else {
            Loaded::Invalid
        }
    }

    /// Performs an [`crate::Output::Store`]: the stored image with the current values of the
    /// groups in `mask` (see [`merge`]) becomes the newest image.
    pub fn save(&mut self, params: &impl Parameters, mask: GroupMask) -> Result<(), SaveError<F::Error>> {
        let newest = self.newest();
        let mut image = Image::new();
        if let Some((n, _)) = newest {
            if self.decode(n, Some(&mut image)).is_err() {
                return Err(SaveError::Verify);
            }
        }
        merge(&mut image, params.od(), params.node_id(), mask).map_err(|_| SaveError::TooLarge)?;
        self.commit(&image, newest)
    }

    /// Makes `image` the newest image as it is (factory programming, tools, tests).
    pub fn write(&mut self, image: &Image) -> Result<(), SaveError<F::Error>> {
        let newest = self.newest();
        self.commit(image, newest)
    }

    fn commit(&mut self, image: &Image, newest: Newest) -> Result<(), SaveError<F::Error>> {
        let page_size = F::ERASE_SIZE as u32;
        if self.region.pages < 2
            || !self.region.offset.is_multiple_of(page_size)
            || !8usize.is_multiple_of(F::WRITE_SIZE)
            || !8usize.is_multiple_of(F::READ_SIZE)
        {
            return Err(SaveError::Region);
        }
        if image::slot_size(image.len()) > F::ERASE_SIZE {
            return Err(SaveError::TooLarge);
        }
        let (n, seq) = match newest {
            Some((n, s)) => ((n + 1) % self.region.pages, s.checked_add(1).ok_or(SaveError::Exhausted)?),
            None => (0, 1),
        };
        let base = self.page(n);
        let header = image.header(self.identity, seq);
        self.flash.erase(base, base + page_size).map_err(SaveError::Flash)?;
        for (i, r) in image.records().iter().enumerate() {
            self.flash.write(base + (HEADER_SIZE + i * RECORD_SIZE) as u32, &r.encode()).map_err(SaveError::Flash)?;
        }
        self.flash.write(base + COMMIT_SIZE as u32, &header).map_err(SaveError::Flash)?;
        // Read back before committing: a page that does not hold what was written never counts.
        let mut head = [0u8; HEADER_SIZE - COMMIT_SIZE];
        self.flash.read(base + COMMIT_SIZE as u32, &mut head).map_err(SaveError::Flash)?;
        if head != header {
            return Err(SaveError::Verify);
        }
        for (i, r) in image.records().iter().enumerate() {
            let mut b = [0u8; RECORD_SIZE];
            self.flash.read(base + (HEADER_SIZE + i * RECORD_SIZE) as u32, &mut b).map_err(SaveError::Flash)?;
            if b != r.encode() {
                return Err(SaveError::Verify);
            }
        }
        self.flash.write(base, &COMMIT).map_err(SaveError::Flash)?;
        if self.decode(n, None) != Ok(seq) {
            // Make sure the page never counts: programming zeros is always possible.
            let _ = self.flash.write(base, &[0; COMMIT_SIZE]);
            return Err(SaveError::Verify);
        }
        Ok(())
    }
}
