//! SDO server (CiA 301 §7.2.4): expedited and segmented transfers on 600h/580h + node-ID.
//!
//! The server is a small state machine over 8-byte request payloads. Every value is read
//! whole when an upload starts and written whole when a download ends, through
//! [`ObjectAccess`], whose write is atomic: an aborted or timed-out transfer leaves the
//! dictionary untouched. Block transfer is not offered; its command specifiers abort with
//! 05040001h.

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

/// The largest value a transfer carries: the longest VISIBLE_STRING of any dictionary.
pub const MAX_VALUE: usize = 32;

/// How long the server waits for the client's next segment (D-SDO-3).
pub const TIMEOUT_US: u64 = 1_000_000;

#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum State {
    Idle,
    Upload,
    Download { size: Option<usize> },
}

/// The SDO server's transfer state.
#[derive(Clone)]
pub struct SdoServer {
    state: State,
    index: u16,
    sub: u8,
    toggle: u8,
    buf: [u8; MAX_VALUE],
    len: usize,
    pos: usize,
    deadline: Instant,
    deferred: Option<(u16, u8, [u8; 8])>,
}

impl Default for SdoServer {
    fn default() -> Self {
        SdoServer::new()
    }
}

/// An abort transfer payload (CiA 301 §7.2.4.3.17).
pub fn abort_frame(index: u16, sub: u8, abort: Abort) -> [u8; 8] {
    let i = index.to_le_bytes();
    let c = abort.0.to_le_bytes();
    [0x80, i[0], i[1], sub, c[0], c[1], c[2], c[3]]
}

fn header(cs: u8, index: u16, sub: u8) -> [u8; 8] {
    let i = index.to_le_bytes();
    [cs, i[0], i[1], sub, 0, 0, 0, 0]
}

impl SdoServer {
    /// An idle server.
    pub const fn new() -> SdoServer {
        SdoServer {
            state: State::Idle,
            index: 0,
            sub: 0,
            toggle: 0,
            buf: [0; MAX_VALUE],
            len: 0,
            pos: 0,
            deadline: Instant::ZERO,
            deferred: None,
        }
    }

    /// Drops any transfer in progress (NMT reset, STOPPED).
    pub fn reset(&mut self) {
        self.state = State::Idle;
        self.deferred = None;
    }

    fn fail(&mut self, index: u16, sub: u8, abort: Abort) -> Option<[u8; 8]> {
        self.state = State::Idle;
        Some(abort_frame(index, sub, abort))
    }

    /// Handles the payload of a request frame; returns the 8-byte response, if any.
    /// Requests shorter than 8 bytes are not SDO requests (CiA 301) and are ignored (D-SDO-2).
    pub fn on_request(&mut self, req: &[u8], now: Instant, dict: &mut impl ObjectAccess) -> Option<[u8; 8]> {
        let req: &[u8; 8] = req.try_into().ok()?;
        let cmd = req[0];
        let index = u16::from_le_bytes([req[1], req[2]]);
        let sub = req[3];
        match cmd >> 5 {
            // Initiate upload.
            2 => {
                self.state = State::Idle;
                self.upload(index, sub, now, dict)
            }
            // Initiate download.
            1 => {
                self.state = State::Idle;
                self.initiate_download(cmd, index, sub, req, now, dict)
            }
            // Upload segment.
            3 => match self.state {
                State::Upload => self.upload_segment(cmd, now),
                _ => self.fail(self.index, self.sub, Abort::INVALID_COMMAND),
            },
            // Download segment.
            0 => match self.state {
                State::Download { size } => self.download_segment(cmd, req, size, now, dict),
                _ => self.fail(self.index, self.sub, Abort::INVALID_COMMAND),
            },
            // Abort from the client: the transfer ends without an answer.
            4 => {
                self.state = State::Idle;
                None
            }
            // Block upload/download and anything else.
            _ => self.fail(index, sub, Abort::INVALID_COMMAND),
        }
    }

    fn upload(&mut self, index: u16, sub: u8, now: Instant, dict: &mut impl ObjectAccess) -> Option<[u8; 8]> {
        let size = match dict.read_size(index, sub) {
            Ok(size) => size,
            Err(abort) => return self.fail(index, sub, abort),
        };
        if size <= 4 {
            let mut out = header(0, index, sub);
            let n = match dict.read(index, sub, &mut out[4..8]) {
                Ok(n) => n,
                Err(abort) => return self.fail(index, sub, abort),
            };
            // Expedited, size indicated: e = 1, s = 1, n = 4 - size.
            out[0] = 0x43 | (((4 - n) as u8) << 2);
            return Some(out);
        }
        let n = match dict.read(index, sub, &mut self.buf[..size.min(MAX_VALUE)]) {
            Ok(n) => n,
            Err(abort) => return self.fail(index, sub, abort),
        };
        self.begin(State::Upload, index, sub, now);
        self.len = n;
        let mut out = header(0x41, index, sub);
        out[4..8].copy_from_slice(&(n as u32).to_le_bytes());
        Some(out)
    }

