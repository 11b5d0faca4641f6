//! Hardware-independent firmware logic.
#![cfg_attr(not(test), no_std)]
