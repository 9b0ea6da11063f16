//! Wire formats: what the bytes of each protocol's messages mean, and nothing else.
//!
//! One module per protocol ([`lss`], [`nmt`], [`emcy`], [`sdo`], and [`j1939`] for J1939's
//! identifier, NAME and parameter-group payloads). Each turns the data bytes of a message into
//! a value (`parse`) and a value back into data bytes (`emit`), so that a service matches on
//! meanings and never on bits. The contract, for every codec here:
//!
//! - **Parse never panics**, whatever the bytes and their number.
//! - **Malformed input is ignored**: `parse` returns `None` for a length the protocol does not
//!   allow, an unknown command or an out-of-range field; the service then does nothing (CiA
//!   301 and 305 define no error answer to a frame they cannot read). Reserved bytes are not
//!   checked on input.
//! - **Reserved bytes are zero on emit** (J1939's are FFh, "not available", as SAE J1939-71
//!   prescribes; [`j1939`] says so per payload), and `parse(emit(x)) == x` for every value `x`
//!   (round-trip tests in each module).
//! - **The data bytes alone**: no codec sees a CAN identifier or a remote flag. Which
//!   identifier carries which message is the transport's business (CANopen's 600h/580h + node-ID
//!   for SDO, J1939's CAM21/CAM11 for the same SDO bytes), checked before the codec is called.
//!
//! The shape follows smoltcp's `wire` module (a representation parsed from, and emitted into,
//! the raw bytes), in the small: CAN payloads are at most 8 bytes, so values are plain copies.

pub mod emcy;
pub mod j1939;
pub mod lss;
pub mod nmt;
pub mod sdo;

/// The little-endian u32 at `data[at..at + 4]`.
#[inline]
pub(crate) const fn u32_le(data: &[u8; 8], at: usize) -> u32 {
    u32::from_le_bytes([data[at], data[at + 1], data[at + 2], data[at + 3]])
}

/// The little-endian u16 at `data[at..at + 2]`.
#[inline]
pub(crate) const fn u16_le(data: &[u8; 8], at: usize) -> u16 {
    u16::from_le_bytes([data[at], data[at + 1]])
}

/// The 8 bytes of a message that must have exactly 8.
#[inline]
pub(crate) fn exactly_8(data: &[u8]) -> Option<&[u8; 8]> {
    data.try_into().ok()
}
