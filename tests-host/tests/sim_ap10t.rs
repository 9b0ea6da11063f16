//! The AP10T in the simulator: `--device ap10t` builds a display whose front panel shows in the
//! live view, and on a socketcand bus it detects the bus's rate, boots up and takes set points.

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant as WallClock};

use od_core::Frame;
use tests_host::sim::devices::Registry;
use tests_host::sim::options::parse_device;
use tests_host::sim::socketcand as sc;

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

/// A running `sim`, killed when dropped.
struct Sim(Child, u16);

impl Sim {
    fn start(args: &[&str]) -> Sim {
        let port = TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
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
}

impl Drop for Sim {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// A rawmode client on can0.
struct Client {
    s: TcpStream,
    buf: String,
}

impl Client {
    fn open(sim: &Sim) -> Client {
        let s = TcpStream::connect(("127.0.0.1", sim.1)).unwrap();
        s.set_read_timeout(Some(Duration::from_millis(100))).unwrap();
        let mut c = Client { s, buf: String::new() };
        assert_eq!(c.next(1000).as_deref(), Some("< hi >"));
        c.s.write_all(b"< open can0 >").unwrap();
        assert_eq!(c.next(1000).as_deref(), Some("< ok >"));
        c.s.write_all(b"< rawmode >").unwrap();
        assert_eq!(c.next(1000).as_deref(), Some("< ok >"));
        c
    }

    fn next(&mut self, ms: u64) -> Option<String> {
        let deadline = WallClock::now() + Duration::from_millis(ms);
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
            if let Ok(n) = self.s.read(&mut chunk) {
                if n == 0 {
                    return None;
                }
                self.buf.push_str(std::str::from_utf8(&chunk[..n]).unwrap());
            }
        }
    }

    fn send(&mut self, id: u16, data: &[u8]) {
        self.s.write_all(sc::send_message(&Frame::std(id, data)).as_bytes()).unwrap();
    }

    /// Sends `poke` every 100 ms until a frame with `id` comes (at most `ms`); its data.
    fn poke_until(&mut self, poke: (u16, &[u8]), id: &str, ms: u64) -> Option<String> {
        let deadline = WallClock::now() + Duration::from_millis(ms);
        while WallClock::now() < deadline {
            self.send(poke.0, poke.1);
            while let Some(msg) = self.next(100) {
                let parts: Vec<&str> = msg.trim_start_matches("< frame ").trim_end_matches(" >").split(' ').collect();
                if msg.starts_with("< frame ") && parts[0] == id {
                    return Some(parts.get(2).unwrap_or(&"").to_string());
                }
            }
        }
        None
    }
}

#[test]
fn a_factory_ap10t_detects_a_250_kbit_bus_and_takes_a_set_point() {
    let sim = Sim::start(&["--device", "ap10t", "--bitrate", "can0=250"]);
    let mut c = Client::open(&sim);
    // Silent until it hears traffic at its rate; then the boot-up of node 7Dh.
    assert_eq!(c.poke_until((0x000, &[0x80, 0x00]), "77D", 8000).as_deref(), Some("00"));
    // Start it, send set point 1 = 12345 and read it back by RTR-less SYNC (TPDO2 is set
    // point 2) and by the status word over SDO: valid, not acknowledged.
    c.send(0x000, &[0x01, 0x7D]);
    c.send(0x27D, &[0x39, 0x30, 0x00, 0x00, 0x00, 0x00, 0x04, 0x00]);
    let sw = c.poke_until((0x67D, &[0x40, 0x19, 0x5F, 0x00, 0, 0, 0, 0]), "5FD", 2000);
    assert_eq!(sw.as_deref(), Some("4B195F0004000000"));
}
