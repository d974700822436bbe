//! Any bytes as an OBJ file: a mesh or an error, never a panic, hang or runaway allocation.
#![no_main]
use libfuzzer_sys::fuzz_target;
use nlos_rs::geometry::mesh::Mesh;

fuzz_target!(|data: &[u8]| {
    if let Ok(mut m) = Mesh::parse_obj(data, std::path::Path::new("fuzz.obj")) {
        m.recompute_vertex_normals();
    }
});
