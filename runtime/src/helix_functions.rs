//! helix_functions
