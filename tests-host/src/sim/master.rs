//! The ready-made bench's master: it asks each configured node for its identity, sets its
//! heartbeat, starts it, and then sends SYNC periodically, so the bench shows every service.

use od_core::Frame;

/// The bench master's SYNC period.
pub const SYNC_MS: u64 = 1000;

/// The master's script and SYNC timer.
pub struct BenchMaster {
    /// (time in ms, bus, frame), in time order.
    script: Vec<(u64, usize, Frame)>,
    next: usize,
    next_sync: u64,
}

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
        BenchMaster { script, next: 0, next_sync: t + 500 }
    }

    /// When the next frame is due, in ms.
    pub fn deadline(&self) -> u64 {
        self.script.get(self.next).map_or(self.next_sync, |s| s.0.min(self.next_sync))
    }

    /// The frames due at `ms`, each with its bus.
    pub fn due(&mut self, ms: u64) -> Vec<(usize, Frame)> {
        let mut out = Vec::new();
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
