//! Grid stage numerics.
