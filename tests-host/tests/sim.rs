//! The simulator: the socketcand parser and serializer, the command line, the device
//! registry, the live view's decoder, and the `sim` binary over TCP (several clients, bad
//! input, a power cycle through `--state-dir`).

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant as WallClock};

use od_core::devices::sgh10;
use od_core::{Bitrate, CanId, Frame, Node};
use tests_host::sim::decode::{describe, Known};
use tests_host::sim::devices::{raw_at, Registry};
use tests_host::sim::options::{parse_device, parse_rate, Kind, Motion, Options, UNCONFIGURED};
use tests_host::sim::socketcand::{self as sc, Request};
use tests_host::TableOnly;

// ---- socketcand ----

#[test]
fn parses_the_rawmode_session() {
    assert_eq!(sc::parse("< open can0 >"), Ok(Request::Open("can0".into())));
    assert_eq!(sc::parse("< rawmode >"), Ok(Request::RawMode));
    assert_eq!(sc::parse("<echo>"), Ok(Request::Echo));
    assert_eq!(
        sc::parse("< send 601 8 40 18 10 1 0 0 0 0 >"),
        Ok(Request::Send(Frame::std(0x601, &[0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0])))
    );
    assert_eq!(sc::parse("< send 0 2 1 a >"), Ok(Request::Send(Frame::std(0, &[1, 0x0A]))));
    assert_eq!(sc::parse("< send 080 0  >"), Ok(Request::Send(Frame::std(0x80, &[]))));
    assert_eq!(
        sc::parse("< send 18FEF100 3 01 02 FF >"),
        Ok(Request::Send(Frame::new(CanId::Ext(0x18FE_F100), &[1, 2, 0xFF])))
    );
}

#[test]
fn refuses_bad_messages_with_a_reason() {
    for (msg, reason) in [
        ("< send 601 9 1 2 3 4 5 6 7 8 9 >", "DLC 9 over 8"),
        ("< send 601 2 1 >", "DLC 2 with 1 data bytes"),
        ("< send 601 1 100 >", "bad data byte 100"),
        ("< send 601 1 zz >", "bad data byte zz"),
        ("< send 800 0 >", "bad identifier 800"),
        ("< send 1234 0 >", "bad identifier 1234"),
        ("< send 20000000 0 >", "bad identifier 20000000"),
        ("< send 601 >", "send needs ID DLC and data"),
        ("< open >", "open takes one bus name"),
        ("< bogus >", "unknown command bogus"),
        ("< >", "empty message"),
        ("open can0", "not a message: open can0"),
    ] {
        assert_eq!(sc::parse(msg), Err(reason.to_string()), "{msg}");
    }
    assert_eq!(sc::error_message("a > b"), "< error a ' b >");
}

#[test]
fn splits_a_stream_into_messages() {
    let mut buf = String::from("< open can0 >< rawmode >junk< send 1 0 > < send 2");
    let got = sc::split_messages(&mut buf);
    assert_eq!(
        got,
        vec![
            Ok("< open can0 >".to_string()),
            Ok("< rawmode >".to_string()),
            Err("text outside < >: junk".to_string()),
            Ok("< send 1 0 >".to_string()),
        ]
    );
    assert_eq!(buf, "< send 2", "the incomplete message waits for the rest");
    buf.push_str(" 0 >\n");
    assert_eq!(sc::split_messages(&mut buf), vec![Ok("< send 2 0 >".to_string())]);
    assert_eq!(buf, "");
    let mut long = format!("<{}", "x".repeat(300));
    assert!(sc::split_messages(&mut long)[0].is_err());
    assert!(long.is_empty());
}

