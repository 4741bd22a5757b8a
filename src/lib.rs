//! laydown: single-fibre laydown on a moving belt, curvature spectra, stochastic
//! nonwoven webs and their uniformity, after Battocchio & Sutcliffe.
pub mod geometry;
pub mod stages;
pub mod uniformity;
