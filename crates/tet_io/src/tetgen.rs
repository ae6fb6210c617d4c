//! TetGen reader (in progress).
