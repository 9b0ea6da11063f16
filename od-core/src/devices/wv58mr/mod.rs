//! WV58MR / WH58MR absolute redundant rotary encoder with SAE J1939 interface (SIKO manual
//! 81/25): its dictionary ([`table`]) and its transport-neutral behaviour ([`Wv58mr`]); the
//! J1939 side is [`crate::j1939::node`].
//!
//! The device is two encoders in one housing (§2), each a J1939 ECU with its own LEDs, NAME
//! and dictionary (D-J1939-17): firmware builds one channel, a redundant pair is two of them
//! with different serial numbers.
//!
//! The encoder behaviour is the WV5800M's ([`crate::devices::wv5800m::Wv5800m`] over this
//! table): the same CiA 406 objects with the same rules (scaling, counting direction, speed,
//! limit speeds, work areas, alarms, warnings, 5000h) and the same error codes (FF05h,
//! FF12h..FF16h, 8120h, 8140h). What differs is the WV58MR's own: writing 6003h calibrates
//! (§4.2, D-J1939-19), 6200h is 3000h.03, 3000h holds the PGN cycle times and priorities, 3001h
//! the NAME and 3002h restarts.

pub mod table;

pub use table::{hooks, table_of, DEFAULT_ADDRESS, DEFAULT_BITRATE_CODE, ENTRIES, HIGHEST_ADDRESS, LOWEST_ADDRESS};

use crate::abort::Abort;
use crate::context::{BusEvent, Context, ResetKind};
use crate::device::Device;
use crate::devices::wv5800m::{Model, Turns, Variant, Wv5800m};
use crate::encoder::{Encoder, SensorFault};
use crate::j1939::claim::State;
use crate::j1939::led::{self, LedInputs};
use crate::j1939::node::{Command, J1939Device};
use crate::led::Leds;
use crate::od::{Entry, Hook};
use crate::time::Instant;
use crate::wire::j1939::NameFields;

/// One WV58MR channel.
#[derive(Clone, Debug)]
pub struct Wv58mr {
    turns: Turns,
    encoder: Wv5800m,
    command: Option<Command>,
    /// The 3000h sub-indices written since the node last asked, as bits (bit n: 3000h.n;
    /// 6200h counts as 3000h.03).
    schedule_changes: u8,
    /// The address claimer's state as the node last told it.
    claim: State,
}

impl Wv58mr {
    /// A channel with `turns`, before its first sensor sample. Inlined, so that an image built
    /// for one measuring range links only that range's dictionary (D-J1939-26).
    #[inline]
    pub fn new(turns: Turns) -> Wv58mr {
        Wv58mr {
            turns,
            encoder: Wv5800m::with_table(Variant { model: Model::Wv, turns }, table_of(turns), &table::ENCODER_ENTRIES),
            command: None,
            schedule_changes: 0,
            claim: State::Off,
        }
    }

    /// What the channel's three LEDs show now (manual §3, D-J1939-8): green the claim as the
    /// node last reported it, red the CAN controller's state, yellow the over-speed;
    /// [`Leds::lit`] gives the blink phase at an instant.
    pub fn leds(&self) -> Leds {
        let (bus_off, warning_limit) = self.encoder.can_state();
        led::leds(&LedInputs { claim: self.claim, bus_off, warning_limit, over_speed: self.encoder.over_speed() })
    }

    /// The measuring range.
    pub const fn turns(&self) -> Turns {
        self.turns
    }

    /// Is the maximum speed exceeded (yellow LED)?
    pub const fn over_speed(&self) -> bool {
        self.encoder.over_speed()
    }

    /// Is the position value invalid (sensor fault)?
    pub const fn fault(&self) -> bool {
        self.encoder.fault()
    }

    /// The CAN controller's state as last reported: (bus-off, warning limit or error passive).
    pub const fn can_state(&self) -> (bool, bool) {
        self.encoder.can_state()
    }

    /// Brings the WV58MR's own derived entries in line after power-on or a reset: 3001h.01
    /// from the factory serial, and 6200h with 3000h.03 (D-J1939-14).
    fn start(&mut self, ctx: &mut Context) {
        let od = &mut ctx.od;
        let at = &table::ENTRIES_OF_MR;
        let serial = od.get(at.serial as usize);
        od.set(at.identity as usize, NameFields::identity_from_serial(serial));
        crate::encoder::merge_linked(od, at.position_cycle as usize, table::ENCODER_ENTRIES.cycle_timer as usize);
    }

    /// 6003h: writing the calibration value calibrates (out of the write hook's line, which
    /// the cyclic groups' parameters take).
    #[inline(never)]
    fn calibrate(&mut self, ctx: &mut Context, pos: usize, value: u32, now: Instant) -> Result<(), Abort> {
        // §4.2: writing the calibration value calibrates, "position value = 0 +
        // calibration value + application offset" at this instant (D-J1939-19).
        let s = self.encoder.scaling(&ctx.od);
        if value as i32 as i64 > s.largest() as i64 {
            return Err(Abort::INVALID_VALUE);
        }
        let raw = self.encoder.raw().ok_or(Abort::NO_DATA)?;
        ctx.od.set(table::ENCODER_ENTRIES.calibration as usize, s.calibrated_at(raw));
        ctx.od.set(pos, value);
        self.encoder.refresh(ctx, now);
        Ok(())
    }

