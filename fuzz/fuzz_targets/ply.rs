//! Any bytes as a PLY file: a mesh or an error, never a panic, hang or runaway allocation.
#![no_main]
use libfuzzer_sys::fuzz_target;
use nlos_rs::geometry::mesh::Mesh;

fuzz_target!(|data: &[u8]| {
    if let Ok(mut m) = Mesh::parse_ply(data, std::path::Path::new("fuzz.ply")) {
        m.recompute_vertex_normals();
    }
});
