//! Parameter storage: the 1010h/1011h groups as a versioned, checksummed image on flash pages,
//! updated so that a power cut at any instant leaves the old or the new image, never a mix.
//!
//! Three layers:
//! - [`image`]: the stored values as records keyed by (index, sub-index) and their byte layout;
//! - [`flash`]: a ring of flash pages over `embedded_storage::nor_flash::NorFlash`: a save
//!   appends the records it changes to the newest page's log and counts only once the entry's
//!   commit unit is written; a page is erased only when the newest one is full, to start again
//!   with the whole image;
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
// [`Storage`] keeps table positions in a byte.
const _: () = assert!(crate::od::MAX_ENTRIES <= 256);

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

/// The bits of the user groups (Comm, App, Manuf) in a [`GroupMask`].
const USER_GROUPS: u8 = GroupMask::ALL.0;

/// The group's bit in a [`GroupMask`] if it is a user group (Comm, App, Manuf), else 0: the
/// bit of group n is 1 << (n - 1), computed rather than looked up through [`Group::bit`].
fn user_bit(g: Group) -> u8 {
    ((1u32 << g as u32) >> 1) as u8 & USER_GROUPS
}

/// Does a store of `mask` write the entry?
fn selected(e: &Entry, mask: GroupMask) -> bool {
    // A user entry in a selected group: its group's bit is in the mask (Factory's and None's
    // bits are outside USER_GROUPS); the pending node-ID and bit rate by the bits naming them.
    let by_hook = match e.hook {
        Hook::Core(CoreHook::PendingNodeId) => GroupMask::LSS.0 | GroupMask::NODE_ID.0,
        Hook::Core(CoreHook::PendingBitrate) => GroupMask::LSS.0 | GroupMask::BITRATE.0,
        _ => 0,
    };
    (user_bit(e.group) | by_hook) & mask.0 != 0
}

/// The node's view of its non-volatile parameters.
#[derive(Clone, Debug)]
pub struct Storage {
    /// Position in the table of each user-stored entry (slot k of `stored`).
    slots: [u8; MAX_STORED],
    /// Number of user-stored entries.
    count: usize,
    /// What the flash holds for each user-stored entry: the value an NMT reset loads.
    stored: [u32; MAX_STORED],
    /// Bit k % 32 of word k / 32: entry k is stored at its default, so it follows the node-ID
    /// (COB-IDs "+ node-ID"). Words of 32 bits: a 64-bit shift by a variable is long code on
    /// the Cortex-M3.
    at_default: [u32; MAX_STORED / 32],
    /// Groups a 1011h "load" marked: the next reset loads their factory defaults.
    restore: GroupMask,
    /// The node-ID every entry's `at_default` bit was computed for (`None`: not all the same).
    captured_id: Option<u8>,
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

    /// Records the current values of the entries a store of `mask` writes (every user-stored
    /// entry with `None`) as the stored ones. While every entry's `at_default` is known for this
    /// node-ID, an entry whose value is the one recorded is left as it is: only a changed value
    /// needs its default compared.
    fn capture(&mut self, od: &Od, node_id: u8, mask: Option<GroupMask>) {
        let all = mask.is_none_or(|m| m.0 & USER_GROUPS == USER_GROUPS);
        let known = self.captured_id == Some(node_id);
        for k in 0..self.count.min(MAX_STORED) {
            let pos = self.slots[k] as usize;
            let value = od.get(pos);
            if known && value == self.stored[k] {
                continue;
            }
            let e = od.entry(pos);
            if !all && !mask.is_some_and(|m| selected(e, m)) {
                continue;
            }
            self.stored[k] = value;
            let (word, bit) = (&mut self.at_default[k / 32], 1 << (k % 32));
            if value == od.default_of(e, node_id) {
                *word |= bit;
            } else {
                *word &= !bit;
            }
        }
        self.captured_id = if all || known { Some(node_id) } else { None };
    }
}

/// The dictionary and storage state a node powers on with. The node-ID the "+ node-ID"
/// defaults use is the stored pending node-ID (or its default), or `fallback` when the
/// dictionary has no pending node-ID entry. Returns them with that node-ID. (The nodes build
/// theirs in place, [`power_on_in`]; the unit tests build a context with this.)
///
/// Panics (at start-up, never on the bus) if the dictionary declares more than
/// [`MAX_STORED`] user-stored entries: a declaration bug every device test catches.
#[cfg(test)]
pub(crate) fn power_on(table: &'static [Entry], loaded: &Loaded, fallback: u8) -> (Od, Storage, u8) {
    let mut od = Od::blank(table, None);
    let mut storage = Storage::empty(loaded);
    let node_id = power_on_in(&mut od, &mut storage, loaded, fallback);
    (od, storage, node_id)
}

