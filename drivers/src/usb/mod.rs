//! placeholder
#[cfg(feature = "hardware")]
mod device;
#[cfg(feature = "hardware")]
pub mod footswitch;
pub mod hid_keys;
pub mod id;
pub mod lightcrafter;
#[cfg(feature = "hardware")]
pub mod transport;
pub use id::UsbId;
