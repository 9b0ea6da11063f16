//! The dictionary access path: what a bus write or read goes through, whichever transport
//! carries it (CANopen SDO, J1939 CAM21/CAM11 SDO, a display's menu). Find the entry, check
//! the access and the value, apply the hook (the context's own rules here, the transport's
//! services through [`Services`], the device's through [`Device::on_write`]), store the value.
//! 1010h "save" and 1011h "load" are commands: their entries keep reading their capabilities,
//! so their value is never stored.

use crate::abort::Abort;
use crate::context::{Context, Written};
use crate::device::Device;
use crate::errors;
use crate::od::{value_of, CoreHook, Hook};
use crate::sdo::{ObjectAccess, MAX_VALUE};
use crate::time::Instant;

/// The rules of the core hooks a transport's services own (CANopen: heartbeat, guarding,
/// 1014h, SYNC and PDO parameters).
pub trait Services {
    /// Checks a write of `value` to entry `pos`, hooked `hook`, and applies its side effect;
    /// on `Ok` the access path stores the value.
    fn write(
        &mut self,
        ctx: &mut Context,
        hook: CoreHook,
        pos: usize,
        value: u32,
        now: Instant,
    ) -> Result<Written, Abort>;

    /// A bus write set the pending bit-rate entry (5F0Ah.02 and alike): CANopen's LSS slave
    /// then lets the next reset adopt it over a rate it configured (D-LSS-15).
    fn pending_bitrate_written(&mut self) {}
}

/// A transport with no services of its own: every service hook is refused (08000000h).
pub struct NoServices;

impl Services for NoServices {
    fn write(&mut self, _: &mut Context, _: CoreHook, _: usize, _: u32, _: Instant) -> Result<Written, Abort> {
        Err(Abort::GENERAL)
    }
}

/// Finds and checks (index, sub) for reading.
#[inline(always)]
fn readable(ctx: &Context, index: u16, sub: u8) -> Result<usize, Abort> {
    let pos = ctx.od.find(index, sub)?;
    ctx.od.check_read(pos)?;
    errors::check_read(&ctx.od, index, sub)?;
    Ok(pos)
}

/// The size of the value at (index, sub), after the read checks.
pub fn read_size(ctx: &Context, index: u16, sub: u8) -> Result<usize, Abort> {
    Ok(ctx.od.entry(readable(ctx, index, sub)?).size())
}

/// The size of the value at (index, sub), whatever its access: what an expedited download
/// without size indication writes (D-SDO-8).
pub fn write_size(ctx: &Context, index: u16, sub: u8) -> Result<usize, Abort> {
    Ok(ctx.od.entry(ctx.od.find(index, sub)?).size())
}

/// The value at (index, sub) into `buf`; returns its size.
pub fn read(ctx: &Context, index: u16, sub: u8, buf: &mut [u8]) -> Result<usize, Abort> {
    Ok(ctx.od.encode(readable(ctx, index, sub)?, buf))
}

/// The value at (index, sub) when it is a number (4 bytes or fewer): its bytes and size;
/// `Ok(None)` for a string.
#[inline(always)]
pub fn read_short(ctx: &Context, index: u16, sub: u8) -> Result<Option<([u8; 4], usize)>, Abort> {
    let pos = readable(ctx, index, sub)?;
    let e = ctx.od.entry(pos);
    if e.string_value().is_some() {
        return Ok(None);
    }
    Ok(Some((ctx.od.get(pos).to_le_bytes(), e.dtype.size())))
}

/// Checks and writes `data` to (index, sub). Nothing changes on `Err`.
#[inline]
pub fn write(
    ctx: &mut Context,
    device: &mut impl Device,
    services: &mut impl Services,
    index: u16,
    sub: u8,
    data: &[u8],
    now: Instant,
) -> Result<Written, Abort> {
    write_value(ctx, device, services, index, sub, value_of(data), data.len(), now)
}

