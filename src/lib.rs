//! fmsr
