//! Host flashes for the parameter storage.
//!
//! [`RamFlash`] behaves like the STM32F1's embedded flash as embassy-stm32's blocking driver
//! presents it through `NorFlash`: 1 KiB erase pages, 2-byte (half-word) writes, erased bytes
//! read FFh, and a half-word that is not erased can only be programmed to 0000h (otherwise the
//! F1 sets PGERR and writes nothing). It can cut the power at the k-th erase or half-word
//! write, optionally leaving that operation half done. [`FileFlash`] is a `RamFlash` kept in a
//! file, so that stopping and starting the simulator is a power cycle.

use std::path::{Path, PathBuf};

use embedded_storage::nor_flash::{ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash};

/// Erase page size of the STM32F103CB.
pub const PAGE: usize = 1024;
/// Program unit (half-word).
pub const WORD: usize = 2;

/// What went wrong.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum FlashError {
    /// Offset or length not a multiple of the write or erase size.
    NotAligned,
    /// Outside the flash.
    OutOfBounds,
    /// The power is off (after a cut, until [`RamFlash::power_on`]).
    PowerLost,
    /// Programming a half-word that is not erased (PGERR).
    NotErased,
    /// The flash is worn out ([`RamFlash::set_worn`]).
    Worn,
}

impl NorFlashError for FlashError {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            FlashError::NotAligned => NorFlashErrorKind::NotAligned,
            FlashError::OutOfBounds => NorFlashErrorKind::OutOfBounds,
            _ => NorFlashErrorKind::Other,
        }
    }
}

/// A planned power cut.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Cut {
    /// The operation (erase or half-word write) the power fails in, counted from
    /// [`RamFlash::cut_after`].
    at: u64,
    /// `None`: the operation does not happen. `Some(m)`: it is torn: a write programs only the
    /// bits of the new value outside `m`; an erase erases only the last `m % PAGE` bytes.
    torn: Option<u16>,
    /// `Some(v)`: the cut operation leaves cells that read back as any value: a write leaves
    /// the half-word reading `v`, an erase leaves every byte of the page a value derived from
    /// `v` (set by [`RamFlash::cut_garbage`]).
    garbage: Option<u16>,
}

/// Flash in RAM with the STM32F1 geometry.
#[derive(Clone, Debug)]
pub struct RamFlash {
    mem: Vec<u8>,
    erases: Vec<u32>,
    ops: u64,
    cut: Option<Cut>,
    off: bool,
    worn: bool,
}

impl RamFlash {
    /// `pages` erased pages.
    pub fn new(pages: usize) -> RamFlash {
        RamFlash::from_bytes(vec![0xFF; pages * PAGE])
    }

    /// A flash holding `bytes` (padded with FFh to whole pages).
    pub fn from_bytes(mut bytes: Vec<u8>) -> RamFlash {
        let len = bytes.len().div_ceil(PAGE).max(1) * PAGE;
        bytes.resize(len, 0xFF);
        let pages = len / PAGE;
        RamFlash { mem: bytes, erases: vec![0; pages], ops: 0, cut: None, off: false, worn: false }
    }

    /// The contents.
    pub fn bytes(&self) -> &[u8] {
        &self.mem
    }

    /// The contents, to corrupt them.
    pub fn bytes_mut(&mut self) -> &mut [u8] {
        &mut self.mem
    }

    /// Erases and half-word writes performed so far (a cut one included).
    pub fn ops(&self) -> u64 {
        self.ops
    }

    /// How often page `n` has been erased (wear).
    pub fn erase_count(&self, n: usize) -> u32 {
        self.erases[n]
    }

    /// Cuts the power in the `k`-th erase or half-word write from now (0 = the next one),
    /// leaving it undone (`torn = None`) or half done; every later operation fails until
    /// [`RamFlash::power_on`].
    pub fn cut_after(&mut self, k: u64, torn: Option<u16>) {
        self.cut = Some(Cut { at: self.ops + k, torn, garbage: None });
    }

    /// Cuts the power in the `k`-th erase or half-word write from now, leaving the cells it
    /// touched reading back as any value: the half-word reads `value`; an erased page reads
    /// bytes derived from `value` (none of them necessarily FFh or the old content).
    pub fn cut_garbage(&mut self, k: u64, value: u16) {
        self.cut = Some(Cut { at: self.ops + k, torn: None, garbage: Some(value) });
    }

    /// The garbage of a cut, if the cut is that kind.
    fn garbage(&self) -> Option<u16> {
        self.cut.and_then(|c| c.garbage)
    }

    /// The power comes back (a power cycle's second half); a planned cut not reached is dropped.
    pub fn power_on(&mut self) {
        self.off = false;
        self.cut = None;
    }

    /// Is the power off after a cut?
    pub fn is_off(&self) -> bool {
        self.off
    }

