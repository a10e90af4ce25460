//! Files in and out: CSV tables, OpenEXR images, PNG previews; every file
//! written atomically.

pub mod atomic;
pub mod canvas;
pub mod exr;
pub mod output;
pub mod preview;
pub mod sky_image;
pub mod sun_table;
