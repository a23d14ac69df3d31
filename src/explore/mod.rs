//! `tacsim run`'s side of the closed loop (the loop itself is the `tacsim-explore` crate):
//! [`learned`] supplies the loop's learned perception with the `tacsim-model` networks, and
//! [`report`] writes the JSON report, the table and the plots.

pub mod learned;
pub mod report;