#[test]
fn formats_frames_as_socketcand_does() {
    let f = Frame::std(0x18A, &[0x12, 0x34, 0, 0, 5, 0]);
    assert_eq!(sc::frame_message(&f, 12_000_034), "< frame 18A 12.000034 123400000500 >");
    assert_eq!(sc::frame_message(&Frame::std(0x80, &[]), 1_500_000), "< frame 080 1.500000  >");
    let e = Frame::new(CanId::Ext(0x0CF0_0400), &[0xAB]);
    assert_eq!(sc::frame_message(&e, 0), "< frame 0CF00400 0.000000 AB >");
    for f in [f, e, Frame::std(0x7E5, &[0x51, 0, 0, 0, 0, 0x80, 0, 0])] {
        assert_eq!(sc::parse(&sc::send_message(&f)), Ok(Request::Send(f)));
    }
}

// ---- options ----

#[test]
fn no_arguments_is_the_bench_on_the_default_port() {
    let o = Options::parse::<&str>(&[]).unwrap();
    assert_eq!(o.listen, "127.0.0.1:29536");
    assert!(o.devices.is_empty() && !o.quiet && !o.help && o.state_dir.is_none() && o.trace.is_none());
    assert_eq!(o.bitrate("can0"), Bitrate::K500);
    assert_eq!(o.bitrate("can1"), Bitrate::K250);
}

#[test]
fn parses_every_option() {
    let o = Options::parse(&[
        "--listen",
        "0.0.0.0:5000",
        "--device",
        "sgh10:node=10,serial=0x1234,motion=sine:1000:2.5",
        "--device=sgh50:redundant=true,node=20,position=466000,bus=can2",
        "--state-dir",
        "/tmp/x",
        "--bitrate",
        "can0=250",
        "--bitrate=can2=1000k",
        "--quiet",
        "--trace",
        "t.log",
    ])
    .unwrap();
    assert_eq!(o.listen, "0.0.0.0:5000");
    assert_eq!(o.devices.len(), 2);
    let d = &o.devices[0];
    assert_eq!((d.kind, d.bus.as_str(), d.node, d.serial), (Kind::Sgh10, "can0", Some(10), Some(0x1234)));
    assert_eq!(d.motion, Some(Motion::Sine(1000.0, 2.5)));
    let d = &o.devices[1];
    assert_eq!(
        (d.kind, d.bus.as_str(), d.redundant, d.motion),
        (Kind::Sgh50, "can2", true, Some(Motion::Fixed(466_000)))
    );
    assert_eq!(o.bitrate("can0"), Bitrate::K250);
    assert_eq!(o.bitrate("can2"), Bitrate::K1000);
    assert!(o.quiet);
    assert_eq!(o.trace.as_deref(), Some(std::path::Path::new("t.log")));
    assert_eq!(o.state_dir.as_deref(), Some(std::path::Path::new("/tmp/x")));
}

#[test]
fn device_specs_and_their_errors() {
    let d = parse_device("wv58mr:address=0x80").unwrap();
    assert_eq!((d.kind, d.bus.as_str(), d.address), (Kind::Wv58mr, "can1", Some(0x80)));
    assert_eq!(parse_device("sgh10:node=unconfigured").unwrap().node, Some(UNCONFIGURED));
    assert_eq!(parse_device("SGH10:motion=ramp:-5").unwrap().motion, Some(Motion::Ramp(-5.0)));
    for (text, err) in [
        ("foo", "unknown device kind foo"),
        ("sgh10:node=0", "node=0: a CANopen node-ID is 1..127"),
        ("sgh10:node=128", "node=128: a CANopen node-ID is 1..127"),
        ("sgh10:node=x", "node=x: not a number"),
        ("wv58mr:address=254", "address=254: a J1939 address is 0..253"),
        ("sgh10:motion=sine:1:0", "motion=sine:1:0: the period must be positive"),
        ("sgh10:motion=zigzag", "motion=zigzag: ramp:STEPS_PER_S or sine:AMPL:PERIOD_S"),
        ("sgh10:colour=red", "unknown device key colour"),
        ("sgh10:node", "node: expected key=value"),
        ("sgh10:bus=a b", "bad bus name a b"),
        ("sgh10:redundant=maybe", "redundant=maybe: true or false"),
    ] {
        let got = parse_device(text).unwrap_err();
        assert!(got.starts_with(err), "{text}: {got}");
    }
    for bad in [&["--listen", "nowhere"][..], &["--bitrate", "can0=333"], &["--bogus"], &["--device"]] {
        assert!(Options::parse(bad).is_err(), "{bad:?}");
    }
    assert_eq!(parse_rate("125"), Ok(Bitrate::K125));
    assert_eq!(parse_rate("125000"), Ok(Bitrate::K125));
    assert!(parse_rate("125500").is_err());
}

