//! The simulator: the socketcand parser and serializer, the command line, the device
//! registry, the live view's decoder, and the `sim` binary over TCP (several clients, bad
//! input, a power cycle through `--state-dir`).

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant as WallClock};

use od_core::devices::sgh10;
use od_core::{Bitrate, CanId, Frame, Node};
use tests_host::sim::decode::{describe, fit, view_line, Known};
use tests_host::sim::devices::{board_uid, raw_at, Registry};
use tests_host::sim::master::BenchMaster;
use tests_host::sim::options::{parse_device, parse_rate, Kind, Motion, Options, UNCONFIGURED};
use tests_host::sim::run::frame_time;
use tests_host::sim::socketcand::{self as sc, Refused, Request};
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

/// Issue 13 point 5: remote frames as socketcand (`sendrtr`) and as python-can (`send` with the
/// DLC and no bytes) write them.
#[test]
fn parses_remote_frames() {
    let rtr = |id, dlc| Ok(Request::Send(Frame::remote(id, dlc)));
    assert_eq!(sc::parse("< sendrtr 70A 1 >"), rtr(CanId::Std(0x70A), 1));
    assert_eq!(sc::parse("< sendrtr 1AAAAAAA 2 >"), rtr(CanId::Ext(0x1AAA_AAAA), 2));
    assert_eq!(sc::parse("< send 28A 6  >"), rtr(CanId::Std(0x28A), 6), "python-can's remote frame");
    assert_eq!(sc::parse("< send 70A 0  >"), rtr(CanId::Std(0x70A), 0), "python-canopen's node guarding");
    assert_eq!(sc::parse("< send 080 0 >"), Ok(Request::Send(Frame::std(0x80, &[]))), "SYNC stays data");
    assert_eq!(sc::parse("< send 700 0 >"), Ok(Request::Send(Frame::std(0x700, &[]))));
    assert_eq!(sc::parse("< sendrtr 70A 9 >"), Err(Refused::Malformed("bad DLC")));
    assert_eq!(sc::parse("< sendrtr 70A >"), Err(Refused::Malformed("sendrtr takes ID and DLC")));
    let f = Frame::remote(CanId::Std(0x70A), 1);
    assert_eq!(sc::frame_message(&f, 23_424_242), "< rtr 70A 23.424242 1 >");
    assert_eq!(sc::parse(&sc::send_message(&f)), Ok(Request::Send(f)));
}

/// Issue 13 point 4: a malformed send is dropped (counted), an unknown command gets socketcand's
/// fixed text; nothing the client sent comes back.
#[test]
fn refuses_bad_messages_without_echoing_them() {
    for (msg, why) in [
        ("< send 601 9 1 2 3 4 5 6 7 8 9 >", "bad DLC"),
        ("< send 601 2 1 >", "DLC and data bytes differ"),
        ("< send 601 1 100 >", "bad data byte"),
        ("< send 601 1 zz >", "bad data byte"),
        ("< send 601 1 +1 >", "bad data byte"),
        ("< send +01 0 >", "bad identifier"),
        ("< send 800 0 >", "bad identifier"),
        ("< send 1234 0 >", "bad identifier"),
        ("< send 20000000 0 >", "bad identifier"),
        ("< send 601 >", "send needs ID and DLC"),
        ("open can0", "not a message"),
    ] {
        assert_eq!(sc::parse(msg), Err(Refused::Malformed(why)), "{msg}");
    }
    for msg in ["< open >", "< bogus >", "< >", "< bcmmode >"] {
        assert_eq!(sc::parse(msg), Err(Refused::Unknown), "{msg}");
    }
    assert_eq!(sc::UNKNOWN_COMMAND, "< error unknown command >");
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
            Err(Refused::Malformed("text outside < >")),
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
        ("sgh10:node=+5", "node=+5: not a number"),
        ("sgh10:serial=0x+5", "serial=0x+5: not a number"),
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
    for bad in [
        &["--listen", "nowhere"][..],
        &["--bitrate", "can0=333"],
        &["--bitrate", "can0=+500"],
        &["--bogus"],
        &["--device"],
    ] {
        assert!(Options::parse(bad).is_err(), "{bad:?}");
    }
    assert_eq!(parse_rate("125"), Ok(Bitrate::K125));
    assert_eq!(parse_rate("125000"), Ok(Bitrate::K125));
    assert!(parse_rate("125500").is_err());
}

// ---- registry ----

#[test]
fn the_j1939_kind_builds_and_wrong_keys_are_refused() {
    let r = Registry::new(None);
    assert_eq!(r.build(&parse_device("wv58mr").unwrap(), 1, 0).unwrap().len(), 1);
    let pair = r.build(&parse_device("wv58mr:redundant=true,serial=7").unwrap(), 1, 0).unwrap();
    assert_eq!(
        pair.iter().map(|p| (p.label.as_str(), p.bus.as_str())).collect::<Vec<_>>(),
        [("WV58MR-A", "can1"), ("WV58MR-B", "can1")]
    );
    assert!(r.build(&parse_device("wv58mr:variant=xyz").unwrap(), 1, 0).is_err());
    let err = r.build(&parse_device("sgh10:address=5").unwrap(), 1, 0).err().unwrap();
    assert!(err.contains("takes node="), "{err}");
    let err = r.build(&parse_device("sgh50:node=127,redundant=true").unwrap(), 1, 0).err().unwrap();
    assert!(err.contains("beyond 127"), "{err}");
    assert_eq!(r.build(&parse_device("sgh50:redundant=true").unwrap(), 1, 0).unwrap().len(), 2);
    assert_eq!(r.build(&parse_device("sgh10:variant=sgh10l").unwrap(), 1, 0).unwrap().len(), 1);
    assert!(r.build(&parse_device("sgh10:variant=xyz").unwrap(), 1, 0).is_err());
    for v in ["wv1", "wv16", "WV256", "wh4096"] {
        assert_eq!(r.build(&parse_device(&format!("wv5800m:variant={v}")).unwrap(), 1, 0).unwrap().len(), 1, "{v}");
    }
    for v in ["wv2", "xx16"] {
        let err = r.build(&parse_device(&format!("wv5800m:variant={v}")).unwrap(), 1, 0).err().unwrap();
        assert!(err.contains("unknown variant"), "{err}");
    }
}