/// [`write()`] of `len` bytes whose first four (at most) are `value` ([`value_of`]).
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn write_value(
    ctx: &mut Context,
    device: &mut impl Device,
    services: &mut impl Services,
    index: u16,
    sub: u8,
    value: u32,
    len: usize,
    now: Instant,
) -> Result<Written, Abort> {
    let pos = ctx.od.find(index, sub)?;
    let value = ctx.od.check_value(pos, value, len)?;
    let hook = ctx.od.entry(pos).hook;
    let written = match hook {
        Hook::None => Written::Done,
        Hook::Core(hook) => core_write(ctx, services, hook, pos, value, now)?,
        Hook::Device(_) => {
            if let Some(link) = device.link(ctx.od.entry(pos)) {
                let target = ctx.od.pos(link.index, link.sub).ok_or(Abort::GENERAL)?;
                core_write(ctx, services, link.hook, target, value, now)?;
                ctx.od.set(target, value);
            }
            device.on_write_deferred(ctx, pos, value, now)?
        }
    };
    if !matches!(hook, Hook::Core(CoreHook::Store | CoreHook::Restore)) {
        ctx.od.set(pos, value);
    }
    Ok(written)
}

/// The rules of a core hook: the context's own (storage, error history, pending node-ID and
/// bit rate), else the transport's.
#[inline(always)]
fn core_write(
    ctx: &mut Context,
    services: &mut impl Services,
    hook: CoreHook,
    pos: usize,
    value: u32,
    now: Instant,
) -> Result<Written, Abort> {
    match hook {
        CoreHook::Store => ctx.on_store(pos, value),
        CoreHook::Restore => ctx.on_restore(pos, value),
        CoreHook::ErrorHistory => errors::clear_history(&mut ctx.od, pos, value).map(|()| Written::Done),
        // 5F0Ah and alike hold the pending node-ID and bit-rate code: storing the value (its
        // range is the entry's limits) is the whole write; the next reset activates it.
        CoreHook::PendingNodeId => Ok(Written::Done),
        CoreHook::PendingBitrate => {
            services.pending_bitrate_written();
            Ok(Written::Done)
        }
        _ => services.write(ctx, hook, pos, value, now),
    }
}

/// The dictionary as an SDO server sees it: the access path over a context, a device and a
/// transport's services.
pub struct Access<'a, D, S> {
    /// The context.
    pub ctx: &'a mut Context,
    /// The device.
    pub device: &'a mut D,
    /// The transport's services.
    pub services: &'a mut S,
}

