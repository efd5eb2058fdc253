//! Integration tests: hb.
