//! SDO server (CiA 301 §7.2.4): expedited and segmented transfers on 600h/580h + node-ID.
//!
//! The server is a small state machine over the 8 data bytes of the requests
//! [`crate::wire::sdo`] describes, whatever carries them (CANopen 600h/580h, J1939
//! CAM21/CAM11); it reads them and writes its answers straight as bytes (D-ARCH-8). Every value is read
//! whole when an upload starts and written whole when a download ends, through
//! [`ObjectAccess`], whose write is atomic: an aborted or timed-out transfer leaves the
//! dictionary untouched. Block transfer is not offered; its command specifiers abort with
//! 05040001h.

use crate::abort::Abort;
use crate::od::value_of;
use crate::time::{Duration, Instant};
use crate::wire::sdo as wire;
use crate::wire::{exactly_8, u16_le, u32_le};

pub use crate::context::Written;

/// What the SDO server needs from the node: read and write by (index, sub).
pub trait ObjectAccess {
    /// Size in bytes of the value at (index, sub), after the access check for reading.
    fn read_size(&mut self, index: u16, sub: u8) -> Result<usize, Abort>;
    /// Copies the value at (index, sub) into `buf` (at least `read_size` bytes); returns its size.
    fn read(&mut self, index: u16, sub: u8, buf: &mut [u8]) -> Result<usize, Abort>;
    /// The value at (index, sub), after the access check for reading: its first four bytes
    /// (little-endian, the missing ones zero) and its size; a value longer than 4 bytes is in
    /// `buf` too. What an upload takes: one lookup, and no copy of a number.
    fn read_value(&mut self, index: u16, sub: u8, buf: &mut [u8; MAX_VALUE]) -> Result<(u32, usize), Abort> {
        let n = self.read(index, sub, buf)?;
        Ok((value_of(&buf[..n.min(4)]), n))
    }
    /// Checks and writes `data` to (index, sub). Nothing changes on `Err`.
    fn write(&mut self, index: u16, sub: u8, data: &[u8], now: Instant) -> Result<Written, Abort>;
    /// [`ObjectAccess::write`] of `len` bytes whose first four (at most) are `value`,
    /// little-endian, the rest of `value` zero: what every download writes, without a byte
    /// slice. No writable value is longer than 4 bytes, so the bytes past the fourth of a
    /// longer one are not given (the default passes zeros): such a write is refused whatever
    /// they are.
    fn write_value(&mut self, index: u16, sub: u8, value: u32, len: usize, now: Instant) -> Result<Written, Abort> {
        let mut data = [0u8; MAX_VALUE];
        data[..4].copy_from_slice(&value.to_le_bytes());
        self.write(index, sub, &data[..len.min(MAX_VALUE)], now)
    }
    /// Size in bytes of the value at (index, sub), whatever its access: how many bytes an
    /// expedited download without size indication writes (CiA 301; issue 13 point 12,
    /// D-SDO-8). By default the readable size.
    fn write_size(&mut self, index: u16, sub: u8) -> Result<usize, Abort> {
        self.read_size(index, sub)
    }
}

/// The largest value a transfer carries: the longest VISIBLE_STRING of any dictionary.
pub const MAX_VALUE: usize = 32;

/// How long the server waits for the client's next segment (D-SDO-3).
pub const TIMEOUT: Duration = Duration::from_secs(1);

/// No segmented transfer under way.
const IDLE: u8 = 0;
/// A segmented upload: `buf[..len]` goes out from `pos` on.
const UPLOAD: u8 = 1;
/// A segmented download: the segments gather in `buf[..len]`.
const DOWNLOAD: u8 = 2;

/// [`SdoServer::size`] of a segmented download that indicated none.
const NO_SIZE: u8 = u8::MAX;

/// The SDO server's transfer state.
#[derive(Clone)]
pub struct SdoServer {
    /// `IDLE`, `UPLOAD` or `DOWNLOAD`.
    state: u8,
    toggle: bool,
    /// Expedited transfers only (the AP10T, D-AP-21).
    expedited_only: bool,
    /// The size a segmented download indicated (at most [`MAX_VALUE`]), or `NO_SIZE`.
    size: u8,
    len: u8,
    pos: u8,
    sub: u8,
    index: u16,
    /// When the client last spoke in the transfer under way: it times out [`TIMEOUT`] later.
    spoke: Instant,
    /// The answer a write waits to give: (index, sub) for an abort instead, and the
    /// confirmation.
    deferred: Option<(u16, u8, [u8; 8])>,
    buf: [u8; MAX_VALUE],
}

