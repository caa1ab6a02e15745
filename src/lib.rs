//! superhelix facade