#[test]
fn the_wv5800m_shows_its_leds() {
    let r = Registry::new(None);
    let plan = r.build(&parse_device("wv5800m:node=30,variant=wh16").unwrap(), 1, 0).unwrap().pop().unwrap();
    assert_eq!(plan.label, "WH5800M");
    let mut params = plan.params;
    let mut node = (plan.boot)(&params.load());
    assert_eq!(node.core().node_id, 30);
    assert_eq!(node.panel().as_deref(), Some("LEDs green=Off red=Off yellow=Off"), "before the boot");
    node.poll(od_core::Instant::ZERO);
    while node.next_output().is_some() {}
    assert_eq!(node.panel().as_deref(), Some("LEDs green=Flashing red=Off yellow=Off"), "pre-operational blinks");
    let plan = r.build(&parse_device("sgh10").unwrap(), 1, 0).unwrap().pop().unwrap();
    assert_eq!((plan.boot)(&od_core::storage::Loaded::Blank).panel(), None, "the SGH10 has no LEDs to show");
}

#[test]
fn a_configured_node_id_and_serial_are_in_the_blank_flash_only() {
    let dir = tempdir("registry");
    let r = Registry::new(Some(&dir));
    let spec = parse_device("sgh10:node=10,serial=777").unwrap();
    let plan = r.build(&spec, 1, 0).unwrap().pop().unwrap();
    let mut params = plan.params;
    let node = (plan.boot)(&params.load());
    assert_eq!(node.core().node_id, 10);
    assert_eq!(node.core().od.value(0x1018, 4), Some(777));
    assert!(dir.join("can0-sgh10-1.flash").exists());
    // A flash holding an image keeps it, whatever the command line says now.
    let spec = parse_device("sgh10:node=11").unwrap();
    let plan = r.build(&spec, 1, 0).unwrap().pop().unwrap();
    let node = (plan.boot)(&plan.params.into_load());
    assert_eq!(node.core().node_id, 10);
    let _ = std::fs::remove_dir_all(dir);
}

/// Issue 13 point 6: every simulated board has a serial number of its own, derived as the
/// firmware derives it from the MCU's unique ID; `serial=` names the first channel's.
#[test]
fn every_board_has_its_own_serial_number() {
    let r = Registry::new(None);
    let serials = |spec: &str, position| -> Vec<u32> {
        let plans = r.build(&parse_device(spec).unwrap(), 1, position).unwrap();
        plans
            .into_iter()
            .map(|p| {
                let mut params = p.params;
                (p.boot)(&params.load()).core().od.value(0x1018, 4).unwrap()
            })
            .collect()
    };
    let both = serials("sgh50:redundant=true", 0);
    assert_ne!(both[0], both[1], "the two SGH50 channels");
    assert_eq!(both[0], board_plan::straps::serial_from_uid(&board_uid("can0", Kind::Sgh50, 0, 0)));
    assert_eq!(serials("sgh50:redundant=true,serial=100", 0), vec![100, 101]);
    let (a, b) = (serials("sgh10", 0), serials("sgh10", 1));
    assert_ne!(a, b, "two SGH10 without serial=");
    assert_eq!(a, serials("sgh10", 0), "the same command line, the same serial numbers");
    assert_ne!(serials("sgh10", 0), serials("sgh10:bus=can2", 0));
    // Every board one bus could hold differs (the varying bytes of the ID lie within 32 bits).
    let mut all = std::collections::HashSet::new();
    for position in 0..300 {
        for (_, kind) in Kind::ALL {
            for channel in 0..2 {
                assert!(all.insert(board_plan::straps::serial_from_uid(&board_uid("can0", kind, position, channel))));
            }
        }
    }
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
    assert_eq!(d(Frame::std(0x60A, &[0x2B, 0x17, 0x10, 0, 0xE8, 3, 0, 0])), "SDO 60A write 1017:00 = 0x3E8");
    assert_eq!(d(Frame::std(0x58A, &[0x43, 0x18, 0x10, 1, 0x95, 1, 0, 0])), "SDO 58A 1018:01 = 0x195");
    assert_eq!(
        d(Frame::std(0x7E4, &[0x5D, 0x78, 0x56, 0x34, 0x12, 0, 0, 0])),
        "LSS response inquire serial number: 0x12345678"
    );
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
    // Issue 13 point 7: PDU1 (PF below F0h) carries the destination, not part of the PGN.
    assert_eq!(d(Frame::new(CanId::Ext(0x18EA_FF80), &[])), "29-bit 18EAFF80 (J1939 PGN 0EA00 to FF, malformed)");
    assert_eq!(d(Frame::new(CanId::Ext(0x0CEF_2A80), &[])), "SA 80h -> SA 2Ah PGN 61184 (0EF00h)");
    assert_eq!(d(Frame::new(CanId::Ext(0x18FE_F180), &[])), "SA 80h PGN 65265 (0FEF1h)");
    // J1939 frames: group, source (destination), meaning.
    assert_eq!(
        d(Frame::new(CanId::Ext(0x18EE_FFEF), &[0x45, 0x23, 0x21, 0x8E, 0, 0x8E, 0, 0xB0])),
        "SA EFh -> all Address Claimed NAME B0008E008E212345"
    );
    assert_eq!(
        d(Frame::new(CanId::Ext(0x0CFC_5FEF), &[0x45, 0x23, 1, 0, 0xFF, 0xFF, 0xFF, 0xFF])),
        "SA EFh EPOS position=74565"
    );
    assert_eq!(
        d(Frame::new(CanId::Ext(0x1C05_00EF), &[0x4B, 0, 0x30, 2, 0x32, 0, 0, 0])),
        "SA EFh -> SA 00h CAM11 3000:02 = 32"
    );
    assert_eq!(
        d(Frame::new(CanId::Ext(0x04FC_68EF), &[0, 0, 0, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF])),
        "SA EFh EMCY 0000 register 00 (error reset)"
    );
    assert_eq!(d(Frame::remote(CanId::Std(0x70A), 1)), "node guarding request to SGH10#10");
}

