//! Files in and out: CSV tables, OpenEXR images, PNG previews; every file written atomically.

pub mod exr;
pub mod output;
pub mod preview;
pub mod sun_table;
