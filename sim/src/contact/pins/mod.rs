//! The pins: how the loaded cells' forces move each pin's tip.
pub(super) mod motion;
