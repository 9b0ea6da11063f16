//! The control port (`--control HOST:PORT`): a line protocol for scripts, on a TCP port of its
//! own. One command per line, one reply line each (D-SIM-18):
//!
//! - `list`: `ok` and every node as `BUS:LABEL#ID`, separated by blanks;
//! - `press DEVICE KEY`: an AP10T key pressed and released; `ok`;
//! - `screen DEVICE`: `ok` and what the device shows, the text of the live view (an AP10T's
//!   two rows, LEDs and backlight);
//! - `position DEVICE RAW`: the encoder's sensor held at RAW from now on; `ok`;
//! - anything else, or a command that cannot be carried out: `error TEXT`.
//!
//! DEVICE is `[BUS:]LABEL[#ID]` as the live view names a node (`can0:AP10T#125`, `AP10T#125`,
//! `AP10T`), the label in any case; it must name exactly one node. KEY is a key's name (`front`,
//! `left`, `star`, `up`, or its symbol `←`, `*`, `↑`) or a function of the key table
//! `od_core::devices::ap10t::keys::KEYMAP` (`confirm`, `auto_id`, `parameterize` ...). Blank
//! lines are skipped without a reply.
//!
//! The commands are carried out by the simulator's main loop, in order with the bus traffic;
//! this module parses them and serves the port.

use std::io::{BufRead, BufReader, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::mpsc::{channel, Sender};
use std::thread;

use od_core::devices::ap10t::keys::KEYMAP;
use od_core::devices::ap10t::Key;

/// One command of the control port.
#[derive(Clone, PartialEq, Eq, Debug)]
pub enum Command {
    /// `list`.
    List,
    /// `press DEVICE KEY`.
    Press {
        /// Which node.
        device: Selector,
        /// Which key.
        key: Key,
    },
    /// `screen DEVICE`.
    Screen {
        /// Which node.
        device: Selector,
    },
    /// `position DEVICE RAW`.
    Position {
        /// Which node.
        device: Selector,
        /// The raw sensor value.
        raw: u32,
    },
}

/// A node named as `[BUS:]LABEL[#ID]`.
#[derive(Clone, PartialEq, Eq, Debug)]
pub struct Selector {
    /// The bus, if given.
    pub bus: Option<String>,
    /// The label (`AP10T`, `SGH50-A` ...).
    pub label: String,
    /// The node-ID (J1939: the address), if given.
    pub id: Option<u8>,
}

impl Selector {
    /// Parses `[BUS:]LABEL[#ID]`.
    pub fn parse(text: &str) -> Result<Selector, String> {
        let (bus, rest) = match text.split_once(':') {
            Some((b, r)) => (Some(b.to_string()), r),
            None => (None, text),
        };
        let (label, id) = match rest.split_once('#') {
            Some((l, n)) => {
                let ok = !n.is_empty() && n.chars().all(|c| c.is_ascii_digit());
                let id = ok.then(|| n.parse::<u8>().ok()).flatten().ok_or(format!("bad node number in {text}"))?;
                (l, Some(id))
            }
            None => (rest, None),
        };
        if label.is_empty() || bus.as_deref() == Some("") {
            return Err(format!("bad device {text} (BUS:LABEL#ID, e.g. can0:AP10T#125)"));
        }
        Ok(Selector { bus, label: label.to_string(), id })
    }

    /// Does the selector name the node `label` with `id` on `bus`?
    pub fn matches(&self, bus: &str, label: &str, id: u8) -> bool {
        self.bus.as_deref().is_none_or(|b| b == bus)
            && self.label.eq_ignore_ascii_case(label)
            && self.id.is_none_or(|n| n == id)
    }
}

impl core::fmt::Display for Selector {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        if let Some(b) = &self.bus {
            write!(f, "{b}:")?;
        }
        write!(f, "{}", self.label)?;
        if let Some(n) = self.id {
            write!(f, "#{n}")?;
        }
        Ok(())
    }
}

/// A node's name as the control port shows and takes it: `BUS:LABEL#ID`.
pub fn node_name(bus: &str, label: &str, id: u8) -> String {
    format!("{bus}:{label}#{id}")
}

/// The key `name` names: a key (`front`, `left`, `star`, `up`, or `←`, `*`, `↑`) or a function
/// of [`KEYMAP`].
pub fn key_named(name: &str) -> Result<Key, String> {
    let k = match name.to_ascii_lowercase().as_str() {
        "front" => Key::Front,
        "left" | "←" => Key::Left,
        "star" | "*" => Key::Star,
        "up" | "↑" => Key::Up,
        "parameterize" => KEYMAP.parameterize,
        "digit_select" => KEYMAP.digit_select,
        "value_input" => KEYMAP.value_input,
        "confirm" => KEYMAP.confirm,
        "back" => KEYMAP.back,
        "auto_id" => KEYMAP.auto_id,
        _ => {
            return Err(format!(
                "unknown key {name} (front, left, star, up, or parameterize, digit_select, value_input, confirm, \
                 back, auto_id)"
            ))
        }
    };
    Ok(k)
}

