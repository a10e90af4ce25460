//! Scheduling: tasks and their work units, shards, checkpoints, merges and
//! plans. No physics.

pub mod allocation;
pub mod assemble;
pub mod bench;
pub mod bench_suite;
pub mod checkpoint;
pub mod grid_bench;
pub mod layout;
pub mod merge;
pub mod out_dir;
pub mod plan;
pub mod shard;
pub mod task;
pub mod task_output;
pub mod work_unit;
