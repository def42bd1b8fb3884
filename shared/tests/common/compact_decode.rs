// Included by `common/mod.rs` and by the host's compact-encoder tests (`include!`), so that
// both decode streams the same way.

/// Decodes a whole compact stream (SPEC.md §5.12) fed in chunks of `chunk` bytes.
pub fn decode_compact(stream: &[u8], chunk: usize) -> Result<Vec<u8>, gridrt_shared::scene::SceneError> {
    let mut u: Box<gridrt_shared::scene::Unpacker<4096>> = Box::default();
    let mut out = Vec::new();
    for c in stream.chunks(chunk.max(1)) {
        u.feed(c, &mut |b, _| {
            out.extend_from_slice(b);
            Ok(())
        })?;
    }
    u.finish()?;
    Ok(out)
}
