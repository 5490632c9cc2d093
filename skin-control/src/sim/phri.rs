//! phri
