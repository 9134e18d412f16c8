// The flat indices of a dispatch over 256-wide workgroups, 2D past the adapter's
// workgroups per dimension (gpu::Gpu::groups): an invocation's, and a workgroup's.
fn index(gid: vec3<u32>, nwg: vec3<u32>) -> u32 {
    return gid.x + gid.y * nwg.x * 256u;
}

fn group_index(wid: vec3<u32>, nwg: vec3<u32>) -> u32 {
    return wid.x + wid.y * nwg.x;
}
