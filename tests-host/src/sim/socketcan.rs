//! A Linux SocketCAN raw socket (`vcan0`, `can0` ...), for bridging a simulated bus to a real or
//! virtual kernel CAN interface (`--socketcan BUS=IFACE`).

use std::ffi::CString;
use std::io;
use std::os::fd::{AsRawFd, FromRawFd, OwnedFd};

use od_core::{CanId, Frame};

/// `struct can_frame`'s size.
pub const FRAME_SIZE: usize = 16;

const EFF: u32 = 0x8000_0000;
const RTR: u32 = 0x4000_0000;
const ERR: u32 = 0x2000_0000;

/// A frame as `struct can_frame` (identifier in native byte order).
pub fn encode(frame: &Frame) -> [u8; FRAME_SIZE] {
    let id = match frame.id {
        CanId::Std(id) => id as u32,
        CanId::Ext(id) => id | EFF,
    } | if frame.rtr { RTR } else { 0 };
    let mut b = [0u8; FRAME_SIZE];
    b[..4].copy_from_slice(&id.to_ne_bytes());
    b[4] = frame.len;
    b[8..].copy_from_slice(&frame.data);
    b
}

/// A `struct can_frame`; `None` for an error frame or a length over 8.
pub fn decode(b: &[u8; FRAME_SIZE]) -> Option<Frame> {
    let raw = u32::from_ne_bytes([b[0], b[1], b[2], b[3]]);
    if raw & ERR != 0 || b[4] > 8 {
        return None;
    }
    let id = if raw & EFF != 0 { CanId::Ext(raw & 0x1FFF_FFFF) } else { CanId::Std((raw & 0x7FF) as u16) };
    if raw & RTR != 0 {
        return Some(Frame::remote(id, b[4]));
    }
    Some(Frame::new(id, &b[8..8 + b[4] as usize]))
}

/// A raw CAN socket bound to one interface.
#[derive(Debug)]
pub struct CanSocket {
    fd: OwnedFd,
}

impl CanSocket {
    /// Opens `iface`. Fails where the kernel has no CAN support or the interface is missing.
    pub fn open(iface: &str) -> io::Result<CanSocket> {
        let name =
            CString::new(iface).map_err(|_| io::Error::new(io::ErrorKind::InvalidInput, "bad interface name"))?;
        // SAFETY: plain system calls on values owned here; the descriptor is owned at once.
        let fd = unsafe { libc::socket(libc::PF_CAN, libc::SOCK_RAW, libc::CAN_RAW) };
        if fd < 0 {
            return Err(io::Error::last_os_error());
        }
        // SAFETY: `fd` is a fresh descriptor nobody else owns.
        let fd = unsafe { OwnedFd::from_raw_fd(fd) };
        // SAFETY: `name` is a valid C string.
        let index = unsafe { libc::if_nametoindex(name.as_ptr()) };
        if index == 0 {
            return Err(io::Error::last_os_error());
        }
        // SAFETY: an all-zero sockaddr_can is valid; bind reads `size_of` bytes of it.
        let rc = unsafe {
            let mut addr: libc::sockaddr_can = std::mem::zeroed();
            addr.can_family = libc::AF_CAN as libc::sa_family_t;
            addr.can_ifindex = index as libc::c_int;
            libc::bind(
                fd.as_raw_fd(),
                &addr as *const libc::sockaddr_can as *const libc::sockaddr,
                std::mem::size_of::<libc::sockaddr_can>() as libc::socklen_t,
            )
        };
        if rc < 0 {
            return Err(io::Error::last_os_error());
        }
        Ok(CanSocket { fd })
    }

    /// A second handle on the same socket (one thread reads, another writes).
    pub fn try_clone(&self) -> io::Result<CanSocket> {
        Ok(CanSocket { fd: self.fd.try_clone()? })
    }

    /// Sends a frame.
    pub fn send(&self, frame: &Frame) -> io::Result<()> {
        let b = encode(frame);
        // SAFETY: writes from a buffer of FRAME_SIZE bytes.
        let n = unsafe { libc::write(self.fd.as_raw_fd(), b.as_ptr().cast(), FRAME_SIZE) };
        match n {
            n if n == FRAME_SIZE as isize => Ok(()),
            n if n < 0 => Err(io::Error::last_os_error()),
            _ => Err(io::Error::new(io::ErrorKind::WriteZero, "short CAN frame write")),
        }
    }

    /// Waits for the next frame (error frames are skipped).
    pub fn recv(&self) -> io::Result<Frame> {
        loop {
            let mut b = [0u8; FRAME_SIZE];
            // SAFETY: reads into a buffer of FRAME_SIZE bytes.
            let n = unsafe { libc::read(self.fd.as_raw_fd(), b.as_mut_ptr().cast(), FRAME_SIZE) };
            if n < 0 {
                return Err(io::Error::last_os_error());
            }
            if n as usize == FRAME_SIZE {
                if let Some(f) = decode(&b) {
                    return Ok(f);
                }
            }
        }
    }
}