/// Issue 13 point 7: the view's lines fit an 80-column terminal (cut with `…`), and are left
/// whole where the view goes to a file.
#[test]
fn view_lines_fit_the_terminal() {
    let node = Node::new(TableOnly(sgh10::TABLE), 10, Bitrate::K500);
    let known = [Known { label: "SGH10", core: node.core() }];
    let f = Frame::std(0x28A, &[0x34, 0x12, 0, 0, 5, 0]);
    let text = format!("{}  (client 12)", describe(&f, &known));
    let whole = view_line("can0", &f, &text, None);
    assert!(whole.chars().count() > 80, "{whole}");
    assert!(
        whole.starts_with("can0       28A  [6]  34 12 00 00 05 00        SGH10#10 TPDO2 Position value=4660"),
        "{whole}"
    );
    let cut = view_line("can0", &f, &text, Some(80));
    assert_eq!(cut.chars().count(), 80, "{cut}");
    assert!(cut.ends_with('…') && whole.starts_with(cut.trim_end_matches('…')), "{cut}");
    let short = view_line("can0", &Frame::std(0x80, &[]), "SYNC", Some(80));
    assert_eq!(short, format!("can0       080  [0]  {}SYNC", " ".repeat(25)));
    assert_eq!(fit("abc", Some(3)), "abc");
    assert_eq!(fit("abcd", Some(3)), "ab…");
    let rtr = view_line("can0", &Frame::remote(CanId::Std(0x70A), 1), "x", None);
    assert!(rtr.contains("[1]  remote request"), "{rtr}");
}

/// Issue 13 point 7: the bench master addresses configured nodes only.
#[test]
fn the_bench_master_leaves_unconfigured_nodes_alone() {
    let mut m = BenchMaster::new(&[(0, 10), (0, UNCONFIGURED), (0, 20)]);
    let mut frames = Vec::new();
    for ms in (0..=6000).step_by(50) {
        frames.extend(m.due(ms));
    }
    let ids: Vec<u16> = frames
        .iter()
        .map(|(_, f)| match f.id {
            CanId::Std(id) => id,
            CanId::Ext(_) => panic!("29-bit"),
        })
        .collect();
    assert!(ids.contains(&0x60A) && ids.contains(&0x614), "{ids:X?}");
    assert!(!ids.contains(&0x6FF) && !ids.contains(&0x67F), "{ids:X?}");
    let nmt: Vec<&[u8]> = frames.iter().filter(|(_, f)| f.id == CanId::Std(0)).map(|(_, f)| f.payload()).collect();
    assert_eq!(nmt, vec![&[1u8, 10][..], &[1, 20]]);
    assert!(ids.contains(&0x080), "SYNC follows");
}

