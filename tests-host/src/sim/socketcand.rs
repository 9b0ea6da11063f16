//! The socketcand protocol's rawmode, as far as the simulator serves it: the messages a client
//! sends, parsed, and the ones the server sends, formatted.
//!
//! A session: server `< hi >`; client `< open can0 >`, server `< ok >`; client `< rawmode >`,
//! server `< ok >`; then the client sends `< send ID DLC B0 B1 .. >` (ID in hex: up to three
//! digits for an 11-bit identifier, eight for a 29-bit one; DLC and bytes in hex) and
//! `< sendrtr ID DLC >`, and receives `< frame ID SEC.USEC DATA >` (DATA: the bytes in hex
//! without spaces) and `< rtr ID SEC.USEC DLC >` (socketcand's `doc/protocol.md`).
//!
//! Errors follow socketcand: a malformed `< send >` or `< sendrtr >` is dropped without an
//! answer (the simulator counts it), text outside `< >` is dropped, an unknown command gets the
//! fixed `< error unknown command >` and a bus that cannot be opened `< error could not open
//! bus >`. No reply ever repeats what the client sent.

use od_core::{CanId, Frame};

/// The greeting.
pub const HI: &str = "< hi >";
/// The positive answer.
pub const OK: &str = "< ok >";
/// socketcand's answer to a command it does not serve in the current mode.
pub const UNKNOWN_COMMAND: &str = "< error unknown command >";
/// socketcand's answer to `< open >` of a bus it does not serve (it then closes the connection).
pub const COULD_NOT_OPEN: &str = "< error could not open bus >";

/// The longest message kept while waiting for its `>`: socketcand reads into a buffer of
/// this size and a frame message is far shorter.
pub const MAX_MESSAGE: usize = 256;

/// A message from a client.
#[derive(Clone, PartialEq, Eq, Debug)]
pub enum Request {
    /// `< open BUS >`.
    Open(String),
    /// `< rawmode >`.
    RawMode,
    /// `< send ID DLC B0 .. >` or `< sendrtr ID DLC >`: a data or a remote frame.
    Send(Frame),
    /// `< echo >`: answered with `< echo >`.
    Echo,
}

