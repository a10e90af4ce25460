//! Files in and out: CSV tables, OpenEXR images, PNG previews and their
//! colour (CIE 1931 to sRGB); every file written atomically.

pub mod atomic;
pub mod canvas;
pub mod exr;
pub mod output;
pub mod preview;
pub mod sky_image;
pub mod srgb;
pub mod sun_table;