impl Default for SdoServer {
    fn default() -> Self {
        SdoServer::new()
    }
}

/// An abort transfer payload (CiA 301 §7.2.4.3.17).
pub fn abort_frame(index: u16, sub: u8, abort: Abort) -> [u8; 8] {
    wire::with_mux(wire::ABORT, index, sub, abort.0)
}

impl SdoServer {
    /// An idle server.
    pub const fn new() -> SdoServer {
        SdoServer {
            state: IDLE,
            toggle: false,
            expedited_only: false,
            size: NO_SIZE,
            len: 0,
            pos: 0,
            sub: 0,
            index: 0,
            spoke: Instant::ZERO,
            deferred: None,
            buf: [0; MAX_VALUE],
        }
    }

    /// Serves expedited transfers only, as the AP10T's manual does ("exclusively via expedited
    /// Request/Response", D-AP-21): a segmented or unsized download request aborts with
    /// 05040001h, and a value longer than four bytes is uploaded expedited with its first four.
    pub fn set_expedited_only(&mut self, on: bool) {
        self.expedited_only = on;
    }

    /// Drops any transfer in progress (NMT reset, STOPPED).
    pub fn reset(&mut self) {
        self.state = IDLE;
        self.deferred = None;
    }

    /// Handles the data bytes of a request; returns the 8-byte response, if any. Requests
    /// that are not 8 bytes long are not SDO requests (CiA 301) and are ignored (D-SDO-2).
    ///
    /// The request is read straight from its bytes, the answer built straight as bytes: the
    /// [`crate::wire::sdo`] codec documents both, and its tests check this server's answers.
    /// Every refusal takes one path: the transfer ends and the abort names the request's
    /// (index, sub), or the transfer's for a segment.
    #[inline]
    pub fn on_request(&mut self, req: &[u8], now: Instant, dict: &mut impl ObjectAccess) -> Option<[u8; 8]> {
        self.on_request_as(self.expedited_only, req, now, dict)
    }

    /// [`SdoServer::on_request`] with the caller's word on [`SdoServer::set_expedited_only`]
    /// (it must be the value set): a node passes its device's constant, so a device that serves
    /// expedited transfers only (the AP10T) keeps no segmented transfer code and the others no
    /// test of the setting.
    #[inline]
    pub fn on_request_as(
        &mut self,
        expedited_only: bool,
        req: &[u8],
        now: Instant,
        dict: &mut impl ObjectAccess,
    ) -> Option<[u8; 8]> {
        let d = exactly_8(req)?;
        let cs = d[0];
        // A segment (ccs 0 and 3) carries no multiplexer: it continues the transfer's.
        let (index, sub) = match cs >> 5 {
            wire::CCS_DOWNLOAD_SEGMENT | wire::CCS_UPLOAD_SEGMENT => (self.index, self.sub),
            _ => (u16_le(d, 1), d[3]),
        };
        match self.serve(expedited_only, d, index, sub, now, dict) {
            Ok(answer) => answer,
            Err(abort) => {
                self.state = IDLE;
                Some(abort_frame(index, sub, abort))
            }
        }
    }