impl Storage {
    /// No user-stored entry yet, nothing to restore or save; the fault says whether `loaded`
    /// found the flash unusable. What [`power_on_in`] fills.
    pub(crate) fn empty(loaded: &Loaded) -> Storage {
        Storage {
            slots: [0; MAX_STORED],
            count: 0,
            stored: [0; MAX_STORED],
            at_default: [0; MAX_STORED / 32],
            restore: GroupMask::default(),
            captured_id: None,
            saving: None,
            fault: matches!(loaded, Loaded::Invalid),
        }
    }
}

/// The dictionary and storage state a node powers on with, filled in place (the node is built
/// where it lives, not assembled in locals and copied): the blank dictionary `od`
/// ([`Od::blank`], the variant's factory node-ID in it) gets every default, then the values
/// `loaded` holds; the empty `storage` ([`Storage::empty`]) the user-stored entries and their
/// stored values. The node-ID the "+ node-ID" defaults use is the stored pending node-ID (or
/// its default), or `fallback` when the dictionary has no pending node-ID entry; returned.
///
/// Panics (at start-up, never on the bus) if the dictionary declares more than
/// [`MAX_STORED`] user-stored entries: a declaration bug every device test catches.
#[inline(never)]
pub(crate) fn power_on_in(od: &mut Od, storage: &mut Storage, loaded: &Loaded, fallback: u8) -> u8 {
    let table = od.table();
    let image = loaded.image();
    let node_id = table
        .iter()
        .find(|e| e.hook == Hook::Core(CoreHook::PendingNodeId))
        .map(|e| image.and_then(|i| i.value_for(e)).unwrap_or(od.default_of(e, 0)) as u8)
        .unwrap_or(fallback);
    // One walk of the table: the stored value or else the default into the dictionary, the
    // user-stored entries' positions into the slots.
    for (pos, e) in table.iter().enumerate() {
        let value = image.and_then(|i| i.value_for(e));
        od.set(pos, value.unwrap_or_else(|| od.default_of(e, node_id)));
        if is_user(e) {
            // MAX_ENTRIES (160) positions fit a byte; slot MAX_STORED panics.
            storage.slots[storage.count] = pos as u8;
            storage.count += 1;
        }
    }
    storage.capture(od, node_id, None);
    node_id
}

/// The value of the entry hooked `hook` (the pending node-ID or bit-rate code), if declared.
pub fn pending(od: &Od, hook: CoreHook) -> Option<u32> {
    od.table().iter().position(|e| e.hook == Hook::Core(hook)).map(|pos| od.get(pos))
}