// ---- registry ----

#[test]
fn kinds_not_built_yet_say_so_and_wrong_keys_are_refused() {
    let r = Registry::new(None);
    let err = r.build(&parse_device("wv58mr").unwrap(), 1).err().unwrap();
    assert!(err.contains("not yet available"), "wv58mr: {err}");
    let err = r.build(&parse_device("sgh10:address=5").unwrap(), 1).err().unwrap();
    assert!(err.contains("takes node="), "{err}");
    let err = r.build(&parse_device("sgh50:node=127,redundant=true").unwrap(), 1).err().unwrap();
    assert!(err.contains("beyond 127"), "{err}");
    assert_eq!(r.build(&parse_device("sgh50:redundant=true").unwrap(), 1).unwrap().len(), 2);
    assert_eq!(r.build(&parse_device("sgh10:variant=sgh10l").unwrap(), 1).unwrap().len(), 1);
    assert!(r.build(&parse_device("sgh10:variant=xyz").unwrap(), 1).is_err());
    for v in ["wv1", "wv16", "WV256", "wh4096"] {
        assert_eq!(r.build(&parse_device(&format!("wv5800m:variant={v}")).unwrap(), 1).unwrap().len(), 1, "{v}");
    }
    for v in ["wv2", "xx16"] {
        let err = r.build(&parse_device(&format!("wv5800m:variant={v}")).unwrap(), 1).err().unwrap();
        assert!(err.contains("unknown variant"), "{err}");
    }
}

#[test]
fn the_wv5800m_shows_its_leds() {
    let r = Registry::new(None);
    let plan = r.build(&parse_device("wv5800m:node=30,variant=wh16").unwrap(), 1).unwrap().pop().unwrap();
    assert_eq!(plan.label, "WH5800M");
    let mut params = plan.params;
    let mut node = (plan.boot)(&params.load());
    assert_eq!(node.core().node_id, 30);
    assert_eq!(node.panel().as_deref(), Some("LEDs green=Off red=Off yellow=Off"), "before the boot");
    node.poll(od_core::Instant::ZERO);
    while node.next_output().is_some() {}
    assert_eq!(node.panel().as_deref(), Some("LEDs green=Flashing red=Off yellow=Off"), "pre-operational blinks");
    let plan = r.build(&parse_device("sgh10").unwrap(), 1).unwrap().pop().unwrap();
    assert_eq!((plan.boot)(&od_core::storage::Loaded::Blank).panel(), None, "the SGH10 has no LEDs to show");
}

#[test]
fn a_configured_node_id_and_serial_are_in_the_blank_flash_only() {
    let dir = tempdir("registry");
    let r = Registry::new(Some(&dir));
    let spec = parse_device("sgh10:node=10,serial=777").unwrap();
    let plan = r.build(&spec, 1).unwrap().pop().unwrap();
    let mut params = plan.params;
    let node = (plan.boot)(&params.load());
    assert_eq!(node.core().node_id, 10);
    assert_eq!(node.core().od.value(0x1018, 4), Some(777));
    assert!(dir.join("can0-sgh10-1.flash").exists());
    // A flash holding an image keeps it, whatever the command line says now.
    let spec = parse_device("sgh10:node=11").unwrap();
    let plan = r.build(&spec, 1).unwrap().pop().unwrap();
    let node = (plan.boot)(&plan.params.into_load());
    assert_eq!(node.core().node_id, 10);
    let _ = std::fs::remove_dir_all(dir);
}

