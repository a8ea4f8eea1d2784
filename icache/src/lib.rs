//! icache (placeholder)