    fn upload_segment(&mut self, cmd: u8, now: Instant) -> Option<[u8; 8]> {
        let t = cmd & 0x10;
        if t != self.toggle {
            return self.fail(self.index, self.sub, Abort::TOGGLE);
        }
        let n = (self.len - self.pos).min(7);
        let mut out = [0u8; 8];
        out[1..1 + n].copy_from_slice(&self.buf[self.pos..self.pos + n]);
        self.pos += n;
        let last = self.pos == self.len;
        out[0] = t | (((7 - n) as u8) << 1) | last as u8;
        self.toggle ^= 0x10;
        self.deadline = now.add_micros(TIMEOUT_US);
        if last {
            self.state = State::Idle;
        }
        Some(out)
    }

    fn initiate_download(
        &mut self,
        cmd: u8,
        index: u16,
        sub: u8,
        req: &[u8; 8],
        now: Instant,
        dict: &mut impl ObjectAccess,
    ) -> Option<[u8; 8]> {
        let expedited = cmd & 0x02 != 0;
        let sized = cmd & 0x01 != 0;
        if expedited {
            // Without a size indication the client sends 4 bytes ("unspecified number").
            let n = if sized { 4 - ((cmd >> 2) & 0x03) as usize } else { 4 };
            return self.write(index, sub, &req[4..4 + n], now, dict);
        }
        let size = if sized { Some(u32::from_le_bytes([req[4], req[5], req[6], req[7]]) as usize) } else { None };
        if size.is_some_and(|s| s > MAX_VALUE) {
            return self.fail(index, sub, Abort::LENGTH_HIGH);
        }
        self.begin(State::Download { size }, index, sub, now);
        Some(header(0x60, index, sub))
    }

    fn download_segment(
        &mut self,
        cmd: u8,
        req: &[u8; 8],
        size: Option<usize>,
        now: Instant,
        dict: &mut impl ObjectAccess,
    ) -> Option<[u8; 8]> {
        let t = cmd & 0x10;
        if t != self.toggle {
            return self.fail(self.index, self.sub, Abort::TOGGLE);
        }
        let n = 7 - ((cmd >> 1) & 0x07) as usize;
        if self.len + n > MAX_VALUE {
            return self.fail(self.index, self.sub, Abort::LENGTH_HIGH);
        }
        self.buf[self.len..self.len + n].copy_from_slice(&req[1..1 + n]);
        self.len += n;
        self.toggle ^= 0x10;
        self.deadline = now.add_micros(TIMEOUT_US);
        if cmd & 0x01 == 0 {
            return Some([0x20 | t, 0, 0, 0, 0, 0, 0, 0]);
        }
        self.state = State::Idle;
        if size.is_some_and(|s| s != self.len) {
            return self.fail(self.index, self.sub, Abort::LENGTH_MISMATCH);
        }
        let (index, sub, len) = (self.index, self.sub, self.len);
        let data = self.buf;
        match dict.write(index, sub, &data[..len], now) {
            Ok(Written::Done) => Some([0x20 | t, 0, 0, 0, 0, 0, 0, 0]),
            Ok(Written::Deferred) => {
                self.deferred = Some((index, sub, [0x20 | t, 0, 0, 0, 0, 0, 0, 0]));
                None
            }
            Err(abort) => self.fail(index, sub, abort),
        }
    }

    fn write(
        &mut self,
        index: u16,
        sub: u8,
        data: &[u8],
        now: Instant,
        dict: &mut impl ObjectAccess,
    ) -> Option<[u8; 8]> {
        match dict.write(index, sub, data, now) {
            Ok(Written::Done) => Some(header(0x60, index, sub)),
            Ok(Written::Deferred) => {
                self.deferred = Some((index, sub, header(0x60, index, sub)));
                None
            }
            Err(abort) => self.fail(index, sub, abort),
        }
    }

    fn begin(&mut self, state: State, index: u16, sub: u8, now: Instant) {
        self.state = state;
        self.index = index;
        self.sub = sub;
        self.toggle = 0;
        self.len = 0;
        self.pos = 0;
        self.deadline = now.add_micros(TIMEOUT_US);
    }

    /// Aborts a transfer whose client fell silent; returns the abort frame payload.
    pub fn poll(&mut self, now: Instant) -> Option<[u8; 8]> {
        if self.state != State::Idle && now >= self.deadline {
            return self.fail(self.index, self.sub, Abort::TIMEOUT);
        }
        None
    }

    /// When [`SdoServer::poll`] must next run.
    pub fn next_deadline(&self) -> Option<Instant> {
        (self.state != State::Idle).then_some(self.deadline)
    }

    /// The deferred write finished; returns the response to send.
    pub fn complete_deferred(&mut self, result: Result<(), Abort>) -> Option<[u8; 8]> {
        let (index, sub, done) = self.deferred.take()?;
        Some(match result {
            Ok(()) => done,
            Err(abort) => abort_frame(index, sub, abort),
        })
    }
}
