//! Spatial algebra (being written).