/// The group mask a 1010h/1011h sub-index selects (`None`: the sub-index selects none, which
/// the caller answers 08000020h). An `Option` of one byte comes back in a register, where a
/// `Result` with the abort code would go through memory.
#[inline]
pub(crate) fn group_of(od: &Od, pos: usize) -> Option<GroupMask> {
    GroupMask::from_subindex(od.entry(pos).sub)
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
        self.capture(od, node_id, Some(mask));
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
        // (Only user entries are restored: the slots are theirs.)
        let restored = |e: &Entry| restore.0 != 0 && restores(e, restore);
        let slots = &self.slots[..self.count.min(MAX_STORED)];
        // The pending entries first: the "+ node-ID" defaults use the node-ID the reset activates.
        for &pos in slots {
            let e = od.entry(pos as usize);
            if is_pending(e) && restored(e) {
                od.set(pos as usize, od.default_of(e, 0));
            }
        }
        let id = pending(od, CoreHook::PendingNodeId).map(|v| v as u8).filter(|v| (1..=127).contains(v));
        let id = id.unwrap_or(node_id);
        for (k, &pos) in slots.iter().enumerate() {
            let (pos, e) = (pos as usize, od.entry(pos as usize));
            let value = if restored(e) {
                od.default_of(e, id)
            } else if !groups.contains(e.group) || is_pending(e) || is_log(e) {
                continue;
            } else if self.at_default[k / 32] & 1 << (k % 32) != 0 {
                od.default_of(e, id)
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
    let mut merged = Image::new();
    merge_into(image.records(), &mut merged, &mut Log::new(), od, &Storable::of(od.table()), node_id, mask)?;
    *image = merged;
    Ok(())
}

/// The key of an entry or record as one number: index << 8 | sub-index.
fn key(index: u16, sub: u8) -> u32 {
    (index as u32) << 8 | sub as u32
}

/// Most records one log entry holds: a save that changes more starts a new page.
pub(crate) const LOG_MAX: usize = 32;
/// The records of one log entry, and room for one more: a log holding more than [`LOG_MAX`]
/// says that the save changed too many for one entry (no count kept beside it).
pub(crate) type Log = heapless::Vec<Record, { LOG_MAX + 1 }>;

/// Adds `r` to `log` if it has room (one call, rather than the push at each place).
#[inline(never)]
fn note(log: &mut Log, r: Record) {
    let _ = log.push(r);
}

/// The table positions of the entries a store may write (a storage group, or a pending
/// node-ID or bit rate), as a bit set: what [`merge_into`] walks instead of the whole table.
#[derive(Clone, Debug)]
pub(crate) struct Storable {
    /// The table it was made for.
    pub(crate) table: &'static [Entry],
    bits: [u32; crate::od::MAX_ENTRIES.div_ceil(32)],
}

impl Storable {
    /// The storable entries of `table` (at most [`crate::od::MAX_ENTRIES`], as `Od::new`
    /// checks).
    pub(crate) fn of(table: &'static [Entry]) -> Storable {
        let mut bits = [0u32; crate::od::MAX_ENTRIES.div_ceil(32)];
        for (pos, e) in table.iter().enumerate() {
            if let (true, Some(word)) = (is_stored(e) || is_pending(e), bits.get_mut(pos / 32)) {
                *word |= 1 << (pos % 32);
            }
        }
        Storable { table, bits }
    }
}

/// [`merge`] of the records `olds` into the empty `new`: one pass over the storable entries
/// and the old records side by side (both sorted by index and sub-index). The keys that changed
/// (records added, changed or dropped) go to `log` as far as it has room (a removal for a
/// record dropped): the records a log entry of this save holds, unless the log is full.
pub(crate) fn merge_into(
    olds: &[Record],
    new: &mut Image,
    log: &mut Log,
    od: &Od,
    storable: &Storable,
    node_id: u8,
    mask: GroupMask,
) -> Result<(), image::Full> {
    let table = od.table();
    let mut i = 0;
    for (w, &word) in storable.bits.iter().enumerate() {
        let mut bits = word;
        while bits != 0 {
            let pos = w * 32 + bits.trailing_zeros() as usize;
            bits &= bits - 1;
            let Some(e) = table.get(pos) else { continue };
            let k = key(e.index, e.sub);
            let mut stored = None;
            while let Some(r) = olds.get(i) {
                let rk = key(r.index, r.sub);
                if rk > k {
                    break;
                }
                i += 1;
                if rk == k {
                    stored = Some(r);
                    break;
                }
                // A record of a key the dictionary does not declare, or does not store: dropped.
                note(log, Record::removal(r.index, r.sub));
            }
            // The value the image keeps for the entry, if any: a selected entry's current value;
            // else the stored one, kept if it fits (factory data that does not fit is replaced
            // by the current value: factory data is only ever added).
            let take = selected(e, mask);
            let old = stored.filter(|_| !take);
            let fits = old.is_some_and(|r| r.fits(e));
            let factory = e.group == Group::Factory;
            let (value, keep) = match old {
                Some(r) if fits || !factory => (r.value, fits),
                _ if take || factory => {
                    let value = od.get(pos);
                    (value, value != od.default_of(e, node_id))
                }
                _ => (0, false),
            };
            match (keep, stored) {
                (false, None) => {}
                (true, Some(r)) if *r == Record::of(e, value) => new.push(*r)?,
                _ => {
                    let record = if keep { Record::of(e, value) } else { Record::removal(e.index, e.sub) };
                    note(log, record);
                    if keep {
                        new.push(record)?;
                    }
                }
            }
        }
    }
    for r in &olds[i..] {
        note(log, Record::removal(r.index, r.sub));
    }
    Ok(())
}

#[cfg(test)]
mod tests;
