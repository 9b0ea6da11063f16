//! SDO abort codes (CiA 301 §7.2.4.3.17). Every refusal the dictionary or a service gives
//! is one of these, so the SDO server can put it on the bus unchanged.

/// A CiA 301 SDO abort code.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Abort(pub u32);

impl Abort {
    /// Toggle bit not alternated.
    pub const TOGGLE: Abort = Abort(0x0503_0000);
    /// SDO protocol timed out.
    pub const TIMEOUT: Abort = Abort(0x0504_0000);
    /// Client/server command specifier not valid or unknown.
    pub const INVALID_COMMAND: Abort = Abort(0x0504_0001);
    /// Unsupported access to an object.
    pub const UNSUPPORTED_ACCESS: Abort = Abort(0x0601_0000);
    /// Attempt to read a write-only object.
    pub const WRITE_ONLY: Abort = Abort(0x0601_0001);
    /// Attempt to write a read-only (or constant) object.
    pub const READ_ONLY: Abort = Abort(0x0601_0002);
    /// Object does not exist in the object dictionary.
    pub const NO_OBJECT: Abort = Abort(0x0602_0000);
    /// Object cannot be mapped to the PDO.
    pub const NOT_MAPPABLE: Abort = Abort(0x0604_0041);
    /// The number and length of the objects to be mapped would exceed the PDO length.
    pub const PDO_LENGTH: Abort = Abort(0x0604_0042);
    /// General parameter incompatibility.
    pub const INCOMPATIBLE: Abort = Abort(0x0604_0043);
    /// Access failed due to a hardware error.
    pub const HARDWARE: Abort = Abort(0x0606_0000);
    /// Data type does not match, length of service parameter does not match.
    pub const LENGTH_MISMATCH: Abort = Abort(0x0607_0010);
    /// Data type does not match, length of service parameter too high.
    pub const LENGTH_HIGH: Abort = Abort(0x0607_0012);
    /// Data type does not match, length of service parameter too low.
    pub const LENGTH_LOW: Abort = Abort(0x0607_0013);
    /// Sub-index does not exist.
    pub const NO_SUBINDEX: Abort = Abort(0x0609_0011);
    /// Invalid value for parameter (download only).
    pub const INVALID_VALUE: Abort = Abort(0x0609_0030);
    /// Value of parameter written too high.
    pub const VALUE_HIGH: Abort = Abort(0x0609_0031);
    /// Value of parameter written too low.
    pub const VALUE_LOW: Abort = Abort(0x0609_0032);
    /// General error.
    pub const GENERAL: Abort = Abort(0x0800_0000);
    /// Data cannot be transferred or stored to the application.
    pub const CANNOT_STORE: Abort = Abort(0x0800_0020);
    /// ... because of local control.
    pub const LOCAL_CONTROL: Abort = Abort(0x0800_0021);
    /// ... because of the present device state.
    pub const DEVICE_STATE: Abort = Abort(0x0800_0022);
    /// No data available.
    pub const NO_DATA: Abort = Abort(0x0800_0024);
}
