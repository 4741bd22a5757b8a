//! Web stage numerics.