impl<D: Device, S: Services> ObjectAccess for Access<'_, D, S> {
    fn read_size(&mut self, index: u16, sub: u8) -> Result<usize, Abort> {
        read_size(self.ctx, index, sub)
    }

    #[inline(always)]
    fn read_value(&mut self, index: u16, sub: u8, buf: &mut [u8; MAX_VALUE]) -> Result<(u32, usize), Abort> {
        let pos = readable(self.ctx, index, sub)?;
        let e = self.ctx.od.entry(pos);
        match e.string_value() {
            Some(s) => {
                buf[..s.len()].copy_from_slice(s);
                Ok((value_of(s), s.len()))
            }
            None => Ok((self.ctx.od.get(pos), e.dtype.size())),
        }
    }

    fn read(&mut self, index: u16, sub: u8, buf: &mut [u8]) -> Result<usize, Abort> {
        read(self.ctx, index, sub, buf)
    }

    fn write(&mut self, index: u16, sub: u8, data: &[u8], now: Instant) -> Result<Written, Abort> {
        self.write_value(index, sub, value_of(data), data.len(), now)
    }

    #[inline]
    fn write_value(&mut self, index: u16, sub: u8, value: u32, len: usize, now: Instant) -> Result<Written, Abort> {
        write_value(self.ctx, self.device, self.services, index, sub, value, len, now)
    }

    fn write_size(&mut self, index: u16, sub: u8) -> Result<usize, Abort> {
        write_size(self.ctx, index, sub)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bitrate::Bitrate;
    use crate::device::Link;
    use crate::od::{Access::*, DataType::*, Entry};
    use crate::storage::{self, Loaded};

    static T: &[Entry] = &[
        Entry::array(0x1010, "Store parameters", 1, Const),
        Entry::member(0x1010, 1, "Save all parameters", Unsigned32, Rw, 1).hook(Hook::Core(CoreHook::Store)),
        Entry::var(0x1017, "Producer heartbeat time", Unsigned16, Rw, 0).hook(Hook::Core(CoreHook::HeartbeatTime)),
        Entry::var(0x2000, "Linked", Unsigned16, Rw, 0).hook(Hook::Device(1)),
        Entry::var(0x2001, "Plain", Unsigned8, Rw, 0),
    ];

    /// A device whose 2000h is linked to 1017h under the heartbeat rule.
    struct Dev {
        writes: u32,
    }
    impl Device for Dev {
        fn table(&self) -> &'static [crate::od::Entry] {
            T
        }
        fn link(&self, e: &Entry) -> Option<Link> {
            (e.index == 0x2000).then_some(Link { index: 0x1017, sub: 0, hook: CoreHook::HeartbeatTime })
        }
        fn on_write(&mut self, _: &mut Context, _: usize, _: u32, _: Instant) -> Result<(), Abort> {
            self.writes += 1;
            Ok(())
        }
    }

    /// A transport whose one rule refuses 1..9 and records what it accepted.
    #[derive(Default)]
    struct Rules {
        seen: heapless::Vec<(CoreHook, u32), 4>,
    }
    impl Services for Rules {
        fn write(
            &mut self,
            _: &mut Context,
            hook: CoreHook,
            _: usize,
            value: u32,
            _: Instant,
        ) -> Result<Written, Abort> {
            if (1..10).contains(&value) {
                return Err(Abort::INVALID_VALUE);
            }
            self.seen.push((hook, value)).unwrap();
            Ok(Written::Done)
        }
    }

    fn ctx() -> Context {
        let (od, storage, _) = storage::power_on(T, &Loaded::Blank, 1);
        Context::new(od, storage, 1, Bitrate::K500)
    }

    #[test]
    fn links_run_the_linked_rule_first_and_store_both() {
        let (mut c, mut d, mut r) = (ctx(), Dev { writes: 0 }, Rules::default());
        let now = Instant::ZERO;
        assert_eq!(write(&mut c, &mut d, &mut r, 0x2000, 0, &[5, 0], now), Err(Abort::INVALID_VALUE));
        assert_eq!((c.od.value(0x2000, 0), c.od.value(0x1017, 0), d.writes), (Some(0), Some(0), 0), "refused whole");
        assert_eq!(write(&mut c, &mut d, &mut r, 0x2000, 0, &[100, 0], now), Ok(Written::Done));
        assert_eq!((c.od.value(0x2000, 0), c.od.value(0x1017, 0), d.writes), (Some(100), Some(100), 1));
        assert_eq!(r.seen.as_slice(), &[(CoreHook::HeartbeatTime, 100)]);
        assert_eq!(write(&mut c, &mut d, &mut r, 0x2001, 0, &[7], now), Ok(Written::Done));
        assert_eq!(r.seen.len(), 1, "no hook, no rule");
    }

    #[test]
    fn save_is_a_command_not_a_value() {
        let (mut c, mut d, mut r) = (ctx(), Dev { writes: 0 }, Rules::default());
        let now = Instant::ZERO;
        assert_eq!(write(&mut c, &mut d, &mut r, 0x1010, 1, b"save", now), Ok(Written::Deferred));
        assert_eq!(c.od.value(0x1010, 1), Some(1), "still reads its capabilities");
        assert_eq!(c.out.pop(), Some(crate::context::Output::Store(crate::od::GroupMask::ALL)));
        assert_eq!(write(&mut c, &mut d, &mut r, 0x1010, 1, b"save", now), Err(Abort::DEVICE_STATE));
        assert_eq!(write(&mut c, &mut d, &mut r, 0x3000, 0, &[1], now), Err(Abort::NO_OBJECT));
        assert_eq!(read_short(&c, 0x1017, 0), Ok(Some(([0, 0, 0, 0], 2))));
        assert!(r.seen.is_empty());
    }
}
