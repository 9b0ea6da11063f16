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
use crate::od::{CoreHook, Default, Hook};
use crate::sdo::ObjectAccess;
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
}

/// A transport with no services of its own: every service hook is refused (08000000h).
pub struct NoServices;

impl Services for NoServices {
    fn write(&mut self, _: &mut Context, _: CoreHook, _: usize, _: u32, _: Instant) -> Result<Written, Abort> {
        Err(Abort::GENERAL)
    }
}

/// Finds and checks (index, sub) for reading.
#[inline]
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

/// The value at (index, sub) into `buf`; returns its size.
pub fn read(ctx: &Context, index: u16, sub: u8, buf: &mut [u8]) -> Result<usize, Abort> {
    Ok(ctx.od.encode(readable(ctx, index, sub)?, buf))
}

/// The value at (index, sub) when it is a number (4 bytes or fewer): its bytes and size;
/// `Ok(None)` for a string.
#[inline]
pub fn read_short(ctx: &Context, index: u16, sub: u8) -> Result<Option<([u8; 4], usize)>, Abort> {
    let pos = readable(ctx, index, sub)?;
    let e = ctx.od.entry(pos);
    if matches!(e.default, Default::Str(_)) {
        return Ok(None);
    }
    Ok(Some((ctx.od.get(pos).to_le_bytes(), e.dtype.size())))
}

/// Checks and writes `data` to (index, sub). Nothing changes on `Err`.
pub fn write(
    ctx: &mut Context,
    device: &mut impl Device,
    services: &mut impl Services,
    index: u16,
    sub: u8,
    data: &[u8],
    now: Instant,
) -> Result<Written, Abort> {
    let pos = ctx.od.find(index, sub)?;
    let value = ctx.od.check_write(pos, data)?;
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
            device.on_write(ctx, pos, value, now)?;
            Written::Done
        }
    };
    if !matches!(hook, Hook::Core(CoreHook::Store | CoreHook::Restore)) {
        ctx.od.set(pos, value);
    }
    Ok(written)
}

/// The rules of a core hook: the context's own (storage, error history, pending node-ID and
/// bit rate), else the transport's.
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
        CoreHook::PendingNodeId | CoreHook::PendingBitrate => Ok(Written::Done),
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

    #[inline]
    fn read_short(&mut self, index: u16, sub: u8) -> Result<Option<([u8; 4], usize)>, Abort> {
        read_short(self.ctx, index, sub)
    }

    fn read(&mut self, index: u16, sub: u8, buf: &mut [u8]) -> Result<usize, Abort> {
        read(self.ctx, index, sub, buf)
    }

    fn write(&mut self, index: u16, sub: u8, data: &[u8], now: Instant) -> Result<Written, Abort> {
        write(self.ctx, self.device, self.services, index, sub, data, now)
    }
}