/// Issue 13 point 2: a frame's time on the bus from its bits (worst-case stuffing).
#[test]
fn frame_times_follow_the_bit_rate() {
    // 8 data bytes, 11-bit: 98 stuffed bits + 24 stuff bits + 13 = 135 bits.
    assert_eq!(frame_time(&Frame::std(0x601, &[0; 8]), Bitrate::K500), 270);
    assert_eq!(frame_time(&Frame::std(0x601, &[0; 8]), Bitrate::K1000), 135);
    assert_eq!(frame_time(&Frame::std(0x601, &[0; 8]), Bitrate::K125), 1080);
    // SYNC: 34 + 8 + 13 = 55 bits.
    assert_eq!(frame_time(&Frame::std(0x80, &[]), Bitrate::K250), 220);
    // 29-bit, 8 bytes: 118 + 29 + 13 = 160 bits.
    assert_eq!(frame_time(&Frame::new(CanId::Ext(0x18FE_F100), &[0; 8]), Bitrate::K250), 640);
    // A remote frame carries no data, whatever its DLC.
    assert_eq!(frame_time(&Frame::remote(CanId::Std(0x70A), 8), Bitrate::K500), 110);
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

/// The binary under test: `$SIM_BIN` if set (to run these tests against another build), else
/// the one Cargo built.
fn sim_bin() -> String {
    std::env::var("SIM_BIN").unwrap_or_else(|_| env!("CARGO_BIN_EXE_sim").to_string())
}

/// A running `sim`, killed when dropped.
struct Sim(Child, u16);

impl Sim {
    fn start(args: &[&str]) -> Sim {
        let port = free_port();
        let listen = format!("127.0.0.1:{port}");
        let child = Command::new(sim_bin())
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

    /// The next message within 500 ms.
    fn next(&mut self) -> Option<String> {
        let deadline = WallClock::now() + Duration::from_millis(500);
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

    /// Sends `poke` until a frame with identifier `id` comes (at most `ms`); its data.
    fn poke_until(&mut self, poke: &str, id: &str, ms: u64) -> Option<String> {
        let deadline = WallClock::now() + Duration::from_millis(ms);
        while WallClock::now() < deadline {
            self.say(poke);
            while WallClock::now() < deadline {
                match self.frame() {
                    Some((i, data)) if i == id => return Some(data),
                    Some(_) => {}
                    None => break,
                }
            }
        }
        None
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

/// Issue 13 points 3 and 4: as socketcand, a malformed frame is dropped without an answer, an
/// unknown command gets `< error unknown command >`, an unknown bus `< error could not open
/// bus >` and the end of the connection; no answer repeats the client's text.
#[test]
fn bad_input_is_dropped_or_refused_as_socketcand_does_and_stops_nothing() {
    let sim = Sim::start(&["--device", "sgh10:node=10"]);
    let mut other = sim.open("can0");
    let mut c = sim.client();
    c.say(&f(0x000, &[0x82, 0]));
    assert_eq!(c.next().as_deref(), Some("< error unknown command >"), "a frame before rawmode");
    c.say("< open can0 >< rawmode >");
    assert_eq!(c.next().as_deref(), Some("< ok >"));
    assert_eq!(c.next().as_deref(), Some("< ok >"));
    c.say("< send 601 9 1 2 3 4 5 6 7 8 9 >garbage< send 601 2 1 >< send 601 1 +1 >");
    c.w.write_all(&[0xFF, 0xFE, b'\n']).unwrap();
    c.say(&format!("< send 601 1 {} >", "7".repeat(2000)));
    c.say("< frobnicate >");
    assert_eq!(c.next().as_deref(), Some("< error unknown command >"), "the unknown command only");
    // The simulator and the other client go on; the client gets frames, nothing else.
    c.say(&f(0x000, &[0x81, 10]));
    assert_eq!(other.wait_for("70A", 2000), Some("00".into()));
    assert_eq!(c.frame(), Some(("70A".into(), "00".into())));
    drop(c);
    let mut d = sim.client();
    d.say("< open can7 >< open can0 >");
    assert_eq!(d.next().as_deref(), Some("< error could not open bus >"));
    assert_eq!(d.next(), None, "the connection ends");
    let mut e = sim.open("can0");
    e.say(&f(0x000, &[0x82, 10]));
    assert_eq!(other.wait_for("70A", 2000), Some("00".into()));
}

/// Issue 13 point 4: the malformed messages a client sent are counted in the live view.
#[test]
fn the_view_counts_malformed_messages() {
    let port = free_port();
    let mut child = Command::new(sim_bin())
        .args(["--listen", &format!("127.0.0.1:{port}"), "--device", "sgh10:node=10"])
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let stdout = child.stdout.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in std::io::BufRead::lines(std::io::BufReader::new(stdout)).map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    let deadline = WallClock::now() + Duration::from_secs(10);
    while TcpStream::connect(("127.0.0.1", port)).is_err() && WallClock::now() < deadline {
        std::thread::sleep(Duration::from_millis(20));
    }
    let sim = Sim(child, port);
    let mut c = sim.open("can0");
    c.say("< send 601 9 1 >< send 601 2 1 >< send 601 1 zz >");
    c.say("< sendrtr 70A 1 >");
    let mut seen = Vec::new();
    let found = loop {
        match rx.recv_timeout(Duration::from_secs(5)) {
            Ok(line) if line.contains("malformed") => break Some(line),
            Ok(line) => seen.push(line),
            Err(_) => break None,
        }
    };
    let line = found.unwrap_or_else(|| panic!("no count in the view: {seen:#?}"));
    assert!(line.contains(" on can0: 3 malformed messages dropped"), "{line}");
    assert!(seen.iter().any(|l| l.contains("remote request") && l.contains("node guarding request")), "{seen:#?}");
}

/// The resident memory of process `pid`, in KiB (Linux).
fn rss_kib(pid: u32) -> Option<u64> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let line = status.lines().find(|l| l.starts_with("VmRSS:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

/// Issue 13 point 3: clients that send garbage and never read cost the simulator bounded
/// memory: their input is dropped, the replies wait bounded in bytes, then TCP holds them.
#[test]
fn clients_that_send_garbage_and_never_read_cost_bounded_memory() {
    let sim = Sim::start(&["--device", "sgh10:node=10"]);
    let Some(before) = rss_kib(sim.0.id()) else { return };
    // Text outside `< >` and unknown commands: the old simulator answered each with an error
    // that repeated up to 1 KB of the text.
    let garbage: String = ("x".repeat(1000) + "< bogus >< send 601 1 zz >< echo >").repeat(200);
    let writers: Vec<_> = (0..20)
        .map(|_| {
            let s = TcpStream::connect(("127.0.0.1", sim.1)).unwrap();
            let garbage = garbage.clone();
            std::thread::spawn(move || {
                s.set_write_timeout(Some(Duration::from_millis(300))).unwrap();
                let mut s = s;
                let mut sent = 0usize;
                let deadline = WallClock::now() + Duration::from_secs(3);
                while WallClock::now() < deadline && s.write_all(garbage.as_bytes()).is_ok() {
                    sent += garbage.len();
                }
                (s, sent)
            })
        })
        .collect();
    let held: Vec<(TcpStream, usize)> = writers.into_iter().map(|w| w.join().unwrap()).collect();
    let after = rss_kib(sim.0.id()).unwrap();
    let sent: usize = held.iter().map(|h| h.1).sum();
    // Unbounded, the replies alone (24 bytes for 9 bytes of `< bogus >`) grow far beyond this.
    assert!(after < before + 40 * 1024, "{before} KiB -> {after} KiB after {sent} bytes of garbage");
    // And the simulator still serves.
    let mut c = sim.open("can0");
    c.say(&f(0x60A, &[0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0]));
    assert!(c.wait_for("58A", 2000).is_some());
    drop(held);
}

/// Issue 13 point 1: a node's answers are drained after every frame, so a burst written at
/// once loses none.
#[test]
fn a_burst_of_a_thousand_reads_gets_a_thousand_answers() {
    let sim = Sim::start(&["--device", "sgh10:node=10"]);
    let mut c = sim.open("can0");
    let read = f(0x60A, &[0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0]);
    c.say(&read.repeat(1000));
    let (mut answers, deadline) = (0, WallClock::now() + Duration::from_secs(20));
    while answers < 1000 && WallClock::now() < deadline {
        if let Some((id, data)) = c.frame() {
            assert_eq!((id.as_str(), &data[..8]), ("58A", "43181001"));
            answers += 1;
        }
    }
    assert_eq!(answers, 1000);
    assert_eq!(c.next(), None, "no more");
}

/// Issue 13 point 1: a "save" behind 40 reads in one write is answered, written to the flash
/// and survives a power cycle.
#[test]
fn a_save_behind_forty_reads_is_kept() {
    let dir = tempdir("burst-save");
    let state = dir.to_str().unwrap();
    {
        let sim = Sim::start(&["--device", "sgh10:node=10", "--state-dir", state]);
        let mut c = sim.open("can0");
        c.say(&f(0x60A, &[0x2B, 0x17, 0x10, 0x00, 0x09, 0x03, 0, 0]));
        assert_eq!(c.wait_for("58A", 1000), Some("6017100000000000".into()));
        let read = f(0x60A, &[0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0]);
        let save = f(0x60A, &[0x23, 0x10, 0x10, 0x01, b's', b'a', b'v', b'e']);
        c.say(&(read.repeat(40) + &save));
        let mut answers = Vec::new();
        while let Some(data) = c.wait_for("58A", 1000) {
            answers.push(data);
        }
        assert_eq!(answers.len(), 41, "{answers:?}");
        assert_eq!(answers[40], "6010100100000000", "the save is answered");
    }
    let sim = Sim::start(&["--device", "sgh10:node=10", "--state-dir", state]);
    let mut c = sim.open("can0");
    c.say(&f(0x60A, &[0x40, 0x17, 0x10, 0x00, 0, 0, 0, 0]));
    assert_eq!(c.wait_for("58A", 1000), Some("4B17100009030000".into()), "1017h = 777 after the power cycle");
    drop(sim);
    let _ = std::fs::remove_dir_all(dir);
}

/// Issue 13 point 2: a client that floods the bus waits for it (its socket is not read
/// meanwhile); another client's SDO read is answered at once and the memory stays bounded.
#[test]
fn a_flooding_client_waits_and_delays_no_one_else() {
    let sim = Sim::start(&["--device", "sgh10:node=10"]);
    let before = rss_kib(sim.0.id());
    let mut c = sim.open("can0");
    // A heartbeat every 100 ms, to see it keep its period through the flood.
    c.say(&f(0x60A, &[0x2B, 0x17, 0x10, 0x00, 100, 0, 0, 0]));
    assert_eq!(c.wait_for("58A", 1000), Some("6017100000000000".into()));
    let flooder = sim.open("can0");
    let flood = f(0x123, &[0x11, 0x22, 0x33, 0x44, 0x55, 0x66, 0x77, 0x88]).repeat(100);
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let stop2 = stop.clone();
    let writer = std::thread::spawn(move || {
        let mut w = flooder.w;
        w.set_write_timeout(Some(Duration::from_millis(100))).unwrap();
        let mut sent = 0usize;
        while !stop2.load(std::sync::atomic::Ordering::Relaxed) {
            if w.write_all(flood.as_bytes()).is_ok() {
                sent += 100;
            }
        }
        sent
    });
    let mut worst = Duration::ZERO;
    let mut heartbeats = Vec::new();
    let mut read_until = |c: &mut Client, id: &str, until: WallClock| -> bool {
        while WallClock::now() < until {
            let Some(msg) = c.next() else { continue };
            let parts: Vec<&str> = msg.split(' ').collect();
            if parts.get(2) == Some(&"70A") {
                heartbeats.push(parts[3].parse::<f64>().unwrap());
            }
            if parts.get(2) == Some(&id) {
                return true;
            }
        }
        false
    };
    read_until(&mut c, "none", WallClock::now() + Duration::from_millis(500));
    for _ in 0..10 {
        let t = WallClock::now();
        c.say(&f(0x60A, &[0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0]));
        assert!(read_until(&mut c, "58A", t + Duration::from_secs(5)), "answered");
        worst = worst.max(t.elapsed());
        read_until(&mut c, "none", WallClock::now() + Duration::from_millis(100));
    }
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    let sent = writer.join().unwrap();
    // The bus carries about 3700 such frames a second at 500 kbit/s; the flooder got to write
    // those, what its queue and the sockets hold, not everything it wanted to.
    assert!(worst < Duration::from_millis(500), "an SDO read waited {worst:?} behind {sent} flood frames");
    let gap = heartbeats.windows(2).map(|w| w[1] - w[0]).fold(0.0, f64::max);
    assert!(heartbeats.len() >= 10 && gap < 0.3, "heartbeat gap {gap:.3} s, {} heartbeats", heartbeats.len());
    if let (Some(before), Some(after)) = (before, rss_kib(sim.0.id())) {
        assert!(after < before + 40 * 1024, "{before} KiB -> {after} KiB after {sent} flood frames");
    }
}

/// Issue 13 point 2: the bus carries frames at its bit rate, no faster: 1000 frames of 8 bytes
/// at 125 kbit/s (1080 µs each) take at least a second, by the timestamps the observer gets.
#[test]
fn the_bus_carries_its_bit_rate_and_no_more() {
    let sim = Sim::start(&["--device", "sgh10:node=10", "--bitrate", "can0=125"]);
    let mut sender = sim.open("can0");
    let mut observer = sim.open("can0");
    sender.say(&f(0x123, &[1, 2, 3, 4, 5, 6, 7, 8]).repeat(1000));
    let mut stamps = Vec::new();
    let deadline = WallClock::now() + Duration::from_secs(15);
    while stamps.len() < 1000 && WallClock::now() < deadline {
        if let Some(msg) = observer.next() {
            let t: f64 = msg.split(' ').nth(3).unwrap().parse().unwrap();
            stamps.push(t);
        }
    }
    assert_eq!(stamps.len(), 1000);
    let span = stamps[999] - stamps[0];
    assert!(span >= 1.0, "1000 frames in {span:.3} s: faster than 125 kbit/s carries them");
}

/// Issue 13 point 5: remote frames both ways: node guarding through `< sendrtr >`, and the
/// other clients see `< rtr ID SEC.USEC DLC >`.
#[test]
fn remote_frames_cross_the_simulator() {
    let sim = Sim::start(&["--device", "sgh10:node=10"]);
    let mut a = sim.open("can0");
    let mut b = sim.open("can0");
    a.say("< sendrtr 70A 1 >");
    let rtr = b.next().unwrap();
    assert!(rtr.starts_with("< rtr 70A ") && rtr.ends_with(" 1 >"), "{rtr}");
    assert_eq!(a.wait_for("70A", 1000), Some("7F".into()), "the guarding answer: pre-operational, toggle 0");
    // python-can's remote frame: the DLC without bytes.
    a.say("< send 70A 1  >");
    assert_eq!(a.wait_for("70A", 1000), Some("FF".into()), "toggle 1");
}

/// Runs `sim` with `args` on a free port; returns its exit status and standard error if it ends
/// within five seconds (`None`: it kept running and was stopped).
fn run_briefly(args: &[&str]) -> Option<(Option<i32>, String)> {
    let mut child = Command::new(sim_bin())
        .args(["--quiet", "--listen", &format!("127.0.0.1:{}", free_port())])
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let deadline = WallClock::now() + Duration::from_secs(5);
    while WallClock::now() < deadline {
        if let Some(status) = child.try_wait().unwrap() {
            let mut err = String::new();
            child.stderr.take().unwrap().read_to_string(&mut err).unwrap();
            return Some((status.code(), err));
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let _ = child.kill();
    let _ = child.wait();
    None
}

/// Issue 13 point 6: two devices on one node-ID of one bus are refused, with the reason.
#[test]
fn two_devices_on_one_node_id_are_refused() {
    for args in [
        &["--device", "sgh10:node=10", "--device", "wv5800m:node=10"][..],
        &["--device", "sgh10", "--device", "sgh10"],
        &["--device", "sgh10:node=21", "--device", "sgh50:node=20,redundant=true"],
    ] {
        let (code, err) = run_briefly(args).expect("refused at start");
        assert_eq!(code, Some(1), "{args:?}");
        assert!(err.contains("both have node-ID") && err.contains("node="), "{args:?}: {err}");
    }
    let (_, err) =
        run_briefly(&["--device", "sgh10:serial=5", "--device", "sgh10:serial=5,node=2"]).expect("refused at start");
    assert!(err.contains("same LSS address"), "{err}");
}

/// Issue 13 point 7: a `--bitrate` for a bus without devices is refused; a bus where no node
/// runs at the bus's rate starts with a hint.
#[test]
fn bit_rates_nobody_uses_are_refused_or_hinted() {
    let (code, err) = run_briefly(&["--device", "sgh10", "--bitrate", "can3=250"]).expect("refused at start");
    assert_eq!(code, Some(1));
    assert!(err.contains("--bitrate can3=250: no device on can3"), "{err}");
    let mut child = Command::new(sim_bin())
        .args(["--quiet", "--listen", &format!("127.0.0.1:{}", free_port()), "--device", "sgh10:node=10"])
        .args(["--bitrate", "can0=250"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let stderr = child.stderr.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let mut line = String::new();
        let _ = std::io::BufRead::read_line(&mut std::io::BufReader::new(stderr), &mut line);
        let _ = tx.send(line);
    });
    let line = rx.recv_timeout(Duration::from_secs(5)).unwrap_or_default();
    let _ = child.kill();
    let _ = child.wait();
    assert!(line.contains("hint: no node on can0 runs at its 250 kbit/s"), "{line}");
    assert!(line.contains("--bitrate can0=500"), "{line}");
}

#[test]
fn a_wv58mr_pair_claims_and_publishes_on_can1() {
    let sim = Sim::start(&["--device", "wv58mr:redundant=true,serial=1000,position=74565"]);
    let mut c = sim.open("can1");
    // Both claim EFh after their delays; the higher NAME moves to 80h; both publish EPOS.
    assert!(c.wait_for("0CFC5FEF", 3000).is_some(), "EPOS from EFh");
    assert_eq!(c.wait_for("0CFC5F80", 3000).as_deref(), Some("45230100FFFFFFFF"));
    // CAM21 read of 3000h.02 from EFh.
    c.say("< send 1C06EF00 8 40 00 30 02 00 00 00 00 >");
    assert_eq!(c.wait_for("1C0500EF", 2000).as_deref(), Some("4B00300232000000"));
}

#[test]
fn the_bench_has_a_wv58mr_pair_on_can1_that_the_master_leaves_alone() {
    let sim = Sim::start(&[]);
    let mut c = sim.open("can1");
    assert!(c.wait_for("0CFC5FEF", 3000).is_some(), "EPOS from EFh");
    assert!(c.wait_for("0CFC5F80", 3000).is_some(), "EPOS from 80h");
    // No CANopen frame reaches can1 within the bench master's first requests.
    let deadline = WallClock::now() + Duration::from_millis(1500);
    while WallClock::now() < deadline {
        if let Some((id, _)) = c.frame() {
            assert_eq!(id.len(), 8, "an 11-bit frame on can1: {id}");
        }
    }
}

#[test]
fn bad_options_fail_cleanly_and_help_lists_the_options() {
    let out = Command::new(sim_bin()).args(["--device", "sgh10:node=0"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let out = Command::new(sim_bin()).arg("--help").output().unwrap();
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
        c.say("< sendrtr 70A 1 >");
        std::thread::sleep(Duration::from_millis(200));
    }
    let sim = Sim::start(&["--device", "sgh10:node=10", "--state-dir", state]);
    let mut c = sim.open("can0");
    c.say(&f(0x000, &[0x82, 0]));
    assert_eq!(c.wait_for("72A", 1000), Some("00".into()), "the stored node-ID 42 is kept");
    let trace = std::fs::read_to_string(dir.join("t.log")).unwrap();
    assert!(trace.lines().any(|l| l.ends_with(" can0 70A#R1")), "the remote frame: {trace}");
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
    let out = Command::new(sim_bin())
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

// ---- the control port ----

/// A client of the control port (`--control`): one command, one reply line.
struct Control(std::io::BufReader<TcpStream>);

impl Control {
    fn connect(port: u16) -> Control {
        let s = TcpStream::connect(("127.0.0.1", port)).unwrap();
        s.set_read_timeout(Some(Duration::from_secs(2))).unwrap();
        Control(std::io::BufReader::new(s))
    }

    fn ask(&mut self, command: &str) -> String {
        use std::io::BufRead;
        writeln!(self.0.get_mut(), "{command}").unwrap();
        let mut line = String::new();
        self.0.read_line(&mut line).unwrap();
        line.trim_end().to_string()
    }

    /// Asks `command` until the reply contains `want` (at most 3 s); the last reply.
    fn until(&mut self, command: &str, want: &str) -> String {
        let deadline = WallClock::now() + Duration::from_secs(3);
        loop {
            let r = self.ask(command);
            if r.contains(want) || WallClock::now() > deadline {
                return r;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

/// The value of an expedited SDO upload of `index`.`sub` from `node`, through client `c`.
fn sdo_read(c: &mut Client, node: u8, index: u16, sub: u8) -> u32 {
    let [lo, hi] = index.to_le_bytes();
    c.say(&f(0x600 + u16::from(node), &[0x40, lo, hi, sub, 0, 0, 0, 0]));
    let data = c.wait_for(&format!("{:03X}", 0x580 + u16::from(node)), 1000).expect("SDO answer");
    assert!(data.starts_with("4"), "an expedited answer, not an abort: {data}");
    let b: Vec<u8> = (8..16).step_by(2).map(|k| u8::from_str_radix(&data[k..k + 2], 16).unwrap()).collect();
    u32::from_le_bytes([b[0], b[1], b[2], b[3]])
}

#[test]
fn the_control_port_lists_presses_shows_and_positions() {
    let port = free_port();
    let addr = format!("127.0.0.1:{port}");
    let sim = Sim::start(&["--control", &addr, "--device", "ap10t", "--device", "wv5800m:node=30,position=100"]);
    let mut ctl = Control::connect(port);
    assert_eq!(ctl.ask("list"), "ok can0:AP10T#125 can0:WV5800M#30");
    // After the display test: no set point yet.
    assert_eq!(ctl.until("screen AP10T", "---"), "ok [   ---|   ---] LED off/off light white+red");
    // "←" shows node-ID and rate (D-AP-9), the front key goes back; names as the view gives them.
    assert_eq!(ctl.ask("press can0:AP10T#125 left"), "ok");
    assert_eq!(ctl.ask("screen can0:ap10t#125"), "ok [ID 125|  AUTO] LED off/off light white+red");
    assert_eq!(ctl.ask("press AP10T parameterize"), "ok");
    assert_eq!(ctl.ask("screen AP10T"), "ok [ID    |   125] LED off/off light white+red");
    assert_eq!(ctl.ask("press AP10T back"), "ok");
    assert_eq!(ctl.ask("screen AP10T"), "ok [   ---|   ---] LED off/off light white+red");
    // The encoder's sensor, read back over the bus.
    let mut c = sim.open("can0");
    let before = sdo_read(&mut c, 30, 0x6004, 0);
    assert_eq!(ctl.ask("position WV5800M#30 5000"), "ok");
    let after = sdo_read(&mut c, 30, 0x6004, 0);
    assert_eq!(after.wrapping_sub(before), 4900, "the position follows the sensor: {before} -> {after}");
    assert!(ctl.ask("screen WV5800M").starts_with("ok LEDs green="));
    // Errors, one line each; the connection stays usable.
    for (command, error) in [
        ("press WV5800M up", "error can0:WV5800M#30 has no keys"),
        ("press AP10T enter", "error unknown key enter"),
        ("screen AP10T#7", "error no device AP10T#7"),
        ("screen can1:AP10T", "error no device can1:AP10T"),
        ("position AP10T 5", "error can0:AP10T#125: it has no sensor"),
        ("position WV5800M 99999999", "error can0:WV5800M#30: 99999999 is beyond"),
        ("jump", "error unknown command jump"),
        ("press AP10T", "error press: wrong arguments"),
    ] {
        let r = ctl.ask(command);
        assert!(r.starts_with(error), "{command}: {r}");
    }
    assert_eq!(ctl.ask("list"), "ok can0:AP10T#125 can0:WV5800M#30");
}

#[test]
fn the_control_port_is_off_unless_given() {
    assert_eq!(Options::parse::<&str>(&[]).unwrap().control, None);
    let o = Options::parse(&["--control", "127.0.0.1:4000"]).unwrap();
    assert_eq!(o.control.as_deref(), Some("127.0.0.1:4000"));
    assert!(Options::parse(&["--control", "4000"]).is_err());
}

#[test]
fn two_devices_of_one_label_need_their_number() {
    let port = free_port();
    let addr = format!("127.0.0.1:{port}");
    let _sim = Sim::start(&["--control", &addr, "--device", "sgh10:node=10", "--device", "sgh10:node=11"]);
    let mut ctl = Control::connect(port);
    assert_eq!(ctl.ask("position SGH10 5"), "error SGH10 names several devices: can0:SGH10#10 can0:SGH10#11");
    assert_eq!(ctl.ask("position SGH10#11 5"), "ok");
}

// ---- the bench's display ----

#[test]
fn the_bench_master_starts_the_display_and_feeds_it_the_encoders_position() {
    let mut m = BenchMaster::new(&[(0, 10), (0, 40)]).with_display(0, 40, 10);
    let quiet = m.deadline();
    assert!(quiet > 0);
    // Another bus, a remote frame, another node's boot-up: nothing.
    m.heard(1, &Frame::std(0x728, &[0]));
    m.heard(0, &Frame::std(0x729, &[0]));
    m.heard(0, &Frame::remote(CanId::Std(0x28A), 6));
    assert_eq!(m.deadline(), quiet);
    // The display boots up: the master starts it at once.
    m.heard(0, &Frame::std(0x728, &[0]));
    assert_eq!(m.deadline(), 0);
    assert_eq!(m.due(0), vec![(0, Frame::std(0x000, &[0x01, 40]))]);
    // The SGH10's TPDO2 (position 7546, speed 59) becomes set point 1, valid and acknowledged.
    m.heard(0, &Frame::std(0x28A, &[0x7A, 0x1D, 0, 0, 0x3B, 0]));
    assert_eq!(m.due(1), vec![(0, Frame::std(0x228, &[0x7A, 0x1D, 0, 0, 0, 0, 0x04, 0x04]))]);
    assert_eq!(m.deadline(), quiet);
    // Without a display the master answers nothing.
    let mut plain = BenchMaster::new(&[(0, 10)]);
    plain.heard(0, &Frame::std(0x28A, &[1, 2, 3, 4, 0, 0]));
    assert!(plain.due(0).is_empty());
}

#[test]
fn the_bench_display_shows_the_sgh10_position() {
    let port = free_port();
    let addr = format!("127.0.0.1:{port}");
    let sim = Sim::start(&["--control", &addr]);
    let mut ctl = Control::connect(port);
    assert!(ctl.ask("list").contains("can0:AP10T#40"));
    let mut c = sim.open("can0");
    // The display detects the rate from the bench's traffic, boots up and is started; after a
    // SYNC the SGH10's position goes to it.
    let deadline = WallClock::now() + Duration::from_secs(12);
    let (mut position, mut set_point) = (None, None);
    let mut sent = Vec::new();
    let mut watch = |c: &mut Client, position: &mut Option<String>, set_point: &mut Option<String>| {
        if let Some((id, data)) = c.frame() {
            match id.as_str() {
                "28A" => *position = Some(data[..8].to_string()),
                "228" => {
                    assert_eq!(&data[8..], "00000404", "valid, acknowledged by the master");
                    *set_point = Some(data[..8].to_string());
                    sent.push(u32::from_str_radix(&data[..8], 16).unwrap().swap_bytes());
                }
                _ => {}
            }
        }
    };
    while set_point.is_none() || set_point != position {
        assert!(WallClock::now() < deadline, "no set point from the SGH10: {position:?} {set_point:?}");
        watch(&mut c, &mut position, &mut set_point);
    }
    // The screen shows a set point the master sent (it changes every second: those sent
    // shortly after the question count too).
    let shown = ctl.ask("screen AP10T");
    let until = WallClock::now() + Duration::from_millis(1200);
    while WallClock::now() < until {
        watch(&mut c, &mut position, &mut set_point);
    }
    let row: String = shown.trim_start_matches("ok [").chars().take_while(|&ch| ch != '|').collect();
    let value: u32 = row.trim().parse().unwrap_or_else(|_| panic!("not a number: {shown}"));
    assert!(sent.contains(&value), "{shown} not among {sent:?}");
    assert!(shown.ends_with("] LED green/off light white+red"), "acknowledged: {shown}");
}

// ---- the AP10T ----

#[test]
fn the_registry_builds_an_ap10t_that_shows_its_panel() {
    let r = Registry::new(None);
    let plan = r.build(&parse_device("ap10t:node=5").unwrap(), 1, 0).unwrap().pop().unwrap();
    assert_eq!(plan.label, "AP10T");
    let mut params = plan.params;
    let mut node = (plan.boot)(&params.load());
    assert_eq!(node.core().node_id, 5);
    // The display test at power-on, then the set points ("---": none received).
    node.poll(od_core::Instant::ZERO);
    assert_eq!(node.panel().as_deref(), Some("[8.8.8.8.8.8.|8.8.8.8.8.8.] LED green/off light white+red"));
    node.poll(od_core::Instant::from_millis(1000));
    assert_eq!(node.panel().as_deref(), Some("[   ---|   ---] LED off/off light white+red"));
    for bad in ["ap10t:redundant=true", "ap10t:serial=5", "ap10t:motion=ramp:5"] {
        assert!(r.build(&parse_device(bad).unwrap(), 1, 0).is_err(), "{bad}");
    }
}

#[test]
fn a_factory_ap10t_detects_a_250_kbit_bus_and_takes_a_set_point() {
    let sim = Sim::start(&["--device", "ap10t", "--bitrate", "can0=250"]);
    let mut c = sim.open("can0");
    // Silent until it hears traffic at its rate; then the boot-up of node 7Dh.
    assert_eq!(c.poke_until(&f(0x000, &[0x80, 0x00]), "77D", 8000).as_deref(), Some("00"));
    // Start it, send set point 1 = 12345 and read it back by RTR-less SYNC (TPDO2 is set
    // point 2) and by the status word over SDO: valid, not acknowledged.
    c.say(&f(0x000, &[0x01, 0x7D]));
    c.say(&f(0x27D, &[0x39, 0x30, 0x00, 0x00, 0x00, 0x00, 0x04, 0x00]));
    let sw = c.poke_until(&f(0x67D, &[0x40, 0x19, 0x5F, 0x00, 0, 0, 0, 0]), "5FD", 2000);
    assert_eq!(sw.as_deref(), Some("4B195F0004000000"));
}