    #[inline]
    fn serve(
        &mut self,
        expedited_only: bool,
        d: &[u8; 8],
        index: u16,
        sub: u8,
        now: Instant,
        dict: &mut impl ObjectAccess,
    ) -> Result<Option<[u8; 8]>, Abort> {
        let cs = d[0];
        let ccs = cs >> 5;
        // One transfer at a time: while a write's answer waits (a 1010h save for the flash, the
        // AP10T's Auto-ID for its key) a new transfer is refused, so the waiting answer is the
        // one the shell's result completes (D-SDO-10).
        if self.deferred.is_some() && (ccs == wire::CCS_INITIATE_DOWNLOAD || ccs == wire::CCS_INITIATE_UPLOAD) {
            return Err(Abort::DEVICE_STATE);
        }
        // A download's value: (value, its length, the confirmation); every other request is
        // answered here.
        let (value, len, confirm) = match ccs {
            wire::CCS_INITIATE_DOWNLOAD => {
                self.state = IDLE;
                let confirm = wire::with_mux(wire::DOWNLOAD_INITIATED, index, sub, 0);
                if cs & wire::EXPEDITED == 0 {
                    if expedited_only {
                        return Err(Abort::INVALID_COMMAND);
                    }
                    return self.initiate_segmented(d, index, sub, now).map(|()| Some(confirm));
                }
                let len = if cs & wire::SIZED != 0 {
                    wire::expedited_len(cs)
                } else if expedited_only {
                    return Err(Abort::INVALID_COMMAND);
                } else {
                    // Without a size indication (22h) the object's size applies (CiA 301,
                    // D-SDO-8); 4 bytes where the dictionary names none (its write then answers
                    // the abort).
                    dict.write_size(index, sub).ok().filter(|n| (1..=4).contains(n)).unwrap_or(4)
                };
                (u32_le(d, 4) & wire::mask(len), len, confirm)
            }
            // No segmented transfer begins where expedited ones only are served.
            wire::CCS_DOWNLOAD_SEGMENT if !expedited_only && self.state == DOWNLOAD => {
                match self.download_segment(d, now)? {
                    Ok(whole) => whole,
                    Err(confirm) => return Ok(Some(confirm)),
                }
            }
            wire::CCS_INITIATE_UPLOAD => {
                self.state = IDLE;
                return self.upload(expedited_only, index, sub, now, dict).map(Some);
            }
            wire::CCS_UPLOAD_SEGMENT if !expedited_only && self.state == UPLOAD => {
                return self.upload_segment(cs, now).map(Some)
            }
            // Abort from the client: the transfer ends without an answer.
            wire::CCS_ABORT => {
                self.state = IDLE;
                return Ok(None);
            }
            // A segment outside its transfer, block upload/download and the reserved command.
            _ => return Err(Abort::INVALID_COMMAND),
        };
        // The one write: an expedited download's, or a segmented one's after its last segment.
        match dict.write_value(index, sub, value, len, now)? {
            Written::Done => Ok(Some(confirm)),
            Written::Deferred => {
                self.deferred = Some((index, sub, confirm));
                Ok(None)
            }
        }
    }

    /// An initiate segmented download (e = 0; the server takes segmented ones): the transfer
    /// begins, unless the size indicated is more than any value holds.
    fn initiate_segmented(&mut self, d: &[u8; 8], index: u16, sub: u8, now: Instant) -> Result<(), Abort> {
        let size = match d[0] & wire::SIZED {
            0 => NO_SIZE,
            _ => match u32_le(d, 4) {
                s if s > MAX_VALUE as u32 => return Err(Abort::LENGTH_HIGH),
                s => s as u8,
            },
        };
        self.begin(DOWNLOAD, index, sub, now);
        self.size = size;
        Ok(())
    }

    #[inline]
    fn upload(
        &mut self,
        expedited_only: bool,
        index: u16,
        sub: u8,
        now: Instant,
        dict: &mut impl ObjectAccess,
    ) -> Result<[u8; 8], Abort> {
        // A value of 4 bytes or fewer goes out expedited; a longer one is read whole and sent
        // segmented.
        let (value, mut n) = dict.read_value(index, sub, &mut self.buf)?;
        if expedited_only {
            n = n.min(4);
        }
        if n <= 4 {
            return Ok(wire::upload_expedited(index, sub, value, n));
        }
        self.begin(UPLOAD, index, sub, now);
        self.len = n as u8;
        Ok(wire::with_mux(wire::UPLOAD_SEGMENTED, index, sub, n as u32))
    }

    fn upload_segment(&mut self, cs: u8, now: Instant) -> Result<[u8; 8], Abort> {
        let toggle = cs & wire::TOGGLE;
        self.step_toggle(toggle, now)?;
        let (pos, len) = (self.pos as usize, self.len as usize);
        let n = (len - pos).min(7);
        let mut out = [0u8; 8];
        out[1..1 + n].copy_from_slice(&self.buf[pos..pos + n]);
        self.pos += n as u8;
        let last = pos + n == len;
        if last {
            self.state = IDLE;
        }
        out[0] = toggle | ((7 - n as u8) << 1) | last as u8;
        Ok(out)
    }

