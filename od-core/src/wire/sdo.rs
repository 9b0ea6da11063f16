//! SDO (CiA 301 §7.2.4.3): the expedited and segmented transfer messages, over the 8 data
//! bytes alone. CANopen carries them on 600h/580h + node-ID; J1939 carries the same bytes in
//! CAM21/CAM11 (the WV58MR), so one codec serves both.
//!
//! Byte 0 is the command specifier: bits 7..5 the command (`ccs` from the client, `scs` from
//! the server), the other bits its flags. The multiplexer (index LSB first, sub-index) is in
//! bytes 1..3 of the initiate and abort messages; segments carry up to 7 bytes in 1..7.

use super::{exactly_8, u16_le, u32_le};

/// A message from the client (what a server receives).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum ClientRequest {
    /// ccs 2: initiate upload of (index, sub).
    InitiateUpload {
        /// Index.
        index: u16,
        /// Sub-index.
        sub: u8,
    },
    /// ccs 1: initiate download to (index, sub).
    InitiateDownload {
        /// Index.
        index: u16,
        /// Sub-index.
        sub: u8,
        /// The data (expedited) or the announced size (segmented).
        kind: Initiate,
    },
    /// ccs 3: upload segment request.
    UploadSegment {
        /// Toggle bit.
        toggle: bool,
    },
    /// ccs 0: download segment.
    DownloadSegment {
        /// Toggle bit.
        toggle: bool,
        /// Segment data: `data[..len]` is valid, the rest zero on emit.
        data: [u8; 7],
        /// Valid bytes, 0..=7 (CiA 301 allows 0 only in theory: n = 7 - len).
        len: u8,
        /// c bit: no more segments.
        last: bool,
    },
    /// ccs 4: the client aborts the transfer (no answer).
    Abort {
        /// Index.
        index: u16,
        /// Sub-index.
        sub: u8,
        /// Abort code.
        code: u32,
    },
    /// ccs 5, 6, 7: block upload, block download and the reserved command, which a server
    /// without block transfers refuses (05040001h) for (index, sub).
    Unsupported {
        /// The command specifier's bits 7..5.
        ccs: u8,
        /// Index.
        index: u16,
        /// Sub-index.
        sub: u8,
    },
}

/// What an initiate download carries.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Initiate {
    /// e = 1, s = 1: the value itself, `data[..len]`.
    Expedited {
        /// Bytes 4..7.
        data: [u8; 4],
        /// Valid bytes, 1..=4.
        len: u8,
    },
    /// e = 1, s = 0: the value in bytes 4..7 with no size indicated; how many of them count is
    /// the server's to know (the object's size, CiA 301).
    ExpeditedUnsized {
        /// Bytes 4..7.
        data: [u8; 4],
    },
    /// e = 0: segments follow; `size` when the client indicates it (s = 1).
    Segmented {
        /// The announced size in bytes.
        size: Option<u32>,
    },
}

/// A message from the server (what a client receives).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum ServerResponse {
    /// scs 2, e = 1, s = 1: the value of (index, sub), `data[..len]`.
    UploadExpedited {
        /// Index.
        index: u16,
        /// Sub-index.
        sub: u8,
        /// Bytes 4..7.
        data: [u8; 4],
        /// Valid bytes, 1..=4.
        len: u8,
    },
    /// scs 2, e = 0, s = 1: the value of (index, sub) follows in segments, `size` bytes.
    UploadSegmented {
        /// Index.
        index: u16,
        /// Sub-index.
        sub: u8,
        /// Size in bytes.
        size: u32,
    },
    /// scs 0: one upload segment.
    UploadSegment {
        /// Toggle bit.
        toggle: bool,
        /// `data[..len]` is valid, the rest zero.
        data: [u8; 7],
        /// Valid bytes, 0..=7.
        len: u8,
        /// c bit: the last segment.
        last: bool,
    },
    /// scs 3: initiate download confirmed (and, for an expedited one, written).
    DownloadInitiated {
        /// Index.
        index: u16,
        /// Sub-index.
        sub: u8,
    },
    /// scs 1: download segment received.
    DownloadSegment {
        /// Toggle bit of the segment confirmed.
        toggle: bool,
    },
    /// scs 4: abort transfer.
    Abort {
        /// Index.
        index: u16,
        /// Sub-index.
        sub: u8,
        /// Abort code.
        code: u32,
    },
}