trait IntoLoad {
    fn into_load(self) -> od_core::storage::Loaded;
}

impl IntoLoad for Box<dyn tests_host::segment::NodeFlash> {
    fn into_load(mut self) -> od_core::storage::Loaded {
        self.load()
    }
}

#[test]
fn sensor_motions() {
    assert_eq!(raw_at(Motion::Fixed(5), 10, 3.0), 5);
    assert_eq!(raw_at(Motion::Ramp(4.0), 10, 2.0), 8);
    assert_eq!(raw_at(Motion::Ramp(4.0), 10, 3.0), 1, "wraps over 0..=10");
    assert_eq!(raw_at(Motion::Ramp(-4.0), 10, 1.0), 7);
    assert_eq!(raw_at(Motion::Sine(4.0, 4.0), 10, 0.0), 5);
    assert_eq!(raw_at(Motion::Sine(4.0, 4.0), 10, 1.0), 9);
    assert_eq!(raw_at(Motion::Sine(100.0, 4.0), 10, 3.0), 0, "clamped to the range");
}

// ---- decoder ----

#[test]
fn decodes_frames_for_the_live_view() {
    let node = Node::new(TableOnly(sgh10::TABLE), 10, Bitrate::K500);
    let known = [Known { label: "SGH10", core: node.core() }];
    let d = |f: Frame| describe(&f, &known);
    assert_eq!(d(Frame::std(0, &[1, 10])), "NMT SGH10#10 -> OPERATIONAL");
    assert_eq!(d(Frame::std(0, &[0x82, 0])), "NMT all nodes -> RESET COMMUNICATION");
    assert_eq!(d(Frame::std(0, &[2, 20])), "NMT node 20 -> STOPPED");
    assert_eq!(d(Frame::std(0x601, &[0x40, 0x18, 0x10, 1, 0, 0, 0, 0])), "SDO 601 read 1018:01");
    assert_eq!(d(Frame::std(0x60A, &[0x2B, 0x17, 0x10, 0, 0xE8, 3, 0, 0])), "SDO 60A write 1017:00 = 3E8");
    assert_eq!(d(Frame::std(0x58A, &[0x43, 0x18, 0x10, 1, 0x95, 1, 0, 0])), "SDO 58A 1018:01 = 195");
    assert_eq!(d(Frame::std(0x58A, &[0x80, 0x00, 0x20, 0, 0, 0, 2, 6])), "SDO 58A abort 2000:00 code 06020000");
    assert_eq!(d(Frame::std(0x70A, &[0x05])), "SGH10#10 heartbeat OPERATIONAL");
    assert_eq!(d(Frame::std(0x70A, &[0x00])), "SGH10#10 heartbeat boot-up");
    assert_eq!(d(Frame::std(0x8A, &[0, 0, 0, 0, 0, 0, 0, 0])), "SGH10#10 EMCY 0000 register 00 (error reset)");
    assert_eq!(d(Frame::std(0x80, &[])), "SYNC");
    assert_eq!(d(Frame::std(0x7E5, &[0x11, 42, 0, 0, 0, 0, 0, 0])), "LSS request configure node-ID 42");
    assert_eq!(d(Frame::std(0x7E4, &[0x17, 0, 0, 0, 0, 0, 0, 0])), "LSS response store configuration: ok");
    // TPDO2 (sync) maps position and speed; 0.1 mm steps.
    assert_eq!(
        d(Frame::std(0x28A, &[0x34, 0x12, 0, 0, 5, 0])),
        "SGH10#10 TPDO2 Position value=4660 (466.0 mm) Speed value channel 1=5"
    );
    assert_eq!(d(Frame::new(CanId::Ext(0x18FE_F180), &[])), "29-bit 18FEF180 (J1939 PGN 0FEF1)");
}

// ---- the binary over TCP ----

