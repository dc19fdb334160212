//! Integration tests of starid-core: one binary (autotests = false), modules by stage.
//!
//! Property-test case counts are modest by default; raise them with
//! `STARID_PROPTEST_CASES=1000 cargo test`; the seed is fixed for reproducible CI runs, and
//! `STARID_PROPTEST_SEED=random` (or a number) explores further.

mod integration;
