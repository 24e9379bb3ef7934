//! Reliability measured at random (issue: every setting a user can reach,
//! randomised): the plugins' settings over their whole type range on the
//! CPU twins, and accepted ones drawn on lavapipe.

mod renders;
mod settings;