    /// A download segment: its bytes join the value. `Ok(Err(confirm))` while more follow;
    /// after the last one, `Ok(Ok((value, len, confirm)))` to write.
    #[allow(clippy::type_complexity)]
    fn download_segment(&mut self, d: &[u8; 8], now: Instant) -> Result<Result<(u32, usize, [u8; 8]), [u8; 8]>, Abort> {
        let cs = d[0];
        let toggle = cs & wire::TOGGLE;
        self.step_toggle(toggle, now)?;
        let n = 7 - ((cs >> 1) & 0x07) as usize;
        let len = self.len as usize;
        if len + n > MAX_VALUE {
            return Err(Abort::LENGTH_HIGH);
        }
        self.buf[len..len + n].copy_from_slice(&d[1..1 + n]);
        let len = len + n;
        self.len = len as u8;
        let confirm = [wire::DOWNLOAD_SEGMENT | toggle, 0, 0, 0, 0, 0, 0, 0];
        if cs & wire::LAST == 0 {
            return Ok(Err(confirm));
        }
        self.state = IDLE;
        if self.size != NO_SIZE && self.size as usize != len {
            return Err(Abort::LENGTH_MISMATCH);
        }
        Ok(Ok((value_of(&self.buf[..len]), len, confirm)))
    }

    /// A segment with toggle bit `toggle` (its bit in the command byte): the one expected, or
    /// the toggle abort. The next one must alternate, within [`TIMEOUT`].
    fn step_toggle(&mut self, toggle: u8, now: Instant) -> Result<(), Abort> {
        if (toggle != 0) != self.toggle {
            return Err(Abort::TOGGLE);
        }
        self.toggle = !self.toggle;
        self.spoke = now;
        Ok(())
    }

    fn begin(&mut self, state: u8, index: u16, sub: u8, now: Instant) {
        self.state = state;
        self.index = index;
        self.sub = sub;
        self.toggle = false;
        self.len = 0;
        self.pos = 0;
        self.spoke = now;
    }

    /// Aborts a transfer whose client fell silent; returns the abort frame payload.
    pub fn poll(&mut self, now: Instant) -> Option<[u8; 8]> {
        if self.state != IDLE && now >= self.spoke + TIMEOUT {
            self.state = IDLE;
            return Some(abort_frame(self.index, self.sub, Abort::TIMEOUT));
        }
        None
    }

