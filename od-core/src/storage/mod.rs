//! Parameter storage: the 1010h/1011h groups as a versioned, checksummed image on flash pages,
//! updated so that a power cut at any instant leaves the old or the new image, never a mix.
//!
//! Three layers:
//! - [`image`]: the stored values as records keyed by (index, sub-index) and their byte layout;
//! - [`flash`]: a ring of flash pages over `embedded_storage::nor_flash::NorFlash`, where each
//!   save goes to the next page and counts only once its commit marker is written;
//! - this module: what the node does with them. At power-on the dictionary is built from the
//!   image ([`Loaded`]); a 1010h "save" asks the shell for an `Output::Store`; a 1011h "load"
//!   marks groups whose factory defaults the next NMT reset loads; an NMT reset loads the
//!   stored values back ([`Storage`] keeps them, so a reset never reads flash). The context
//!   ([`crate::context::Context`]) joins these to the outbox and the error conditions.
//!
//! The decisions behind the semantics are in `docs/decisions.md`, "Parameter storage".

pub mod crc;
pub mod flash;
pub mod image;

pub use flash::{ParamFlash, Region, SaveError};
pub use image::{identity, Image, Record};

use crate::abort::Abort;
use crate::od::{CoreHook, Entry, Group, GroupMask, Hook, Od};

/// The 1010h signature "save" (bytes 73h 61h 76h 65h).
pub const SAVE: u32 = 0x6576_6173;
/// The 1011h signature "load" (bytes 6Ch 6Fh 61h 64h).
pub const LOAD: u32 = 0x6461_6F6C;
/// EMCY error code sent after a power-on that found the parameter flash unusable (CiA 301
/// "Data set"); the node runs on factory defaults until a save succeeds.
pub const EMCY_DATA_SET: u16 = 0x6300;
/// Most user-stored entries (groups Comm, App, Manuf) a dictionary may declare.
pub const MAX_STORED: usize = 64;

/// What the parameter flash held at power-on.
// The image is not boxed: no allocation. It lives only while the node powers on.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, PartialEq, Eq, Debug)]
pub enum Loaded {
    /// Never saved: erased, or only a first save that the power cut short. Factory defaults,
    /// nothing to report.
    Blank,
    /// The newest valid image of this device.
    Image(Image),
    /// No valid image of this device, but pages that were committed or not written by us
    /// (corrupt, zeroed, foreign, unknown layout): factory defaults, reported by EMCY
    /// [`EMCY_DATA_SET`].
    Invalid,
}

impl Loaded {
    /// The image, if there is one.
    pub fn image(&self) -> Option<&Image> {
        match self {
            Loaded::Image(i) => Some(i),
            _ => None,
        }
    }
}

/// Is the entry kept in the parameter image (any storage group)?
pub(crate) fn is_stored(e: &Entry) -> bool {
    matches!(e.group, Group::Comm | Group::App | Group::Manuf | Group::Factory)
}

/// Is the entry in a group the user saves and restores (not factory data)?
fn is_user(e: &Entry) -> bool {
    matches!(e.group, Group::Comm | Group::App | Group::Manuf)
}

/// Is the entry the pending node-ID or bit rate (what a reset activates, what LSS stores)?
fn is_pending(e: &Entry) -> bool {
    matches!(e.hook, Hook::Core(CoreHook::PendingNodeId | CoreHook::PendingBitrate))
}

/// Is the entry part of the 1003h error history (a log, not a setting)?
fn is_log(e: &Entry) -> bool {
    e.index == 0x1003
}

/// Does a store of `mask` write the entry?
fn selected(e: &Entry, mask: GroupMask) -> bool {
    (is_user(e) && mask.contains(e.group))
        || (mask.0 & GroupMask::LSS.0 != 0 && is_pending(e))
        || (mask.0 & GroupMask::NODE_ID.0 != 0 && e.hook == Hook::Core(CoreHook::PendingNodeId))
        || (mask.0 & GroupMask::BITRATE.0 != 0 && e.hook == Hook::Core(CoreHook::PendingBitrate))
}