fn tempdir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("sim-test-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port()
}

/// A running `sim`, killed when dropped.
struct Sim(Child, u16);

impl Sim {
    fn start(args: &[&str]) -> Sim {
        let port = free_port();
        let listen = format!("127.0.0.1:{port}");
        let child = Command::new(env!("CARGO_BIN_EXE_sim"))
            .args(["--quiet", "--listen", &listen])
            .args(args)
            .stdout(Stdio::null())
            .spawn()
            .unwrap();
        let deadline = WallClock::now() + Duration::from_secs(10);
        while TcpStream::connect(&listen).is_err() {
            assert!(WallClock::now() < deadline, "sim does not listen");
            std::thread::sleep(Duration::from_millis(20));
        }
        Sim(child, port)
    }

    fn client(&self) -> Client {
        let s = TcpStream::connect(("127.0.0.1", self.1)).unwrap();
        s.set_read_timeout(Some(Duration::from_millis(200))).unwrap();
        let mut c = Client { w: s, buf: String::new() };
        assert_eq!(c.next().as_deref(), Some("< hi >"));
        c
    }

    fn open(&self, bus: &str) -> Client {
        let mut c = self.client();
        c.say(&format!("< open {bus} >"));
        assert_eq!(c.next().as_deref(), Some("< ok >"));
        c.say("< rawmode >");
        assert_eq!(c.next().as_deref(), Some("< ok >"));
        c
    }
}

impl Drop for Sim {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

struct Client {
    w: TcpStream,
    buf: String,
}

impl Client {
    fn say(&mut self, msg: &str) {
        self.w.write_all(msg.as_bytes()).unwrap();
    }

    /// The next message within 200 ms.
    fn next(&mut self) -> Option<String> {
        let deadline = WallClock::now() + Duration::from_millis(200);
        loop {
            if let Some(end) = self.buf.find('>') {
                let msg = self.buf[..=end].trim().to_string();
                self.buf.drain(..=end);
                return Some(msg);
            }
            if WallClock::now() > deadline {
                return None;
            }
            let mut chunk = [0u8; 512];
            match self.w.read(&mut chunk) {
                Ok(0) => return None,
                Ok(n) => self.buf.push_str(std::str::from_utf8(&chunk[..n]).unwrap()),
                Err(_) => {}
            }
        }
    }

    /// The next `< frame >` as (id, data), skipping nothing else.
    fn frame(&mut self) -> Option<(String, String)> {
        let msg = self.next()?;
        let parts: Vec<&str> = msg.trim_start_matches("< frame ").trim_end_matches(" >").split(' ').collect();
        assert!(msg.starts_with("< frame "), "{msg}");
        assert!(parts[1].contains('.'), "{msg}");
        Some((parts[0].to_string(), parts.get(2).unwrap_or(&"").to_string()))
    }