/// ccs 0: download segment.
pub const CCS_DOWNLOAD_SEGMENT: u8 = 0;
/// ccs 1: initiate download.
pub const CCS_INITIATE_DOWNLOAD: u8 = 1;
/// ccs 2: initiate upload.
pub const CCS_INITIATE_UPLOAD: u8 = 2;
/// ccs 3: upload segment.
pub const CCS_UPLOAD_SEGMENT: u8 = 3;
/// ccs 4: abort transfer.
pub const CCS_ABORT: u8 = 4;

/// Initiate download, command byte: e, the value is in bytes 4..7.
pub const EXPEDITED: u8 = 0x02;
/// Initiate download, command byte: s, the size is indicated.
pub const SIZED: u8 = 0x01;
/// Segment command byte: t, the toggle bit.
pub const TOGGLE: u8 = 0x10;
/// Segment command byte: c, no more segments.
pub const LAST: u8 = 0x01;

/// Server command byte of [`ServerResponse::DownloadInitiated`].
pub const DOWNLOAD_INITIATED: u8 = 0x60;
/// Server command byte of [`ServerResponse::UploadSegmented`] (s = 1).
pub const UPLOAD_SEGMENTED: u8 = 0x41;
/// Server command byte of [`ServerResponse::DownloadSegment`], without its toggle bit.
pub const DOWNLOAD_SEGMENT: u8 = 0x20;
/// Command byte of an abort transfer.
pub const ABORT: u8 = 0x80;

/// A message of a command byte, the multiplexer and four bytes `tail` (little-endian): every
/// initiate message and the abort.
#[inline]
pub const fn with_mux(cs: u8, index: u16, sub: u8, tail: u32) -> [u8; 8] {
    (cs as u64 | (index as u64) << 8 | (sub as u64) << 24 | (tail as u64) << 32).to_le_bytes()
}

/// How many bytes of an expedited initiate download with size indicated (command byte `cs`)
/// are valid: 4 - n, 1..=4.
#[inline]
pub const fn expedited_len(cs: u8) -> usize {
    4 - ((cs >> 2) & 0x03) as usize
}

/// The mask of the first `len` bytes (1..=4; 0 counts as 1, as an expedited message has at
/// least one) of a little-endian u32.
#[inline]
pub const fn mask(len: usize) -> u32 {
    let len = if len == 0 {
        1
    } else if len > 4 {
        4
    } else {
        len
    };
    u32::MAX >> (8 * (4 - len as u32))
}

/// [`ServerResponse::UploadExpedited`] of the first `len` bytes (1..=4; 0 counts as 1) of
/// `value`, little-endian.
#[inline]
pub const fn upload_expedited(index: u16, sub: u8, value: u32, len: usize) -> [u8; 8] {
    let len = if len == 0 {
        1
    } else if len > 4 {
        4
    } else {
        len
    };
    with_mux(0x43 | ((4 - len as u8) << 2), index, sub, value & mask(len))
}

#[inline]
fn mux(d: &[u8; 8]) -> (u16, u8) {
    (u16_le(d, 1), d[3])
}

#[inline]
fn mux_and(cs: u8, index: u16, sub: u8, tail: [u8; 4]) -> [u8; 8] {
    with_mux(cs, index, sub, u32::from_le_bytes(tail))
}

fn segment(cs: u8, data: &[u8; 7], len: u8) -> [u8; 8] {
    let mut out = [cs, 0, 0, 0, 0, 0, 0, 0];
    let n = len.min(7) as usize;
    out[1..1 + n].copy_from_slice(&data[..n]);
    out
}

fn segment_data(d: &[u8; 8], len: u8) -> [u8; 7] {
    let mut data = [0u8; 7];
    let n = len as usize;
    data[..n].copy_from_slice(&d[1..1 + n]);
    data
}

/// `data[..len]` (len 1..=4) and the rest zero, without a variable-length copy.
#[inline]
fn expedited_tail(data: [u8; 4], len: u8) -> [u8; 4] {
    let keep = u32::MAX >> (8 * (4 - len.clamp(1, 4) as u32));
    (u32::from_le_bytes(data) & keep).to_le_bytes()
}