    /// Makes every erase and write fail (a worn-out flash) or work again.
    pub fn set_worn(&mut self, worn: bool) {
        self.worn = worn;
    }

    /// Counts one operation; `Some(torn)` if the power fails in it.
    fn step(&mut self) -> Result<Option<Option<u16>>, FlashError> {
        if self.off {
            return Err(FlashError::PowerLost);
        }
        if self.worn {
            return Err(FlashError::Worn);
        }
        let this = self.ops;
        self.ops += 1;
        match self.cut {
            Some(c) if c.at == this => {
                self.off = true;
                Ok(Some(c.torn))
            }
            _ => Ok(None),
        }
    }

    fn check(&self, offset: u32, len: usize, align: usize) -> Result<usize, FlashError> {
        let start = offset as usize;
        if !start.is_multiple_of(align) || !len.is_multiple_of(align) {
            return Err(FlashError::NotAligned);
        }
        if start.checked_add(len).is_none_or(|end| end > self.mem.len()) {
            return Err(FlashError::OutOfBounds);
        }
        Ok(start)
    }
}

impl ErrorType for RamFlash {
    type Error = FlashError;
}

impl ReadNorFlash for RamFlash {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), FlashError> {
        if self.off {
            return Err(FlashError::PowerLost);
        }
        let start = self.check(offset, bytes.len(), 1)?;
        bytes.copy_from_slice(&self.mem[start..start + bytes.len()]);
        Ok(())
    }

    fn capacity(&self) -> usize {
        self.mem.len()
    }
}

impl NorFlash for RamFlash {
    const WRITE_SIZE: usize = WORD;
    const ERASE_SIZE: usize = PAGE;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), FlashError> {
        let start = self.check(from, (to as usize).saturating_sub(from as usize), PAGE)?;
        if to < from {
            return Err(FlashError::NotAligned);
        }
        for page in (start..to as usize).step_by(PAGE) {
            match self.step()? {
                None => {
                    self.mem[page..page + PAGE].fill(0xFF);
                    self.erases[page / PAGE] += 1;
                }
                Some(_) if self.garbage().is_some() => {
                    let [a, b] = self.garbage().unwrap_or(0).to_le_bytes();
                    for (i, x) in self.mem[page..page + PAGE].iter_mut().enumerate() {
                        *x = if i % 2 == 0 { a } else { b }.rotate_left(i as u32 % 8) ^ (i / 2) as u8;
                    }
                    return Err(FlashError::PowerLost);
                }
                Some(torn) => {
                    let n = torn.map_or(0, |m| m as usize % PAGE);
                    self.mem[page + PAGE - n..page + PAGE].fill(0xFF);
                    return Err(FlashError::PowerLost);
                }
            }
        }
        Ok(())
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), FlashError> {
        let start = self.check(offset, bytes.len(), WORD)?;
        for (i, w) in bytes.chunks_exact(WORD).enumerate() {
            let at = start + i * WORD;
            let old = u16::from_le_bytes([self.mem[at], self.mem[at + 1]]);
            let new = u16::from_le_bytes([w[0], w[1]]);
            let cut = self.step()?;
            if old != 0xFFFF && new != 0 {
                return Err(FlashError::NotErased);
            }
            let value = match cut {
                Some(_) if self.garbage().is_some() => self.garbage().unwrap_or(0),
                None => new,
                Some(None) => old,
                Some(Some(mask)) => old & (new | mask),
            };
            self.mem[at..at + WORD].copy_from_slice(&value.to_le_bytes());
            if cut.is_some() {
                return Err(FlashError::PowerLost);
            }
        }
        Ok(())
    }
}

/// A [`RamFlash`] kept in a file: every erase and write is saved at once (through a temporary
/// file and a rename, so that killing the simulator never leaves a half-written file).
#[derive(Debug)]
pub struct FileFlash {
    ram: RamFlash,
    path: PathBuf,
}

impl FileFlash {
    /// Opens the flash in `path`, or a blank one of `pages` pages if the file does not exist.
    /// A file of another size is an error (it belongs to another flash layout).
    pub fn open(path: impl AsRef<Path>, pages: usize) -> std::io::Result<FileFlash> {
        let path = path.as_ref().to_path_buf();
        let ram = match std::fs::read(&path) {
            Ok(bytes) if bytes.len() == pages * PAGE => RamFlash::from_bytes(bytes),
            Ok(bytes) => {
                return Err(std::io::Error::new(
                    std::io::ErrorKind::InvalidData,
                    format!("{}: {} bytes, expected {}", path.display(), bytes.len(), pages * PAGE),
                ))
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => RamFlash::new(pages),
            Err(e) => return Err(e),
        };
        Ok(FileFlash { ram, path })
    }

    /// The flash in RAM.
    pub fn ram(&mut self) -> &mut RamFlash {
        &mut self.ram
    }

    fn persist(&self) -> std::io::Result<()> {
        let tmp = self.path.with_extension("tmp");
        std::fs::write(&tmp, self.ram.bytes())?;
        std::fs::rename(&tmp, &self.path)
    }

    fn then_persist(&mut self, r: Result<(), FlashError>) -> Result<(), FlashError> {
        // What the operation did (even a failed one) is what the file must hold.
        match self.persist() {
            Ok(()) => r,
            Err(_) => Err(FlashError::Worn),
        }
    }
}

impl ErrorType for FileFlash {
    type Error = FlashError;
}

impl ReadNorFlash for FileFlash {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), FlashError> {
        self.ram.read(offset, bytes)
    }

