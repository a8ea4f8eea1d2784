//! gather (placeholder)
