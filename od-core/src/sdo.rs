//! SDO server (CiA 301 §7.2.4): expedited and segmented transfers on 600h/580h + node-ID.

use crate::abort::Abort;
use crate::time::Instant;

/// The result of a successful write.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Written {
    /// Done: confirm now.
    Done,
    /// The value was accepted but the confirmation waits for the shell (a 1010h "save"):
    /// the server answers when [`SdoServer::complete_deferred`] is called.
    Deferred,
}

/// What the SDO server needs from the node: read and write by (index, sub).
pub trait ObjectAccess {
    /// Size in bytes of the value at (index, sub), after the access check for reading.
    fn read_size(&mut self, index: u16, sub: u8) -> Result<usize, Abort>;
    /// Copies the value at (index, sub) into `buf` (at least `read_size` bytes); returns its size.
    fn read(&mut self, index: u16, sub: u8, buf: &mut [u8]) -> Result<usize, Abort>;
    /// Checks and writes `data` to (index, sub). Nothing changes on `Err`.
    fn write(&mut self, index: u16, sub: u8, data: &[u8], now: Instant) -> Result<Written, Abort>;
}

/// The SDO server's transfer state.
#[derive(Clone, Default)]
pub struct SdoServer {}

impl SdoServer {
    /// An idle server.
    pub fn new() -> SdoServer {
        SdoServer {}
    }

    /// Drops any transfer in progress (NMT reset, STOPPED).
    pub fn reset(&mut self) {}

    /// Handles the payload of a request frame; returns the 8-byte response, if any.
    pub fn on_request(&mut self, req: &[u8], now: Instant, dict: &mut impl ObjectAccess) -> Option<[u8; 8]> {
        let _ = (req, now, dict);
        None
    }

    /// Aborts a transfer whose client fell silent; returns the abort frame payload.
    pub fn poll(&mut self, now: Instant) -> Option<[u8; 8]> {
        let _ = now;
        None
    }

    /// When [`SdoServer::poll`] must next run.
    pub fn next_deadline(&self) -> Option<Instant> {
        None
    }

    /// The deferred write finished; returns the response to send.
    pub fn complete_deferred(&mut self, result: Result<(), Abort>) -> Option<[u8; 8]> {
        let _ = result;
        None
    }
}