    fn capacity(&self) -> usize {
        self.ram.capacity()
    }
}

impl NorFlash for FileFlash {
    const WRITE_SIZE: usize = WORD;
    const ERASE_SIZE: usize = PAGE;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), FlashError> {
        let r = self.ram.erase(from, to);
        self.then_persist(r)
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), FlashError> {
        let r = self.ram.write(offset, bytes);
        self.then_persist(r)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn geometry_and_programming_rules() {
        let mut f = RamFlash::new(2);
        assert_eq!(f.capacity(), 2048);
        assert_eq!(f.write(1, &[0, 0]), Err(FlashError::NotAligned));
        assert_eq!(f.write(0, &[0]), Err(FlashError::NotAligned));
        assert_eq!(f.write(2048, &[0, 0]), Err(FlashError::OutOfBounds));
        assert_eq!(f.erase(1, 1025), Err(FlashError::NotAligned));
        f.write(0, &[0x12, 0x34]).unwrap();
        assert_eq!(f.write(0, &[0x10, 0x30]), Err(FlashError::NotErased));
        f.write(0, &[0, 0]).unwrap();
        assert_eq!(&f.bytes()[..3], &[0, 0, 0xFF]);
        f.erase(0, 1024).unwrap();
        assert!(f.bytes()[..1024].iter().all(|&b| b == 0xFF));
        assert_eq!(f.ops(), 4, "the refused program counts as an attempt");
    }

    #[test]
    fn power_cut_stops_everything_until_power_on() {
        let mut f = RamFlash::new(1);
        f.cut_after(1, None);
        assert_eq!(f.write(0, &[1, 2, 3, 4, 5, 6]), Err(FlashError::PowerLost));
        assert_eq!(&f.bytes()[..6], &[1, 2, 0xFF, 0xFF, 0xFF, 0xFF]);
        let mut b = [0u8; 2];
        assert_eq!(f.read(0, &mut b), Err(FlashError::PowerLost));
        assert_eq!(f.erase(0, 1024), Err(FlashError::PowerLost));
        f.power_on();
        f.read(0, &mut b).unwrap();
        assert_eq!(b, [1, 2]);
    }

    #[test]
    fn torn_write_and_torn_erase() {
        let mut f = RamFlash::new(1);
        f.cut_after(0, Some(0xFF00));
        assert_eq!(f.write(0, &[0x00, 0x00]), Err(FlashError::PowerLost));
        assert_eq!(&f.bytes()[..2], &[0x00, 0xFF], "only the low byte programmed");
        f.power_on();
        f.cut_after(0, Some(1000));
        assert_eq!(f.erase(0, 1024), Err(FlashError::PowerLost));
        assert_eq!(&f.bytes()[..2], &[0x00, 0xFF], "the start is not erased yet");
    }

    #[test]
    fn a_cut_can_leave_any_value() {
        let mut f = RamFlash::new(1);
        f.cut_garbage(1, 0x1234);
        assert_eq!(f.write(0, &[0, 0, 0, 0]), Err(FlashError::PowerLost));
        assert_eq!(&f.bytes()[..4], &[0, 0, 0x34, 0x12], "the cut half-word reads anything");
        f.power_on();
        f.cut_garbage(0, 0xA5C3);
        assert_eq!(f.erase(0, 1024), Err(FlashError::PowerLost));
        assert!(f.bytes().iter().any(|&b| b != 0xFF), "an interrupted erase leaves garbage");
        assert!(f.bytes()[..4] != [0, 0, 0x34, 0x12]);
    }

    #[test]
    fn file_flash_survives_reopening() {
        let dir = std::env::temp_dir().join(format!("siko-fileflash-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("params.bin");
        let _ = std::fs::remove_file(&path);
        {
            let mut f = FileFlash::open(&path, 2).unwrap();
            f.write(1024, &[0xAB, 0xCD]).unwrap();
        }
        let mut f = FileFlash::open(&path, 2).unwrap();
        let mut b = [0u8; 3];
        f.read(1024, &mut b).unwrap();
        assert_eq!(b, [0xAB, 0xCD, 0xFF]);
        assert!(FileFlash::open(&path, 3).is_err(), "another layout");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
