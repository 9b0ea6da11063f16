//! The STM32F103CB's flash as the parameter pages' `NorFlash`, through its registers (RM0008
//! 3.3.3, PM0075): the checks, unlock sequence, half-word programming and page erase of
//! Embassy's blocking flash driver, without its sector tables (the F103CB has one kind of page,
//! 1 KiB) and its generic chunking.

use core::sync::atomic::{fence, Ordering};

use embassy_stm32::pac;
use embassy_stm32::peripherals::FLASH;
use embassy_stm32::Peri;
use embedded_storage::nor_flash::{ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash};

/// Where the flash starts in the address space.
const BASE: u32 = 0x0800_0000;
/// The flash's size (STM32F103CB: 128 KiB).
const SIZE: u32 = 128 * 1024;
/// A page, the unit of erasing.
const PAGE: u32 = 1024;

/// Why a flash access failed (Embassy's `flash::Error` cases that can happen here).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Error {
    /// Beyond the end of the flash.
    Size,
    /// Not on a write unit's (4 bytes) or a page's boundary.
    Unaligned,
    /// The page is write-protected (WRPRTERR).
    Protected,
    /// Programming a half-word that was not erased (PGERR).
    Seq,
    /// An erase did not report its end (EOP).
    Prog,
}

impl NorFlashError for Error {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            Error::Size => NorFlashErrorKind::OutOfBounds,
            Error::Unaligned => NorFlashErrorKind::NotAligned,
            _ => NorFlashErrorKind::Other,
        }
    }
}

/// The flash, offsets counted from its start (as Embassy's `Flash`).
pub struct Flash(());

impl Flash {
    /// The flash controller; nothing is written until a write or an erase.
    pub fn new(_flash: Peri<'static, FLASH>) -> Flash {
        Flash(())
    }
}

/// Clears the status register's error and end flags (written back as read: they clear by
/// writing 1), then unlocks the controller if it is locked.
fn unlock() {
    let flash = pac::FLASH;
    flash.sr().modify(|_| {});
    fence(Ordering::SeqCst);
    if flash.cr().read().lock() {
        flash.keyr().write_value(0x4567_0123);
        flash.keyr().write_value(0xCDEF_89AB);
    }
    fence(Ordering::SeqCst);
}

/// Locks the controller again.
fn lock() {
    fence(Ordering::SeqCst);
    pac::FLASH.cr().modify(|w| w.set_lock(true));
}

/// Waits until the controller is idle; its error flags say how the operation ended.
fn wait_ready() -> Result<(), Error> {
    loop {
        let sr = pac::FLASH.sr().read();
        if !sr.bsy() {
            return if sr.wrprterr() {
                Err(Error::Protected)
            } else if sr.pgerr() {
                Err(Error::Seq)
            } else {
                Ok(())
            };
        }
    }
}

impl ErrorType for Flash {
    type Error = Error;
}

impl ReadNorFlash for Flash {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Error> {
        if offset + bytes.len() as u32 > SIZE {
            return Err(Error::Size);
        }
        // SAFETY: inside the flash, which is always readable memory.
        let data = unsafe { core::slice::from_raw_parts((BASE + offset) as *const u8, bytes.len()) };
        bytes.copy_from_slice(data);
        Ok(())
    }

    fn capacity(&self) -> usize {
        SIZE as usize
    }
}

impl NorFlash for Flash {
    const WRITE_SIZE: usize = 4;
    const ERASE_SIZE: usize = PAGE as usize;

    /// Programs `bytes` half-word by half-word (PG), each one waited for.
    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Error> {
        if offset + bytes.len() as u32 > SIZE {
            return Err(Error::Size);
        }
        if !offset.is_multiple_of(4) || !bytes.len().is_multiple_of(4) {
            return Err(Error::Unaligned);
        }
        let flash = pac::FLASH;
        unlock();
        flash.cr().write(|w| w.set_pg(true));
        fence(Ordering::SeqCst);
        let mut result = Ok(());
        for (k, half) in bytes.chunks_exact(2).enumerate() {
            let address = BASE + offset + 2 * k as u32;
            // SAFETY: a half-word inside the flash, programmed as the controller's PG mode asks.
            unsafe { core::ptr::write_volatile(address as *mut u16, u16::from_le_bytes([half[0], half[1]])) };
            fence(Ordering::SeqCst);
            result = wait_ready();
            if result.is_err() {
                break;
            }
        }
        flash.cr().write(|w| w.set_pg(false));
        lock();
        result
    }

    /// Erases the pages from `from` to `to` (page boundaries), one by one (PER, AR, STRT).
    fn erase(&mut self, from: u32, to: u32) -> Result<(), Error> {
        if to > SIZE || from > to {
            return Err(Error::Size);
        }
        if !from.is_multiple_of(PAGE) || !to.is_multiple_of(PAGE) {
            return Err(Error::Unaligned);
        }
        let flash = pac::FLASH;
        for page in (from..to).step_by(PAGE as usize) {
            unlock();
            flash.cr().modify(|w| w.set_per(true));
            flash.ar().write(|w| w.set_far(BASE + page));
            flash.cr().modify(|w| w.set_strt(true));
            // BSY rises one cycle after STRT (STM32F10xxC/D/E errata 2.2.8): read CR first.
            let _ = flash.cr().read();
            let mut result = wait_ready();
            if !flash.sr().read().eop() {
                result = Err(Error::Prog);
            } else {
                flash.sr().write(|w| w.set_eop(true));
            }
            flash.cr().modify(|w| w.set_per(false));
            flash.sr().modify(|_| {});
            lock();
            result?;
        }
        Ok(())
    }
}
