//! Integration tests of starid-core.
