//! The socketcand protocol's rawmode, as far as the simulator serves it: the messages a client
//! sends, parsed, and the ones the server sends, formatted.
//!
//! A session: server `< hi >`; client `< open can0 >`, server `< ok >`; client `< rawmode >`,
//! server `< ok >`; then the client sends `< send ID DLC B0 B1 .. >` (ID in hex: up to three
//! digits for an 11-bit identifier, eight for a 29-bit one; DLC and bytes in hex) and receives
//! `< frame ID SEC.USEC DATA >` (DATA: the bytes in hex without spaces). Anything else gets
//! `< error TEXT >`.

use od_core::{CanId, Frame};

/// The greeting.
pub const HI: &str = "< hi >";
/// The positive answer.
pub const OK: &str = "< ok >";

/// A message from a client.
#[derive(Clone, PartialEq, Eq, Debug)]
pub enum Request {
    /// `< open BUS >`.
    Open(String),
    /// `< rawmode >`.
    RawMode,
    /// `< send ID DLC B0 .. >`.
    Send(Frame),
    /// `< echo >`: answered with `< echo >`.
    Echo,
}

/// Splits complete `< ... >` messages off the front of `buf`; returns them and leaves an
/// incomplete rest in `buf`. Text before a `<` is dropped as noise (reported as an error).
pub fn split_messages(buf: &mut String) -> Vec<Result<String, String>> {
    let mut out = Vec::new();
    loop {
        let Some(start) = buf.find('<') else {
            if !buf.trim().is_empty() {
                out.push(Err(format!("text outside < >: {}", buf.trim())));
            }
            buf.clear();
            break;
        };
        if !buf[..start].trim().is_empty() {
            out.push(Err(format!("text outside < >: {}", buf[..start].trim())));
        }
        let Some(len) = buf[start..].find('>') else {
            buf.drain(..start);
            if buf.len() > 256 {
                out.push(Err("message longer than 256 characters".into()));
                buf.clear();
            }
            break;
        };
        let end = start + len;
        out.push(Ok(buf[start..=end].to_string()));
        buf.drain(..=end);
    }
    out
}

/// Parses one message `< ... >`; an `Err` holds the text for `< error ... >`.
pub fn parse(msg: &str) -> Result<Request, String> {
    let inner = msg
        .trim()
        .strip_prefix('<')
        .and_then(|m| m.strip_suffix('>'))
        .ok_or_else(|| format!("not a message: {msg}"))?;
    let words: Vec<&str> = inner.split_ascii_whitespace().collect();
    match words.as_slice() {
        ["open", bus] => Ok(Request::Open(bus.to_string())),
        ["open", ..] => Err("open takes one bus name".into()),
        ["rawmode"] => Ok(Request::RawMode),
        ["echo"] => Ok(Request::Echo),
        ["send", id, dlc, bytes @ ..] => parse_send(id, dlc, bytes).map(Request::Send),
        ["send", ..] => Err("send needs ID DLC and data".into()),
        [] => Err("empty message".into()),
        [cmd, ..] => Err(format!("unknown command {cmd}")),
    }
}

fn hex(word: &str, what: &str) -> Result<u32, String> {
    if word.is_empty() || word.len() > 8 {
        return Err(format!("bad {what} {word}"));
    }
    u32::from_str_radix(word, 16).map_err(|_| format!("bad {what} {word}"))
}

fn parse_send(id: &str, dlc: &str, bytes: &[&str]) -> Result<Frame, String> {
    let raw = hex(id, "identifier")?;
    let id = match id.len() {
        1..=3 if raw <= 0x7FF => CanId::Std(raw as u16),
        8 if raw <= 0x1FFF_FFFF => CanId::Ext(raw),
        _ => return Err(format!("bad identifier {id}")),
    };
    let dlc = hex(dlc, "DLC")?;
    if dlc > 8 {
        return Err(format!("DLC {dlc} over 8"));
    }
    if bytes.len() != dlc as usize {
        return Err(format!("DLC {dlc} with {} data bytes", bytes.len()));
    }
    let mut data = [0u8; 8];
    for (d, w) in data.iter_mut().zip(bytes) {
        let v = hex(w, "data byte")?;
        *d = u8::try_from(v).map_err(|_| format!("bad data byte {w}"))?;
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

/// `< frame ID SEC.USEC DATA >` for a frame received `micros` µs after the epoch.
pub fn frame_message(frame: &Frame, micros: u64) -> String {
    let data: String = frame.payload().iter().map(|b| format!("{b:02X}")).collect();
    format!("< frame {} {}.{:06} {} >", id_text(frame.id), micros / 1_000_000, micros % 1_000_000, data)
}

/// `< error TEXT >` (a `>` in the text would end the message early, so it is replaced).
pub fn error_message(text: &str) -> String {
    format!("< error {} >", text.replace(['<', '>'], "'"))
}

/// `< send ... >` as python-can writes it (for tests and clients of this crate).
pub fn send_message(frame: &Frame) -> String {
    let bytes: Vec<String> = frame.payload().iter().map(|b| format!("{b:x}")).collect();
    format!("< send {} {:X} {} >", id_text(frame.id), frame.len, bytes.join(" "))
}