/// The user-stored entries as (slot in [`Storage`], position in the table, entry).
fn user_entries(table: &'static [Entry]) -> impl Iterator<Item = (usize, usize, &'static Entry)> {
    table.iter().enumerate().filter(|(_, e)| is_user(e)).enumerate().map(|(k, (pos, e))| (k, pos, e))
}

/// The node's view of its non-volatile parameters.
#[derive(Clone, Debug)]
pub struct Storage {
    /// What the flash holds for each user-stored entry: the value an NMT reset loads.
    stored: [u32; MAX_STORED],
    /// Bit k: entry k is stored at its default, so it follows the node-ID (COB-IDs "+ node-ID").
    at_default: u64,
    /// Groups a 1011h "load" marked: the next reset loads their factory defaults.
    restore: GroupMask,
    /// The store the shell is performing.
    saving: Option<GroupMask>,
    /// The power-on found no usable image (reported by EMCY until a save succeeds).
    fault: bool,
}

impl Storage {
    /// Groups whose defaults the next reset loads.
    pub fn restore_pending(&self) -> GroupMask {
        self.restore
    }

    /// Did the power-on find the parameter flash unusable (and no save has fixed it yet)?
    pub fn fault(&self) -> bool {
        self.fault
    }

    /// Is a store under way (requested, the shell has not reported yet)?
    pub fn saving(&self) -> bool {
        self.saving.is_some()
    }

    /// Records the current values of the entries `select` picks as the stored ones.
    fn capture(&mut self, od: &Od, node_id: u8, select: impl Fn(&Entry) -> bool) {
        for (k, pos, e) in user_entries(od.table()) {
            if select(e) {
                let value = od.get(pos);
                self.stored[k] = value;
                let bit = 1u64 << k;
                if value == e.default_value(node_id) {
                    self.at_default |= bit;
                } else {
                    self.at_default &= !bit;
                }
            }
        }
    }
}

/// The dictionary and storage state a node powers on with. The node-ID the "+ node-ID"
/// defaults use is the stored pending node-ID (or its default), or `fallback` when the
/// dictionary has no pending node-ID entry. Returns them with that node-ID.
///
/// Panics (at start-up, never on the bus) if the dictionary declares more than
/// [`MAX_STORED`] user-stored entries: a declaration bug every device test catches.
pub(crate) fn power_on(table: &'static [Entry], loaded: &Loaded, fallback: u8) -> (Od, Storage, u8) {
    assert!(user_entries(table).count() <= MAX_STORED, "more stored entries than MAX_STORED");
    let image = loaded.image();
    let node_id = table
        .iter()
        .find(|e| e.hook == Hook::Core(CoreHook::PendingNodeId))
        .map(|e| image.and_then(|i| i.value_for(e)).unwrap_or(e.default_value(0)) as u8)
        .unwrap_or(fallback);
    let mut od = Od::new(table, node_id);
    if let Some(image) = image {
        for (pos, e) in table.iter().enumerate() {
            if let Some(v) = image.value_for(e) {
                od.set(pos, v);
            }
        }
    }
    let mut storage = Storage {
        stored: [0; MAX_STORED],
        at_default: 0,
        restore: GroupMask::default(),
        saving: None,
        fault: *loaded == Loaded::Invalid,
    };
    storage.capture(&od, node_id, |_| true);
    (od, storage, node_id)
}

/// The value of the entry hooked `hook` (the pending node-ID or bit-rate code), if declared.
pub fn pending(od: &Od, hook: CoreHook) -> Option<u32> {
    od.table().iter().position(|e| e.hook == Hook::Core(hook)).map(|pos| od.get(pos))
}

/// The group mask a 1010h/1011h sub-index selects.
pub(crate) fn group_of(od: &Od, pos: usize) -> Result<GroupMask, Abort> {
    GroupMask::from_subindex(od.entry(pos).sub).ok_or(Abort::CANNOT_STORE)
}

impl Storage {
    /// Starts a store of `mask`: one at a time, 08000022h while one is under way.
    pub(crate) fn begin_save(&mut self, mask: GroupMask) -> Result<(), Abort> {
        if self.saving.is_some() {
            return Err(Abort::DEVICE_STATE);
        }
        self.saving = Some(mask);
        Ok(())
    }