    /// When [`SdoServer::poll`] must next run.
    pub fn next_deadline(&self) -> Option<Instant> {
        (self.state != IDLE).then_some(self.spoke + TIMEOUT)
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

#[cfg(test)]
mod tests {
    use super::*;

    /// One 4-byte read-write value at 2000h.00 and a 10-byte read-only string at 2001h.00.
    struct Fake {
        value: u32,
    }

    const NAME: &[u8] = b"0123456789";

    impl ObjectAccess for Fake {
        fn read_size(&mut self, index: u16, sub: u8) -> Result<usize, Abort> {
            match (index, sub) {
                (0x2000, 0) => Ok(4),
                (0x2001, 0) => Ok(NAME.len()),
                (0x2000 | 0x2001, _) => Err(Abort::NO_SUBINDEX),
                _ => Err(Abort::NO_OBJECT),
            }
        }
        fn read(&mut self, index: u16, sub: u8, buf: &mut [u8]) -> Result<usize, Abort> {
            let n = self.read_size(index, sub)?;
            if index == 0x2000 {
                buf[..4].copy_from_slice(&self.value.to_le_bytes());
            } else {
                buf[..n].copy_from_slice(NAME);
            }
            Ok(n)
        }
        fn write(&mut self, index: u16, sub: u8, data: &[u8], _now: Instant) -> Result<Written, Abort> {
            self.read_size(index, sub)?;
            if index != 0x2000 {
                return Err(Abort::READ_ONLY);
            }
            let v: [u8; 4] = data.try_into().map_err(|_| Abort::LENGTH_MISMATCH)?;
            self.value = u32::from_le_bytes(v);
            Ok(Written::Done)
        }
    }

    fn at(ms: u64) -> Instant {
        Instant::from_millis(ms)
    }

    #[test]
    fn expedited_only_aborts_segmented_and_unsized_requests_and_cuts_long_values() {
        let mut d = Fake { value: 7 };
        let mut s = SdoServer::new();
        s.set_expedited_only(true);
        let t = Instant::ZERO;
        // Initiate segmented download (21h, 20h) and unsized expedited (22h): 05040001h.
        for cmd in [0x21, 0x20, 0x22] {
            assert_eq!(
                s.on_request(&[cmd, 0x00, 0x20, 0x00, 4, 0, 0, 0], t, &mut d),
                Some([0x80, 0x00, 0x20, 0x00, 0x01, 0x00, 0x04, 0x05])
            );
        }
        assert_eq!(d.value, 7);
        // Sized expedited still writes.
        assert_eq!(
            s.on_request(&[0x23, 0x00, 0x20, 0x00, 9, 0, 0, 0], t, &mut d),
            Some([0x60, 0x00, 0x20, 0, 0, 0, 0, 0])
        );
        assert_eq!(d.value, 9);
        // The 10-byte string: its first four bytes, expedited.
        assert_eq!(
            s.on_request(&[0x40, 0x01, 0x20, 0x00, 0, 0, 0, 0], t, &mut d),
            Some([0x43, 0x01, 0x20, 0x00, b'0', b'1', b'2', b'3'])
        );
        // No segment follows.
        assert_eq!(s.on_request(&[0x60, 0, 0, 0, 0, 0, 0, 0], t, &mut d).map(|r| r[0]), Some(0x80));
    }

    #[test]
    fn segmented_upload_of_ten_bytes_in_two_segments() {
        let (mut s, mut d) = (SdoServer::new(), Fake { value: 0 });
        let r = s.on_request(&[0x40, 0x01, 0x20, 0, 0, 0, 0, 0], at(0), &mut d);
        assert_eq!(r, Some([0x41, 0x01, 0x20, 0, 10, 0, 0, 0]));
        let r = s.on_request(&[0x60, 0, 0, 0, 0, 0, 0, 0], at(1), &mut d);
        assert_eq!(r, Some([0x00, b'0', b'1', b'2', b'3', b'4', b'5', b'6']));
        assert_eq!(s.next_deadline(), Some(at(1001)));
        let r = s.on_request(&[0x70, 0, 0, 0, 0, 0, 0, 0], at(2), &mut d);
        assert_eq!(r, Some([0x19, b'7', b'8', b'9', 0, 0, 0, 0]));
        assert_eq!(s.next_deadline(), None);
    }

    #[test]
    fn segmented_download_in_two_segments_without_size() {
        let (mut s, mut d) = (SdoServer::new(), Fake { value: 0 });
        assert_eq!(
            s.on_request(&[0x20, 0x00, 0x20, 0, 0, 0, 0, 0], at(0), &mut d),
            Some([0x60, 0, 0x20, 0, 0, 0, 0, 0])
        );
        assert_eq!(s.on_request(&[0x0A, 1, 2, 0, 0, 0, 0, 0], at(0), &mut d), Some([0x20, 0, 0, 0, 0, 0, 0, 0]));
        assert_eq!(d.value, 0, "nothing is written before the last segment");
        assert_eq!(s.on_request(&[0x1B, 3, 4, 0, 0, 0, 0, 0], at(0), &mut d), Some([0x30, 0, 0, 0, 0, 0, 0, 0]));
        assert_eq!(d.value, 0x0403_0201);
    }

    #[test]
    fn oversized_downloads_abort_before_any_write() {
        let (mut s, mut d) = (SdoServer::new(), Fake { value: 7 });
        let r = s.on_request(&[0x21, 0x00, 0x20, 0, 33, 0, 0, 0], at(0), &mut d);
        assert_eq!(r, Some(abort_frame(0x2000, 0, Abort::LENGTH_HIGH)));
        s.on_request(&[0x20, 0x00, 0x20, 0, 0, 0, 0, 0], at(0), &mut d);
        for i in 0..4u8 {
            assert!(s.on_request(&[i << 4 & 0x10, 1, 2, 3, 4, 5, 6, 7], at(0), &mut d).unwrap()[0] != 0x80);
        }
        let r = s.on_request(&[0x00, 1, 2, 3, 4, 5, 6, 7], at(0), &mut d);
        assert_eq!(r, Some(abort_frame(0x2000, 0, Abort::LENGTH_HIGH)));
        assert_eq!(d.value, 7);
    }

    #[test]
    fn a_transfer_while_an_answer_waits_is_refused_and_the_waiting_answer_kept() {
        /// A 4-byte value at 2000h whose writes wait for the shell while `defer` is set.
        struct Waiting {
            value: u32,
            defer: bool,
        }
        impl ObjectAccess for Waiting {
            fn read_size(&mut self, _: u16, _: u8) -> Result<usize, Abort> {
                Ok(4)
            }
            fn read(&mut self, _: u16, _: u8, buf: &mut [u8]) -> Result<usize, Abort> {
                buf[..4].copy_from_slice(&self.value.to_le_bytes());
                Ok(4)
            }
            fn write(&mut self, _: u16, _: u8, data: &[u8], _: Instant) -> Result<Written, Abort> {
                self.value = u32::from_le_bytes(data.try_into().map_err(|_| Abort::LENGTH_MISMATCH)?);
                Ok(if self.defer { Written::Deferred } else { Written::Done })
            }
        }
        let mut s = SdoServer::new();
        let mut d = Waiting { value: 0, defer: true };
        assert_eq!(s.on_request(&[0x23, 0x00, 0x20, 0, 1, 2, 3, 4], at(0), &mut d), None);
        d.defer = false;
        let refused = s.on_request(&[0x40, 0x01, 0x20, 0, 0, 0, 0, 0], at(0), &mut d);
        assert_eq!(refused, Some(abort_frame(0x2001, 0, Abort::DEVICE_STATE)));
        let refused = s.on_request(&[0x23, 0x00, 0x20, 0, 9, 9, 9, 9], at(0), &mut d);
        assert_eq!(refused, Some(abort_frame(0x2000, 0, Abort::DEVICE_STATE)));
        assert_eq!(d.value, 0x0403_0201, "the refused write changed nothing");
        assert_eq!(s.complete_deferred(Ok(())), Some([0x60, 0x00, 0x20, 0, 0, 0, 0, 0]));
        assert_eq!(s.on_request(&[0x40, 0x00, 0x20, 0, 0, 0, 0, 0], at(0), &mut d).map(|a| a[0]), Some(0x43));
    }

    #[test]
    fn deferred_writes_answer_when_the_shell_is_done() {
        struct Saving;
        impl ObjectAccess for Saving {
            fn read_size(&mut self, _: u16, _: u8) -> Result<usize, Abort> {
                Ok(4)
            }
            fn read(&mut self, _: u16, _: u8, _: &mut [u8]) -> Result<usize, Abort> {
                Ok(4)
            }
            fn write(&mut self, _: u16, _: u8, _: &[u8], _: Instant) -> Result<Written, Abort> {
                Ok(Written::Deferred)
            }
        }
        let mut s = SdoServer::new();
        assert_eq!(s.on_request(&[0x23, 0x10, 0x10, 1, b's', b'a', b'v', b'e'], at(0), &mut Saving), None);
        assert_eq!(s.complete_deferred(Ok(())), Some([0x60, 0x10, 0x10, 1, 0, 0, 0, 0]));
        assert_eq!(s.complete_deferred(Ok(())), None);
        s.on_request(&[0x23, 0x10, 0x10, 1, b's', b'a', b'v', b'e'], at(0), &mut Saving);
        assert_eq!(s.complete_deferred(Err(Abort::CANNOT_STORE)), Some(abort_frame(0x1010, 1, Abort::CANNOT_STORE)));
    }

    #[test]
    fn short_frames_are_not_requests() {
        let (mut s, mut d) = (SdoServer::new(), Fake { value: 0 });
        assert_eq!(s.on_request(&[0x40, 0x00, 0x20, 0], at(0), &mut d), None);
    }

    mod fuzz {
        use super::*;
        use proptest::prelude::*;

        proptest! {
            /// Any sequence of requests gets a well-formed answer or none, never a panic, and
            /// the value only ever holds what a complete write carried.
            #[test]
            fn arbitrary_requests_never_panic(reqs in proptest::collection::vec(proptest::array::uniform8(any::<u8>()), 1..40)) {
                let (mut s, mut d) = (SdoServer::new(), Fake { value: 0 });
                for (i, r) in reqs.iter().enumerate() {
                    if let Some(resp) = s.on_request(r, at(i as u64 * 10), &mut d) {
                        prop_assert!((resp[0] >> 5) <= 4, "{resp:02X?}");
                    }
                    let _ = s.poll(at(i as u64 * 10 + 5));
                }
            }
        }
    }
}
