//! Integration tests of starid-core: one binary (autotests = false), modules by stage.
//!
//! Property-test case counts are modest by default; raise them with
//! `STARID_PROPTEST_CASES=1000 cargo test`.

mod integration;