/// Why a message was not taken.
#[derive(Clone, PartialEq, Eq, Debug)]
pub enum Refused {
    /// A `< send >` or `< sendrtr >` that does not make a frame, text outside `< >`, an
    /// over-long message: dropped and counted, never answered (socketcand logs a syntax error
    /// and goes on). The text says why, for tests and logs, never for the client.
    Malformed(&'static str),
    /// Anything else: `< error unknown command >`.
    Unknown,
}

/// Splits complete `< ... >` messages off the front of `buf`; returns them and leaves an
/// incomplete rest in `buf` (at most [`MAX_MESSAGE`] bytes). Text before a `<` is noise.
pub fn split_messages(buf: &mut String) -> Vec<Result<String, Refused>> {
    let mut out = Vec::new();
    loop {
        let Some(start) = buf.find('<') else {
            if !buf.trim().is_empty() {
                out.push(Err(Refused::Malformed("text outside < >")));
            }
            buf.clear();
            break;
        };
        if !buf[..start].trim().is_empty() {
            out.push(Err(Refused::Malformed("text outside < >")));
        }
        let Some(len) = buf[start..].find('>') else {
            buf.drain(..start);
            if buf.len() > MAX_MESSAGE {
                out.push(Err(Refused::Malformed("message too long")));
                buf.clear();
            }
            break;
        };
        let end = start + len;
        if len >= MAX_MESSAGE {
            out.push(Err(Refused::Malformed("message too long")));
        } else {
            out.push(Ok(buf[start..=end].to_string()));
        }
        buf.drain(..=end);
    }
    out
}

/// Parses one message `< ... >`.
pub fn parse(msg: &str) -> Result<Request, Refused> {
    let inner =
        msg.trim().strip_prefix('<').and_then(|m| m.strip_suffix('>')).ok_or(Refused::Malformed("not a message"))?;
    let words: Vec<&str> = inner.split_ascii_whitespace().collect();
    match words.as_slice() {
        ["open", bus] => Ok(Request::Open(bus.to_string())),
        ["rawmode"] => Ok(Request::RawMode),
        ["echo"] => Ok(Request::Echo),
        ["send", rest @ ..] => parse_send(rest).map(Request::Send).map_err(Refused::Malformed),
        ["sendrtr", id, dlc] => {
            let id = identifier(id)?;
            Ok(Request::Send(Frame::remote(id, dlc_of(dlc)?)))
        }
        ["sendrtr", ..] => Err(Refused::Malformed("sendrtr takes ID and DLC")),
        _ => Err(Refused::Unknown),
    }
}

/// A hex number of up to eight digits, nothing but digits (no sign, no `0x`).
pub fn hex(word: &str) -> Option<u32> {
    if word.is_empty() || word.len() > 8 || !word.bytes().all(|b| b.is_ascii_hexdigit()) {
        return None;
    }
    u32::from_str_radix(word, 16).ok()
}

fn identifier(word: &str) -> Result<CanId, Refused> {
    let raw = hex(word).ok_or(Refused::Malformed("bad identifier"))?;
    match word.len() {
        1..=3 if raw <= 0x7FF => Ok(CanId::Std(raw as u16)),
        8 if raw <= 0x1FFF_FFFF => Ok(CanId::Ext(raw)),
        _ => Err(Refused::Malformed("bad identifier")),
    }
}

fn dlc_of(word: &str) -> Result<u8, Refused> {
    match hex(word) {
        Some(d) if d <= 8 => Ok(d as u8),
        _ => Err(Refused::Malformed("bad DLC")),
    }
}

/// `send ID DLC B0 ..`. A DLC with no data bytes at all is a remote frame: python-can's
/// socketcand interface writes a remote frame so (it sends the DLC and the message's empty
/// data). A DLC of 0 without bytes is an empty data frame (SYNC), except on 701h..77Fh, the
/// CANopen NMT error control identifiers, where no empty data frame has a meaning and
/// python-canopen's node guarding sends its remote request as exactly that (D-SIM-13).
fn parse_send(words: &[&str]) -> Result<Frame, &'static str> {
    let [id, dlc, bytes @ ..] = words else { return Err("send needs ID and DLC") };
    let id = identifier(id).map_err(|_| "bad identifier")?;
    let dlc = dlc_of(dlc).map_err(|_| "bad DLC")?;
    if bytes.is_empty() && (dlc > 0 || matches!(id, CanId::Std(0x701..=0x77F))) {
        return Ok(Frame::remote(id, dlc));
    }
    if bytes.len() != dlc as usize {
        return Err("DLC and data bytes differ");
    }
    let mut data = [0u8; 8];
    for (d, w) in data.iter_mut().zip(bytes) {
        *d = hex(w).and_then(|v| u8::try_from(v).ok()).ok_or("bad data byte")?;
    }
    Ok(Frame::new(id, &data[..dlc as usize]))
}

/// The identifier as socketcand writes it: three hex digits, or eight for a 29-bit one.
pub fn id_text(id: CanId) -> String {
    match id {
        CanId::Std(id) => format!("{id:03X}"),
        CanId::Ext(id) => format!("{id:08X}"),
    }
}

/// A frame received `micros` µs after the epoch, as socketcand sends it: `< frame ID SEC.USEC
/// DATA >`, or `< rtr ID SEC.USEC DLC >` for a remote frame (DLC in decimal, as socketcand
/// prints it).
pub fn frame_message(frame: &Frame, micros: u64) -> String {
    let (id, sec, usec) = (id_text(frame.id), micros / 1_000_000, micros % 1_000_000);
    if frame.rtr {
        return format!("< rtr {id} {sec}.{usec:06} {} >", frame.len);
    }
    let data: String = frame.payload().iter().map(|b| format!("{b:02X}")).collect();
    format!("< frame {id} {sec}.{usec:06} {data} >")
}

/// `< send ... >` as python-can writes it (for tests and clients of this crate); a remote
/// frame as `< sendrtr ID DLC >`.
pub fn send_message(frame: &Frame) -> String {
    if frame.rtr {
        return format!("< sendrtr {} {} >", id_text(frame.id), frame.len);
    }
    let bytes: Vec<String> = frame.payload().iter().map(|b| format!("{b:x}")).collect();
    format!("< send {} {:X} {} >", id_text(frame.id), frame.len, bytes.join(" "))
}