    /// Marks `mask` for a restore of its factory defaults at the next reset.
    pub(crate) fn mark_restore(&mut self, mask: GroupMask) {
        self.restore.0 |= mask.0;
    }

    /// The shell finished the store under way: on success the saved values become the ones a
    /// reset loads and a power-on fault is cleared (flash now holds a valid image). A pending
    /// restore stays pending: the next reset still loads the defaults (issue 13 point 10,
    /// D-STO-10). Returns true when it cleared the fault.
    pub(crate) fn finish_save(&mut self, od: &Od, node_id: u8, ok: bool) -> bool {
        let Some(mask) = self.saving.take() else {
            return false;
        };
        if !ok {
            return false;
        }
        self.capture(od, node_id, |e| selected(e, mask));
        core::mem::replace(&mut self.fault, false)
    }

    /// Re-initialises `od` for a reset that reloads `groups` (Reset Node: all of them; Reset
    /// Communication: the communication group): their stored values, except that groups
    /// marked by 1011h get their factory defaults instead, all of them whichever reset it is
    /// (issue 13 point 10, D-STO-10),
    /// on the entries `restores(entry, groups)` picks (the device's
    /// [`crate::device::Device::restores`]). The pending node-ID and bit rate keep their RAM
    /// value (the reset activates it) unless restored; the 1003h history is kept unless
    /// restored. `node_id` is the active node-ID.
    pub(crate) fn reload(
        &mut self,
        od: &mut Od,
        node_id: u8,
        groups: GroupMask,
        restores: impl Fn(&Entry, GroupMask) -> bool,
    ) {
        // Any reset applies a pending restore to every group 1011h named (D-STO-10).
        let restore = self.restore;
        let restored = |e: &Entry| restore.0 != 0 && is_user(e) && restores(e, restore);
        // The pending entries first: the "+ node-ID" defaults use the node-ID the reset activates.
        for (pos, e) in od.table().iter().enumerate() {
            if is_pending(e) && restored(e) {
                od.set(pos, e.default_value(0));
            }
        }
        let id = pending(od, CoreHook::PendingNodeId).map(|v| v as u8).filter(|v| (1..=127).contains(v));
        let id = id.unwrap_or(node_id);
        for (k, pos, e) in user_entries(od.table()) {
            let value = if restored(e) {
                e.default_value(id)
            } else if !groups.contains(e.group) || is_pending(e) || is_log(e) {
                continue;
            } else if self.at_default & (1 << k) != 0 {
                e.default_value(id)
            } else {
                self.stored[k]
            };
            od.set(pos, value);
        }
        self.restore = GroupMask::default();
    }
}

/// What a store reads: the dictionary and the node-ID its "+ node-ID" defaults follow
/// ([`crate::context::Context`] is one).
pub trait Parameters {
    /// The dictionary.
    fn od(&self) -> &Od;
    /// The node-ID the "+ node-ID" defaults follow.
    fn node_id(&self) -> u8;
}

/// Updates `image` (what the flash holds) for a store of `mask`: the selected entries get
/// their current values, every other record stays as stored; factory data is only ever added,
/// never changed. Values equal to their default for `node_id` are left out, so that defaults
/// (notably the COB-IDs "+ node-ID") follow a later node-ID change. Records of entries the
/// dictionary no longer declares, or can no longer take, are dropped.
pub fn merge(image: &mut Image, od: &Od, node_id: u8, mask: GroupMask) -> Result<(), image::Full> {
    image.retain(|r| od.pos(r.index, r.sub).is_some_and(|p| r.fits(od.entry(p))));
    for (pos, e) in od.table().iter().enumerate() {
        let factory = e.group == Group::Factory && image.get(e.index, e.sub).is_none();
        if selected(e, mask) || factory {
            let value = od.get(pos);
            if value == e.default_value(node_id) {
                image.remove(e.index, e.sub);
            } else {
                image.set(Record::of(e, value))?;
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests;