impl ClientRequest {
    /// Parses the data bytes of a request; `None` unless there are exactly 8 (D-SDO-2).
    #[inline]
    pub fn parse(data: &[u8]) -> Option<ClientRequest> {
        let d = exactly_8(data)?;
        let cs = d[0];
        let (index, sub) = mux(d);
        Some(match cs >> 5 {
            0 => {
                let len = 7 - ((cs >> 1) & 0x07);
                ClientRequest::DownloadSegment {
                    toggle: cs & TOGGLE != 0,
                    data: segment_data(d, len),
                    len,
                    last: cs & 0x01 != 0,
                }
            }
            1 => {
                let kind = if cs & 0x03 == 0x03 {
                    let len = 4 - ((cs >> 2) & 0x03);
                    Initiate::Expedited { data: expedited_tail([d[4], d[5], d[6], d[7]], len), len }
                } else if cs & 0x02 != 0 {
                    Initiate::ExpeditedUnsized { data: [d[4], d[5], d[6], d[7]] }
                } else {
                    Initiate::Segmented { size: (cs & 0x01 != 0).then(|| u32_le(d, 4)) }
                };
                ClientRequest::InitiateDownload { index, sub, kind }
            }
            2 => ClientRequest::InitiateUpload { index, sub },
            3 => ClientRequest::UploadSegment { toggle: cs & TOGGLE != 0 },
            4 => ClientRequest::Abort { index, sub, code: u32_le(d, 4) },
            ccs => ClientRequest::Unsupported { ccs, index, sub },
        })
    }

    /// The 8 data bytes a client sends (reserved bits and bytes zero).
    #[inline]
    pub fn emit(&self) -> [u8; 8] {
        match *self {
            ClientRequest::InitiateUpload { index, sub } => mux_and(0x40, index, sub, [0; 4]),
            ClientRequest::InitiateDownload { index, sub, kind: Initiate::Expedited { data, len } } => {
                let len = len.clamp(1, 4);
                mux_and(0x23 | ((4 - len) << 2), index, sub, expedited_tail(data, len))
            }
            ClientRequest::InitiateDownload { index, sub, kind: Initiate::ExpeditedUnsized { data } } => {
                mux_and(0x22, index, sub, data)
            }
            ClientRequest::InitiateDownload { index, sub, kind: Initiate::Segmented { size } } => match size {
                Some(s) => mux_and(0x21, index, sub, s.to_le_bytes()),
                None => mux_and(0x20, index, sub, [0; 4]),
            },
            ClientRequest::UploadSegment { toggle } => [0x60 | if toggle { TOGGLE } else { 0 }, 0, 0, 0, 0, 0, 0, 0],
            ClientRequest::DownloadSegment { toggle, data, len, last } => {
                let len = len.min(7);
                let cs = if toggle { TOGGLE } else { 0 } | ((7 - len) << 1) | last as u8;
                segment(cs, &data, len)
            }
            ClientRequest::Abort { index, sub, code } => mux_and(0x80, index, sub, code.to_le_bytes()),
            ClientRequest::Unsupported { ccs, index, sub } => mux_and((ccs.clamp(5, 7)) << 5, index, sub, [0; 4]),
        }
    }
}

impl ServerResponse {
    /// The 8 data bytes the server sends (reserved bits and bytes zero).
    #[inline]
    pub fn emit(&self) -> [u8; 8] {
        // Every response but the segments is a command byte, the multiplexer and four bytes.
        let (cs, index, sub, tail) = match *self {
            ServerResponse::UploadExpedited { index, sub, data, len } => {
                return upload_expedited(index, sub, u32::from_le_bytes(data), len as usize);
            }
            ServerResponse::UploadSegmented { index, sub, size } => (UPLOAD_SEGMENTED, index, sub, size),
            ServerResponse::DownloadInitiated { index, sub } => (DOWNLOAD_INITIATED, index, sub, 0),
            ServerResponse::Abort { index, sub, code } => (ABORT, index, sub, code),
            ServerResponse::UploadSegment { toggle, data, len, last } => {
                let len = len.min(7);
                let cs = if toggle { TOGGLE } else { 0 } | ((7 - len) << 1) | last as u8;
                return segment(cs, &data, len);
            }
            ServerResponse::DownloadSegment { toggle } => {
                return [0x20 | if toggle { TOGGLE } else { 0 }, 0, 0, 0, 0, 0, 0, 0];
            }
        };
        with_mux(cs, index, sub, tail)
    }