    /// The WV5800M's write rules (out of the write hook's line).
    #[inline(never)]
    fn encoder_write(&mut self, ctx: &mut Context, pos: usize, value: u32, now: Instant) -> Result<(), Abort> {
        self.encoder.on_write(ctx, pos, value, now)
    }
}

impl Device for Wv58mr {
    fn table(&self) -> &'static [Entry] {
        // The one `new` chose: looked up again from `turns` at run time, every image would
        // link the four measuring ranges' dictionaries (D-J1939-26).
        self.encoder.table()
    }

    fn on_write(&mut self, ctx: &mut Context, pos: usize, value: u32, now: Instant) -> Result<(), Abort> {
        let Hook::Device(hook) = ctx.od.entry(pos).hook else {
            return Ok(());
        };
        match hook {
            hooks::PRESET => return self.calibrate(ctx, pos, value, now),
            // 6200h and 3000h.03: one value (D-J1939-14).
            hooks::CYCLE_TIMER => {
                ctx.od.set(table::ENTRIES_OF_MR.position_cycle as usize, value);
                self.schedule_changes |= 1 << 3;
            }
            // The transport reads the cycle times and priorities written back after the write.
            hooks::PGN_CYCLE | hooks::PGN_PRIORITY => {
                let sub = ctx.od.entry(pos).sub;
                if sub == 3 {
                    ctx.od.set(table::ENCODER_ENTRIES.cycle_timer as usize, value);
                }
                self.schedule_changes |= 1 << (sub & 7);
            }
            hooks::SAE_INIT => self.command = Some(Command::InitialiseSae),
            hooks::RESTART => self.command = Some(Command::Restart),
            _ => return self.encoder_write(ctx, pos, value, now),
        }
        Ok(())
    }

    fn on_reset(&mut self, ctx: &mut Context, kind: ResetKind, now: Instant) {
        self.command = None;
        self.schedule_changes = 0;
        self.start(ctx);
        self.encoder.on_reset(ctx, kind, now);
    }

    fn poll(&mut self, ctx: &mut Context, now: Instant) {
        self.encoder.poll(ctx, now);
    }

    fn on_bus_event(&mut self, ctx: &mut Context, event: BusEvent, now: Instant) {
        self.encoder.on_bus_event(ctx, event, now);
    }
}

impl J1939Device for Wv58mr {
    fn take_command(&mut self) -> Option<Command> {
        self.command.take()
    }

    fn take_schedule_changes(&mut self) -> u8 {
        core::mem::take(&mut self.schedule_changes)
    }

    fn over_speed(&self) -> bool {
        self.encoder.over_speed()
    }

    fn on_claim(&mut self, state: State) {
        self.claim = state;
    }

    fn process_data(&self, od: &crate::od::Od) -> (u32, i16) {
        let at = &table::ENCODER_ENTRIES;
        (od.get(at.position as usize), od.get(at.speed as usize) as u16 as i16)
    }
}

impl Encoder for Wv58mr {
    fn on_sample(&mut self, ctx: &mut Context, raw: Result<u32, SensorFault>, now: Instant) {
        self.encoder.on_sample(ctx, raw, now);
    }

    fn sample_period_us(&self) -> u32 {
        self.encoder.sample_period_us()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_table_has_the_objects_where_the_encoder_looks() {
        use crate::devices::wv5800m::Entries;
        for turns in [Turns::Single, Turns::Multi4, Turns::Multi8, Turns::Multi12] {
            assert_eq!(Entries::of(table_of(turns)), table::ENCODER_ENTRIES, "{turns:?}");
        }
        for turns in [Turns::Single, Turns::Multi4, Turns::Multi8, Turns::Multi12] {
            assert_eq!(table::Entries::of(table_of(turns)), table::ENTRIES_OF_MR, "{turns:?}");
        }
        let mr = table::ENTRIES_OF_MR;
        let t = table_of(Turns::Single);
        assert_eq!((t[mr.serial as usize].index, t[mr.serial as usize].sub), (0x1018, 4));
        assert_eq!((t[mr.identity as usize].index, t[mr.identity as usize].sub), (0x3001, 1));
        assert_eq!((t[mr.position_cycle as usize].index, t[mr.position_cycle as usize].sub), (0x3000, 3));
        let at = table::ENCODER_ENTRIES;
        assert_eq!((at.event_timer, at.counters), (crate::encoder::ABSENT, crate::encoder::ABSENT));
        let t = table_of(Turns::Multi12);
        assert_eq!((t[at.cycle_timer as usize].index, t[at.speed as usize].index), (0x6200, 0x6030));
        // What the cyclic groups carry is what the dictionary holds.
        let d = Wv58mr::new(Turns::Multi4);
        let mut od = crate::od::Od::new(d.table(), 0);
        od.set_value(0x6004, 0, 123_456);
        od.set_value(0x6030, 1, -5i16 as u16 as u32);
        assert_eq!(d.process_data(&od), (123_456, -5));
    }

    #[test]
    fn a_channel_serves_the_dictionary_of_its_measuring_range() {
        for turns in [Turns::Single, Turns::Multi4, Turns::Multi8, Turns::Multi12] {
            let d = Wv58mr::new(turns);
            assert!(core::ptr::eq(d.table(), table_of(turns)), "{turns:?}");
            assert_eq!(d.turns(), turns);
            let revolutions = d.table().iter().find(|e| (e.index, e.sub) == (0x6502, 0)).map(|e| e.default_value(0));
            assert_eq!(revolutions, Some(turns.revolutions()), "{turns:?}: 6502h");
        }
    }
}
