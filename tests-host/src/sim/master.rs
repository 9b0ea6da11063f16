//! The ready-made bench's master: it asks each configured node for its identity, sets its
//! heartbeat, starts it, and then sends SYNC periodically, so the bench shows every service.
//! With a display ([`BenchMaster::with_display`]) it also starts the display when it boots up
//! and sends it, as set point 1, the position an encoder reports on the bus (D-SIM-19).

use od_core::{CanId, Frame};

/// The bench master's SYNC period.
pub const SYNC_MS: u64 = 1000;

/// The master's script and SYNC timer.
pub struct BenchMaster {
    /// (time in ms, bus, frame), in time order.
    script: Vec<(u64, usize, Frame)>,
    next: usize,
    next_sync: u64,
    /// The display fed from an encoder, if any.
    display: Option<Feed>,
    /// Answers to frames the master heard, sent at once: (bus, frame).
    queued: Vec<(usize, Frame)>,
}

/// An AP10T on `bus` at node `node`, fed the position of the encoder at node `source` there.
#[derive(Clone, Copy)]
struct Feed {
    bus: usize,
    node: u8,
    source: u8,
}

/// The control word the master sends with a set point: set point 1 valid and acknowledged by
/// the master (bits 2 and 10), so a value that changes every second stands steady.
pub const SET_POINT_CONTROL: u16 = (1 << 2) | (1 << 10);

impl BenchMaster {
    /// A master for `nodes`, each as (bus, node-ID). A node without a node-ID (unconfigured,
    /// FFh: it answers LSS only, D-LSS-5) gets nothing: it has no SDO server and no NMT address.
    /// SYNC goes to bus 0.
    pub fn new(nodes: &[(usize, u8)]) -> BenchMaster {
        let mut script = Vec::new();
        let mut t = 500;
        for &(b, id) in nodes.iter().filter(|(_, id)| (1..=127).contains(id)) {
            let sdo = 0x600 + u16::from(id);
            script.push((t, b, Frame::std(sdo, &[0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0])));
            script.push((t + 100, b, Frame::std(sdo, &[0x2B, 0x17, 0x10, 0x00, 0xE8, 0x03, 0, 0])));
            script.push((t + 200, b, Frame::std(0x000, &[0x01, id])));
            t += 400;
        }
        BenchMaster { script, next: 0, next_sync: t + 500, display: None, queued: Vec::new() }
    }

    /// Also feeds the AP10T `node` on `bus`: when it boots up (a boot-up message on 700h +
    /// node) the master starts it, and each position the encoder at node `source` on that bus
    /// sends in TPDO2 (on every SYNC, bytes 0-3) goes to the display by RPDO1 (200h + node)
    /// as set point 1 with [`SET_POINT_CONTROL`].
    pub fn with_display(mut self, bus: usize, node: u8, source: u8) -> BenchMaster {
        self.display = Some(Feed { bus, node, source });
        self
    }

    /// A frame the bus `b` carried (the master's own too): what it answers goes out at the
    /// next [`BenchMaster::due`].
    pub fn heard(&mut self, b: usize, frame: &Frame) {
        let Some(feed) = self.display.filter(|d| d.bus == b) else { return };
        let CanId::Std(id) = frame.id else { return };
        if frame.rtr {
            return;
        }
        if id == 0x700 + u16::from(feed.node) && frame.payload() == [0x00] {
            self.queued.push((b, Frame::std(0x000, &[0x01, feed.node])));
        } else if id == 0x280 + u16::from(feed.source) && frame.len >= 4 {
            let p = frame.payload();
            let [c0, c1] = SET_POINT_CONTROL.to_le_bytes();
            let rpdo = Frame::std(0x200 + u16::from(feed.node), &[p[0], p[1], p[2], p[3], 0, 0, c0, c1]);
            self.queued.push((b, rpdo));
        }
    }

    /// When the next frame is due, in ms.
    pub fn deadline(&self) -> u64 {
        if !self.queued.is_empty() {
            return 0;
        }
        self.script.get(self.next).map_or(self.next_sync, |s| s.0.min(self.next_sync))
    }

    /// The frames due at `ms`, each with its bus.
    pub fn due(&mut self, ms: u64) -> Vec<(usize, Frame)> {
        let mut out = std::mem::take(&mut self.queued);
        while let Some(&(_, b, f)) = self.script.get(self.next).filter(|s| s.0 <= ms) {
            out.push((b, f));
            self.next += 1;
        }
        if ms >= self.next_sync {
            out.push((0, Frame::std(0x080, &[])));
            self.next_sync += SYNC_MS;
        }
        out
    }
}