    /// Parses the data bytes of a response (what a client reads); `None` unless there are
    /// exactly 8 and the command is one a server sends. An upload response without size or
    /// without the expedited bit is not produced by this server and is refused.
    pub fn parse(data: &[u8]) -> Option<ServerResponse> {
        let d = exactly_8(data)?;
        let cs = d[0];
        let (index, sub) = mux(d);
        Some(match cs >> 5 {
            0 => {
                let len = 7 - ((cs >> 1) & 0x07);
                ServerResponse::UploadSegment {
                    toggle: cs & TOGGLE != 0,
                    data: segment_data(d, len),
                    len,
                    last: cs & 0x01 != 0,
                }
            }
            1 => ServerResponse::DownloadSegment { toggle: cs & TOGGLE != 0 },
            2 => match cs & 0x03 {
                0x03 => {
                    let len = 4 - ((cs >> 2) & 0x03);
                    ServerResponse::UploadExpedited {
                        index,
                        sub,
                        data: expedited_tail([d[4], d[5], d[6], d[7]], len),
                        len,
                    }
                }
                0x01 => ServerResponse::UploadSegmented { index, sub, size: u32_le(d, 4) },
                _ => return None,
            },
            3 => ServerResponse::DownloadInitiated { index, sub },
            4 => ServerResponse::Abort { index, sub, code: u32_le(d, 4) },
            _ => return None,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn client_requests_byte_by_byte() {
        assert_eq!(
            ClientRequest::parse(&[0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0]),
            Some(ClientRequest::InitiateUpload { index: 0x1018, sub: 1 })
        );
        // 2Bh: expedited, size indicated, n = 2: two bytes.
        assert_eq!(
            ClientRequest::parse(&[0x2B, 0x17, 0x10, 0, 0xE8, 0x03, 0xAA, 0xBB]),
            Some(ClientRequest::InitiateDownload {
                index: 0x1017,
                sub: 0,
                kind: Initiate::Expedited { data: [0xE8, 0x03, 0, 0], len: 2 }
            })
        );
        // 22h: expedited without size: four bytes, the server knows how many count.
        assert_eq!(
            ClientRequest::parse(&[0x22, 0x10, 0x10, 1, b's', b'a', b'v', b'e']),
            Some(ClientRequest::InitiateDownload {
                index: 0x1010,
                sub: 1,
                kind: Initiate::ExpeditedUnsized { data: *b"save" }
            })
        );
        assert_eq!(
            ClientRequest::parse(&[0x21, 0x08, 0x10, 0, 10, 0, 0, 0]),
            Some(ClientRequest::InitiateDownload {
                index: 0x1008,
                sub: 0,
                kind: Initiate::Segmented { size: Some(10) }
            })
        );
        assert_eq!(
            ClientRequest::parse(&[0x20, 0x08, 0x10, 0, 10, 0, 0, 0]),
            Some(ClientRequest::InitiateDownload { index: 0x1008, sub: 0, kind: Initiate::Segmented { size: None } })
        );
        assert_eq!(
            ClientRequest::parse(&[0x70, 9, 9, 9, 9, 9, 9, 9]),
            Some(ClientRequest::UploadSegment { toggle: true })
        );
        // 0Bh: toggle 0, n = 5 (two bytes), last.
        assert_eq!(
            ClientRequest::parse(&[0x0B, 1, 2, 9, 9, 9, 9, 9]),
            Some(ClientRequest::DownloadSegment { toggle: false, data: [1, 2, 0, 0, 0, 0, 0], len: 2, last: true })
        );
        assert_eq!(
            ClientRequest::parse(&[0x80, 0x00, 0x20, 1, 0x00, 0x00, 0x04, 0x05]),
            Some(ClientRequest::Abort { index: 0x2000, sub: 1, code: 0x0504_0000 })
        );
        for cs in [0xA0, 0xC0, 0xE0] {
            assert_eq!(
                ClientRequest::parse(&[cs, 0x00, 0x20, 3, 0, 0, 0, 0]),
                Some(ClientRequest::Unsupported { ccs: cs >> 5, index: 0x2000, sub: 3 })
            );
        }
        assert_eq!(ClientRequest::parse(&[0x40, 0x00, 0x20, 0]), None);
        assert_eq!(ClientRequest::parse(&[0x40, 0x00, 0x20, 0, 0, 0, 0, 0, 0]), None);
        assert_eq!(ClientRequest::parse(&[]), None);
    }

    #[test]
    fn server_responses_byte_by_byte() {
        let r = |x: ServerResponse| x.emit();
        assert_eq!(
            r(ServerResponse::UploadExpedited { index: 0x1018, sub: 1, data: [0x95, 1, 0, 0], len: 4 }),
            [0x43, 0x18, 0x10, 1, 0x95, 1, 0, 0]
        );
        assert_eq!(
            r(ServerResponse::UploadExpedited { index: 0x1001, sub: 0, data: [0x81, 0xFF, 0xFF, 0xFF], len: 1 }),
            [0x4F, 0x01, 0x10, 0, 0x81, 0, 0, 0]
        );
        assert_eq!(
            r(ServerResponse::UploadSegmented { index: 0x1008, sub: 0, size: 5 }),
            [0x41, 8, 0x10, 0, 5, 0, 0, 0]
        );
        // D-SDO-4: five bytes in the last segment are 05h (n = 2, c = 1).
        assert_eq!(
            r(ServerResponse::UploadSegment { toggle: false, data: *b"SGH10\xFF\xFF", len: 5, last: true }),
            [0x05, b'S', b'G', b'H', b'1', b'0', 0, 0]
        );
        assert_eq!(r(ServerResponse::DownloadInitiated { index: 0x1017, sub: 0 }), [0x60, 0x17, 0x10, 0, 0, 0, 0, 0]);
        assert_eq!(r(ServerResponse::DownloadSegment { toggle: true }), [0x30, 0, 0, 0, 0, 0, 0, 0]);
        assert_eq!(
            r(ServerResponse::Abort { index: 0x6000, sub: 0, code: 0x0609_0030 }),
            [0x80, 0, 0x60, 0, 0x30, 0, 0x09, 0x06]
        );
    }

    fn client() -> impl Strategy<Value = ClientRequest> {
        let mux = (any::<u16>(), any::<u8>());
        prop_oneof![
            mux.prop_map(|(index, sub)| ClientRequest::InitiateUpload { index, sub }),
            (mux, any::<[u8; 4]>(), 1u8..=4).prop_map(|((index, sub), mut data, len)| {
                data[len as usize..].fill(0);
                ClientRequest::InitiateDownload { index, sub, kind: Initiate::Expedited { data, len } }
            }),
            (mux, proptest::option::of(any::<u32>())).prop_map(|((index, sub), size)| {
                ClientRequest::InitiateDownload { index, sub, kind: Initiate::Segmented { size } }
            }),
            any::<bool>().prop_map(|toggle| ClientRequest::UploadSegment { toggle }),
            (any::<bool>(), any::<[u8; 7]>(), 0u8..=7, any::<bool>()).prop_map(|(toggle, mut data, len, last)| {
                data[len as usize..].fill(0);
                ClientRequest::DownloadSegment { toggle, data, len, last }
            }),
            (mux, any::<u32>()).prop_map(|((index, sub), code)| ClientRequest::Abort { index, sub, code }),
            (5u8..=7, mux).prop_map(|(ccs, (index, sub))| ClientRequest::Unsupported { ccs, index, sub }),
        ]
    }

    fn server() -> impl Strategy<Value = ServerResponse> {
        let mux = (any::<u16>(), any::<u8>());
        prop_oneof![
            (mux, any::<[u8; 4]>(), 1u8..=4).prop_map(|((index, sub), mut data, len)| {
                data[len as usize..].fill(0);
                ServerResponse::UploadExpedited { index, sub, data, len }
            }),
            (mux, any::<u32>()).prop_map(|((index, sub), size)| ServerResponse::UploadSegmented { index, sub, size }),
            (any::<bool>(), any::<[u8; 7]>(), 0u8..=7, any::<bool>()).prop_map(|(toggle, mut data, len, last)| {
                data[len as usize..].fill(0);
                ServerResponse::UploadSegment { toggle, data, len, last }
            }),
            mux.prop_map(|(index, sub)| ServerResponse::DownloadInitiated { index, sub }),
            any::<bool>().prop_map(|toggle| ServerResponse::DownloadSegment { toggle }),
            (mux, any::<u32>()).prop_map(|((index, sub), code)| ServerResponse::Abort { index, sub, code }),
        ]
    }

    proptest! {
        #[test]
        fn client_requests_round_trip(r in client()) {
            prop_assert_eq!(ClientRequest::parse(&r.emit()), Some(r));
        }

        #[test]
        fn server_responses_round_trip(r in server()) {
            prop_assert_eq!(ServerResponse::parse(&r.emit()), Some(r));
        }

        #[test]
        fn parse_never_panics(data in proptest::collection::vec(any::<u8>(), 0..=9)) {
            let _ = ClientRequest::parse(&data);
            let _ = ServerResponse::parse(&data);
        }
    }
}
