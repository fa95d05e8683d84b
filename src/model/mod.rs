//! The generated Suslov model (work in progress).
