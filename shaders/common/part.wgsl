// The part of the neighbour lists a dispatch runs on (src/gpu/parts.rs): its first
// particle and its rows. The `offsets`, `ids` and per-pair buffers bound with it are the
// part's: row k is particle part.first + k, and a pair index counts from the part's first
// pair.

struct Part {
    first: u32,
    rows: u32,
}

@group(0) @binding(15) var<uniform> part: Part;
