//! Progress reporting of long phases, shared by the render driver and the passes it runs.

/// Progress of long phases; the binary draws a bar, tests pass [`NoProgress`].
pub trait Progress: Sync {
    fn start(&self, phase: &str, total: u64);
    fn set(&self, done: u64);
    fn finish(&self);
}

/// Reports nothing.
pub struct NoProgress;

impl Progress for NoProgress {
    fn start(&self, _: &str, _: u64) {}
    fn set(&self, _: u64) {}
    fn finish(&self) {}
}
