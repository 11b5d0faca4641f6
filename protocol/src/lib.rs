//! The wire contract between `lrmcal` and the firmware.
#![cfg_attr(not(feature = "use-std"), no_std)]
