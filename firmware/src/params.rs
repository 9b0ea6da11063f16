//! The parameter pages: the region `memory.x` reserves at the end of the flash, holding the
//! core's power-fail-safe parameter images (`od_core::storage::ParamFlash`), written through
//! the board's flash driver (`boards::flash`). A save blocks the loop for its writes (and, when the
//! newest page is full, the erase of the next one: the F103 cannot read its flash while
//! erasing it), and the node answers the store once it is done.

use boards::flash::Flash;
use embedded_storage::nor_flash::NorFlash;
use od_core::storage::{ParamFlash, Region};

/// The parameter pages of a board.
pub type Params = ParamFlash<Flash>;

extern "C" {
    /// Offset of the parameter pages from the start of flash (`memory.x`).
    static __params_offset: u8;
    /// Size of the parameter pages in bytes (`memory.x`).
    static __params_size: u8;
}

/// The region `memory.x` reserves: its symbols are absolute values, read as addresses.
pub fn region() -> Region {
    let offset = core::ptr::addr_of!(__params_offset) as u32;
    let size = core::ptr::addr_of!(__params_size) as u32;
    Region { offset, pages: size / Flash::ERASE_SIZE as u32 }
}

/// The parameter pages of the device whose images carry `identity`
/// (`od_core::storage::identity` of its dictionary, computed when the image is built).
pub fn open(flash: Flash, identity: u32) -> Params {
    ParamFlash::new(flash, region(), identity)
}