/// Parses one command line.
pub fn parse(line: &str) -> Result<Command, String> {
    let words: Vec<&str> = line.split_whitespace().collect();
    match words.as_slice() {
        ["list"] => Ok(Command::List),
        ["press", d, k] => Ok(Command::Press { device: Selector::parse(d)?, key: key_named(k)? }),
        ["screen", d] => Ok(Command::Screen { device: Selector::parse(d)? }),
        ["position", d, raw] => {
            let ok = raw.chars().all(|c| c.is_ascii_digit());
            let raw = ok.then(|| raw.parse::<u32>().ok()).flatten().ok_or(format!("bad raw value {raw}"))?;
            Ok(Command::Position { device: Selector::parse(d)?, raw })
        }
        [w @ ("list" | "press" | "screen" | "position"), ..] => {
            Err(format!("{w}: wrong arguments (list | press DEVICE KEY | screen DEVICE | position DEVICE RAW)"))
        }
        _ => Err(format!("unknown command {} (list, press, screen, position)", words.first().copied().unwrap_or(""))),
    }
}

/// A command for the main loop with where its reply goes (the reply line without its end).
pub struct Request {
    /// The command.
    pub command: Command,
    /// Where the reply goes.
    pub reply: Sender<String>,
}

/// Serves the control port: every connection in a thread of its own, each command handed to
/// `submit` (false: the simulator stopped).
pub fn serve<F>(listener: TcpListener, submit: F)
where
    F: Fn(Request) -> bool + Clone + Send + 'static,
{
    for conn in listener.incoming() {
        let Ok(stream) = conn else { continue };
        let submit = submit.clone();
        thread::spawn(move || session(stream, submit));
    }
}

fn session<F: Fn(Request) -> bool>(stream: TcpStream, submit: F) {
    let _ = stream.set_nodelay(true);
    let Ok(mut out) = stream.try_clone() else { return };
    for line in BufReader::new(stream).lines() {
        let Ok(line) = line else { return };
        if line.trim().is_empty() {
            continue;
        }
        let reply = match parse(&line) {
            Err(e) => format!("error {e}"),
            Ok(command) => {
                let (tx, rx) = channel();
                if !submit(Request { command, reply: tx }) {
                    return;
                }
                match rx.recv() {
                    Ok(r) => r,
                    Err(_) => return,
                }
            }
        };
        if writeln!(out, "{reply}").is_err() {
            return;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commands() {
        let ap = |bus: Option<&str>, id| Selector { bus: bus.map(str::to_string), label: "AP10T".into(), id };
        assert_eq!(parse("list"), Ok(Command::List));
        assert_eq!(
            parse("press can0:AP10T#125 star"),
            Ok(Command::Press { device: ap(Some("can0"), Some(125)), key: Key::Star })
        );
        assert_eq!(parse("press AP10T confirm"), Ok(Command::Press { device: ap(None, None), key: KEYMAP.confirm }));
        assert_eq!(parse(" screen  AP10T#7 "), Ok(Command::Screen { device: ap(None, Some(7)) }));
        assert_eq!(
            parse("position can0:SGH10#10 1234"),
            Ok(Command::Position {
                device: Selector { bus: Some("can0".into()), label: "SGH10".into(), id: Some(10) },
                raw: 1234
            })
        );
        assert!(parse("press AP10T").is_err());
        assert!(parse("press AP10T enter").is_err());
        assert!(parse("position SGH10 -1").is_err());
        assert!(parse("position SGH10 +1").is_err());
        assert!(parse("screen AP10T#300").is_err());
        assert!(parse("screen :AP10T").is_err());
        assert!(parse("jump").is_err());
    }

    #[test]
    fn selectors() {
        let s = Selector::parse("ap10t#125").unwrap();
        assert!(s.matches("can0", "AP10T", 125));
        assert!(!s.matches("can0", "AP10T", 7));
        assert!(Selector::parse("AP10T").unwrap().matches("can3", "AP10T", 7));
        assert!(!Selector::parse("can1:AP10T").unwrap().matches("can0", "AP10T", 7));
        assert_eq!(Selector::parse("can0:AP10T#125").unwrap().to_string(), node_name("can0", "AP10T", 125));
    }
}
