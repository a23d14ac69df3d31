//! The contact problems: the normal (Polonsky-Keer) and tangential (Kalker) solves, and a
//! step's alternation of the two on a coupled material.
pub(super) mod coupled;
pub(super) mod normal;
pub(super) mod tangential;