    /// Waits up to `ms` for a frame with identifier `id`.
    fn wait_for(&mut self, id: &str, ms: u64) -> Option<String> {
        let deadline = WallClock::now() + Duration::from_millis(ms);
        while WallClock::now() < deadline {
            if let Some((i, data)) = self.frame() {
                if i == id {
                    return Some(data);
                }
            }
        }
        None
    }
}

fn f(id: u16, data: &[u8]) -> String {
    sc::send_message(&Frame::std(id, data))
}

#[test]
fn two_clients_see_each_other_and_the_devices() {
    let sim = Sim::start(&["--device", "sgh10:node=10"]);
    let mut a = sim.open("can0");
    let mut b = sim.open("can0");
    a.say(&f(0x000, &[0x82, 10]));
    assert_eq!(b.frame(), Some(("000".into(), "820A".into())), "b sees a's frame");
    assert_eq!(b.frame(), Some(("70A".into(), "00".into())), "and the boot-up");
    assert_eq!(a.frame(), Some(("70A".into(), "00".into())), "a sees the boot-up, not its own frame");
    b.say(&sc::send_message(&Frame::new(CanId::Ext(0x18FE_F100), &[1, 2, 3])));
    assert_eq!(a.frame(), Some(("18FEF100".into(), "010203".into())));
    assert_eq!(b.next(), None);
}

#[test]
fn bad_input_gets_an_error_and_stops_nothing() {
    let sim = Sim::start(&["--device", "sgh10:node=10"]);
    let mut other = sim.open("can0");
    let mut c = sim.client();
    c.say("< open can7 >");
    assert_eq!(c.next().as_deref(), Some("< error unknown bus can7 >"));
    c.say(&f(0x000, &[0x82, 0]));
    assert_eq!(c.next().as_deref(), Some("< error send needs rawmode >"));
    c.say("< open can0 >< rawmode >");
    assert_eq!(c.next().as_deref(), Some("< ok >"));
    assert_eq!(c.next().as_deref(), Some("< ok >"));
    c.say("< send 601 9 1 2 3 4 5 6 7 8 9 >");
    assert_eq!(c.next().as_deref(), Some("< error DLC 9 over 8 >"));
    c.say("garbage < frobnicate >");
    assert_eq!(c.next().as_deref(), Some("< error text outside ' ': garbage >"));
    assert_eq!(c.next().as_deref(), Some("< error unknown command frobnicate >"));
    c.say("< send 601 1 >");
    assert_eq!(c.next().as_deref(), Some("< error DLC 1 with 0 data bytes >"));
    c.w.write_all(&[0xFF, 0xFE, b'\n']).unwrap();
    assert!(c.next().unwrap().starts_with("< error text outside"));
    // The simulator and the other client go on.
    c.say(&f(0x000, &[0x81, 10]));
    assert_eq!(other.wait_for("70A", 2000), Some("00".into()));
    drop(c);
    let mut d = sim.open("can0");
    d.say(&f(0x000, &[0x82, 10]));
    assert_eq!(other.wait_for("70A", 2000), Some("00".into()));
}

#[test]
fn unavailable_devices_fail_cleanly() {
    let out = Command::new(env!("CARGO_BIN_EXE_sim")).args(["--device", "wv58mr"]).output().unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("WV58MR (J1939) not yet available"), "{err}");
    let out = Command::new(env!("CARGO_BIN_EXE_sim")).args(["--device", "sgh10:node=0"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let out = Command::new(env!("CARGO_BIN_EXE_sim")).arg("--help").output().unwrap();
    assert!(out.status.success());
    let help = String::from_utf8_lossy(&out.stdout);
    for opt in ["--listen", "--device", "--state-dir", "--bitrate", "--quiet", "--trace", "redundant=true", "motion="] {
        assert!(help.contains(opt), "--help lacks {opt}");
    }
}

#[test]
fn a_node_at_another_bit_rate_neither_sees_nor_sends() {
    let sim = Sim::start(&["--device", "sgh10:node=10", "--bitrate", "can0=250"]);
    let mut c = sim.open("can0");
    c.say(&f(0x000, &[0x82, 0]));
    assert_eq!(c.wait_for("70A", 500), None);
}

#[test]
fn restart_on_the_same_state_dir_is_a_power_cycle() {
    let dir = tempdir("power");
    let state = dir.to_str().unwrap();
    let lss = |c: &mut Client, data: &[u8]| c.say(&f(0x7E5, data));
    {
        let sim =
            Sim::start(&["--device", "sgh10:node=10", "--state-dir", state, "--trace", &format!("{state}/t.log")]);
        let mut c = sim.open("can0");
        lss(&mut c, &[0x04, 1, 0, 0, 0, 0, 0, 0]);
        lss(&mut c, &[0x11, 42, 0, 0, 0, 0, 0, 0]);
        assert_eq!(c.wait_for("7E4", 1000), Some("1100000000000000".into()));
        lss(&mut c, &[0x17, 0, 0, 0, 0, 0, 0, 0]);
        assert_eq!(c.wait_for("7E4", 1000), Some("1700000000000000".into()));
    }
    let sim = Sim::start(&["--device", "sgh10:node=10", "--state-dir", state]);
    let mut c = sim.open("can0");
    c.say(&f(0x000, &[0x82, 0]));
    assert_eq!(c.wait_for("72A", 1000), Some("00".into()), "the stored node-ID 42 is kept");
    let trace = std::fs::read_to_string(dir.join("t.log")).unwrap();
    assert!(trace.lines().any(|l| l.ends_with(" can0 7E5#112A000000000000") && l.starts_with('(')), "{trace}");
    drop(sim);
    let _ = std::fs::remove_dir_all(dir);
}

// ---- SocketCAN bridge ----

#[test]
fn socketcan_frames_encode_as_struct_can_frame() {
    use tests_host::sim::socketcan::{decode, encode};
    let f = Frame::std(0x18A, &[1, 2, 3]);
    let b = encode(&f);
    assert_eq!(u32::from_ne_bytes([b[0], b[1], b[2], b[3]]), 0x18A);
    assert_eq!(&b[4..11], &[3, 0, 0, 0, 1, 2, 3]);
    assert_eq!(decode(&b), Some(f));
    let e = Frame::new(CanId::Ext(0x18FE_F100), &[9; 8]);
    let b = encode(&e);
    assert_eq!(u32::from_ne_bytes([b[0], b[1], b[2], b[3]]), 0x98FE_F100, "EFF flag");
    assert_eq!(decode(&b), Some(e));
    let r = Frame::remote(CanId::Std(0x70A), 1);
    assert_eq!(u32::from_ne_bytes(encode(&r)[..4].try_into().unwrap()), 0x4000_070A, "RTR flag");
    assert_eq!(decode(&encode(&r)), Some(r));
    let mut err = [0u8; 16];
    err[..4].copy_from_slice(&0x2000_0004u32.to_ne_bytes());
    assert_eq!(decode(&err), None, "error frames are not bus traffic");
    let mut long = encode(&f);
    long[4] = 9;
    assert_eq!(decode(&long), None);
}

#[test]
fn socketcan_bridge_needs_the_interface() {
    let iface = "simtestnone0";
    let out = Command::new(env!("CARGO_BIN_EXE_sim"))
        .args(["--quiet", "--listen", &format!("127.0.0.1:{}", free_port()), "--device", "sgh10"])
        .args(["--socketcan", &format!("can0={iface}")])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.starts_with(&format!("sim: --socketcan can0={iface}: ")), "{err}");
}

/// Where the machine has a `vcan0` (`ip link add vcan0 type vcan`), frames cross the bridge
/// both ways. Elsewhere the kernel refuses the socket and there is nothing to bridge to.
#[test]
fn socketcan_bridge_carries_frames_both_ways_where_vcan0_exists() {
    use tests_host::sim::socketcan::CanSocket;
    let Ok(can) = CanSocket::open("vcan0") else { return };
    let sim = Sim::start(&["--device", "sgh10:node=10", "--socketcan", "can0=vcan0"]);
    let mut c = sim.open("can0");
    std::thread::sleep(Duration::from_millis(100));
    can.send(&Frame::std(0x000, &[0x82, 10])).unwrap();
    assert_eq!(c.wait_for("000", 1000), Some("820A".into()), "vcan0 to the socketcand client");
    c.say(&f(0x123, &[0xAA]));
    let deadline = WallClock::now() + Duration::from_secs(2);
    let mut seen = Vec::new();
    while WallClock::now() < deadline && !seen.contains(&Frame::std(0x123, &[0xAA])) {
        seen.push(can.recv().unwrap());
    }
    assert!(seen.contains(&Frame::std(0x70A, &[0])), "the boot-up reaches vcan0: {seen:?}");
    assert!(seen.contains(&Frame::std(0x123, &[0xAA])), "the client's frame reaches vcan0");
}
